"""LIGGGHTS' output read as a LIGGGHTS user writes it (tests/decks/pile_liggghts.lig, run
by Debian's ``liggghts``): a bidisperse Hertz pile at rest, periodic in x and y, on a
mesh floor (its contacts from compute wall/gran/local) or a primitive one (its force
per atom, store_force yes), and the same pile flowing down a 30 degree incline.

Checked against physics (the weight above each bulk slab; the momentum balance), an
independent recomputation from the raw LIGGGHTS columns, and the same run's VTK atom
dumps."""

import logging
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import granavg
from granavg.io.profiles_io import read_profiles

from .helpers import DECKS, cli, frame_lines, last_rows

pytestmark = [
    pytest.mark.skipif(shutil.which("liggghts") is None,
                       reason="liggghts not installed: apt-get install -y liggghts"),
    pytest.mark.slow]

L = 0.016                        # the box's x and y edges (m)
SLABS = dict(slabs="z", range=(0.0, 0.048), bins=8)       # 6 mm: 2.5 large diameters
G = 9.81
KEYWORDS = "pos id force delta"


def run_deck(out: Path, **variables) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    args = ["liggghts", "-in", str(DECKS / "pile_liggghts.lig"), "-log", "none", "-echo",
            "none", "-var", "out", str(out), "-var", "stl", str(DECKS / "floor_liggghts.stl")]
    for k, v in variables.items():
        args += ["-var", k, str(v)]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and (out / "contacts.dump").exists(), proc.stdout[-2000:]
    return out


@pytest.fixture(scope="module")
def mesh(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("liggghts_mesh"))


@pytest.fixture(scope="module")
def primitive(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("liggghts_primitive"), mesh=0)


@pytest.fixture(scope="module")
def flowing(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("liggghts_flowing"), tilt=30)


@pytest.fixture(scope="module")
def flowing_split(tmp_path_factory):
    """The flowing pile again, its pair contacts dumped as force_normal and
    force_tangential (the same trajectory: a compute does not change the run)."""
    return run_deck(tmp_path_factory.mktemp("liggghts_flowing_split"), tilt=30, split=1)


def average(run, *, walls=True, keywords=KEYWORDS, **options):
    """granavg.average of a LIGGGHTS run's text dumps over the 6-mm slabs."""
    more = dict(wall_contacts=run / "walls.dump", wall_keywords=KEYWORDS) if walls else {}
    return granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                           liggghts=keywords, dt=1e-5, units="si", cells=dict(SLABS),
                           **more, **options)


def weight_above(run, edges):
    """The weight of the spheres' parts above each of 400 cuts through each slab,
    averaged over the slab (spherical caps), last frame."""
    rows, cols = last_rows(run / "atoms.dump")
    z, a, m = (rows[:, cols.index(c)] for c in ("z", "radius", "mass"))
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        cuts = lo + (np.arange(400) + 0.5) / 400 * (hi - lo)
        u = np.clip((cuts[:, None] - z[None, :]) / a[None, :], -1, 1)
        out.append(np.mean(((1 - u) ** 2 * (2 + u) / 4) @ m) * G)
    return np.where(np.array(out) > 0, out, np.nan), m.sum() * G


def bulk(p, run):
    """Slabs between the floor's and the one holding the free surface (nu below 0.55)."""
    nu = p.values["nu"]
    top = int(np.flatnonzero(nu > 0.55)[-1])
    return np.arange(1, top + 1)


# -- the pile carries its weight -----------------------------------------------------------

def test_mesh_pile_carries_its_weight_through_the_cli(capsys, mesh, tmp_path):
    """Only the keywords named: -sigma_zz L^2 is the weight above in every bulk slab
    within 1%; the floor's slab too, with the mesh's contacts, and by more than 10% off
    without them; the sidecar names the keywords and the walls."""
    out = tmp_path / "p.csv"
    code, err = cli(capsys, "average", "--atoms", mesh / "atoms.dump", "--contacts",
                    mesh / "contacts.dump", "--wall-contacts", mesh / "walls.dump",
                    "--liggghts", KEYWORDS, "--dt", 1e-5, "--units", "si", "--slabs", "z",
                    "--range", 0, 0.048, "--bins", 8, "--out", out, "--no-progress")
    assert code == 0, err
    p = read_profiles(out)
    above, _ = weight_above(mesh, p.cells.edges)
    carried = -p.values["sigma_zz"] * L * L / above
    k = bulk(p, mesh)
    assert len(k) >= 3 and np.all(np.abs(carried[k] - 1) < 0.01), carried
    assert abs(carried[0] - 1) < 0.01, carried
    meta = p.meta["inputs"]
    assert meta["format"] == "liggghts" and meta["liggghts"]["keywords"] == KEYWORDS
    assert "mesh walls" in meta["liggghts"]["walls"]
    alone = average(mesh, walls=False, quantities=["sigma"])
    assert abs(-alone.values["sigma_zz"][0] * L * L / above[0] - 1) > 0.1


def test_primitive_floor_is_said_and_its_force_comes_from_a_per_atom_column(caplog,
                                                                            primitive):
    """No wall contacts: one log line says primitive walls cannot be dumped; the bulk
    still carries its weight within 1%; the floor force per atom named bx by bz closes
    the body force over the pile (sum b V = 0 within the pile's residual motion, 1e-3 of
    its weight); without it the body force is the weight."""
    caplog.set_level(logging.INFO, logger="granavg")
    p = average(primitive, walls=False, gravity=(0, 0, -G),
                atom_map={"bx": "f_force_wall[1]", "by": "f_force_wall[2]",
                          "bz": "f_force_wall[3]"})
    said = [m for m in caplog.messages if "primitive walls" in m]
    assert len(said) == 1 and "store_force" in said[0], caplog.messages
    assert "primitive walls" in p.meta["inputs"]["liggghts"]["walls"]
    above, weight = weight_above(primitive, p.cells.edges)
    carried = -p.values["sigma_zz"] * L * L / above
    k = bulk(p, primitive)
    assert len(k) >= 3 and np.all(np.abs(carried[k] - 1) < 0.01), carried
    assert abs(np.sum(p.values["body_z"] * p.cells.volume)) < 1e-3 * weight
    plain = average(primitive, walls=False, gravity=(0, 0, -G), quantities=["body"])
    assert abs(np.sum(plain.values["body_z"] * plain.cells.volume) / weight + 1) < 1e-3


# -- the stress is the documented formula of the raw columns -------------------------------

def raw_frames(path):
    """(columns, rows) of every frame of a LIGGGHTS dump, read without granavg."""
    out = []
    for f in frame_lines(path):
        head = next(k for k, ln in enumerate(f) if ln.startswith(("ITEM: ATOMS",
                                                                  "ITEM: ENTRIES")))
        out.append((f[head].split()[2:], np.array([ln.split() for ln in f[head + 1:]],
                                                  float)))
    return out


def recomputed_stress(run, edges):
    """sigma_ij of each slab from LIGGGHTS' raw columns (pos id force delta): every
    sphere's sum of f_i l_j, l = (a - delta/2) n from its centre towards the contact
    (the partner's centre, nearest image; the mesh's contact point), shared among the
    slabs by the sphere's volume in each, over the frames."""
    below = lambda c, z, a: (1 + (u := np.clip((c - z) / a, -1, 1))) ** 2 * (2 - u) / 4
    total = np.zeros((len(edges) - 1, 3, 3))
    A, C, W = (raw_frames(run / f) for f in ("atoms.dump", "contacts.dump", "walls.dump"))
    for (ac, ar), (_, cr), (_, wr) in zip(A, C, W):
        row = {int(i): k for k, i in enumerate(ar[:, ac.index("id")])}
        x, a = ar[:, [ac.index(c) for c in "xyz"]], ar[:, ac.index("radius")]
        S = np.zeros((len(ar), 3, 3))
        i1, i2 = (np.array([row[int(i)] for i in cr[:, c]]) for c in (6, 7))
        d = cr[:, 0:3] - cr[:, 3:6]
        d[:, :2] -= L * np.round(d[:, :2] / L)
        n = -d / np.linalg.norm(d, axis=1)[:, None]
        for p, f, nn in ((i1, cr[:, 9:12], n), (i2, -cr[:, 9:12], -n)):
            np.add.at(S, p, f[:, :, None] * ((a[p] - cr[:, 12] / 2)[:, None] * nn)[:, None])
        ip = np.array([row[int(i)] for i in wr[:, 8]])
        nn = wr[:, 0:3] - x[ip]
        nn /= np.linalg.norm(nn, axis=1)[:, None]
        np.add.at(S, ip, wr[:, 9:12][:, :, None] *
                  ((a[ip] - wr[:, 12] / 2)[:, None] * nn)[:, None])
        for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
            share = below(hi, x[:, 2], a) - below(lo, x[:, 2], a)
            total[k] += np.einsum("p,pij->ij", share, S)
    return total / len(A) / (L * L * np.diff(edges))[:, None, None]


@pytest.mark.parametrize("case", ["mesh", "flowing"])
def test_stress_is_the_raw_columns_recomputed(request, case):
    """All nine components in every slab equal the recomputation to 1e-7 of the largest
    (measured 3e-16); its transpose differs by percents in the flowing pile (the test
    tells sigma_ij from sigma_ji)."""
    run = request.getfixturevalue(case)
    p = average(run, quantities=["sigma"])
    ours = np.moveaxis(np.array([[p.values[f"sigma_{i}{j}"] for j in "xyz"] for i in "xyz"]),
                       -1, 0)
    theirs = recomputed_stress(run, p.cells.edges)
    scale = np.max(np.abs(theirs))
    assert np.max(np.abs(ours - theirs)) < 1e-7 * scale
    if case == "flowing":
        assert np.max(np.abs(ours - theirs.transpose(0, 2, 1))) > 1e-2 * scale


def test_the_flowing_pile_balances_its_momentum(flowing):
    """Over all slabs, in the run's first dumped frame: sum (b + t) V = sum m a V (the
    atoms' own total forces fx fy fz; t the mesh floor's contacts) within 1e-4 of the
    weight along x and z; without the mesh's contacts it misses by the floor's load.
    Later frames miss by more than 10% of the weight: LIGGGHTS' contact dumps after a
    run's first dump step do not hold the forces that moved the spheres (docs/formats.md;
    per sphere, tests below)."""
    g = (G * np.sin(np.radians(30)), 0.0, -G * np.cos(np.radians(30)))
    first = 0.5                                     # step 50000 x dt
    p = average(flowing, gravity=g, t_max=first)
    _, weight = weight_above(flowing, p.cells.edges)
    for x in "xz":
        lhs = np.sum((p.values[f"body_{x}"] + p.values[f"boundary_{x}"]) * p.cells.volume)
        rhs = np.sum(p.values[f"ma_{x}"] * p.cells.volume)
        assert abs(lhs - rhs) < 1e-4 * weight, (x, lhs, rhs)
    q = average(flowing, walls=False, gravity=g, t_max=first)
    assert abs(np.sum((q.values["body_z"] - q.values["ma_z"]) * q.cells.volume)) > \
        0.5 * weight
    later = average(flowing, gravity=g, t_min=first + 1e-3)
    lhs = np.sum((later.values["body_x"] + later.values["boundary_x"] -
                  later.values["ma_x"]) * later.cells.volume)
    assert abs(lhs) > 0.1 * weight
    assert np.nanmax(p.values["v_x"]) > 0.05                   # it flows (m/s)


def per_sphere_misfit(run, tilt=0.0):
    """Per frame, the largest |f - (m g + the contacts' forces)| over the spheres, in
    units of the sphere's weight, from the raw columns."""
    A, C, W = (raw_frames(run / f) for f in ("atoms.dump", "contacts.dump", "walls.dump"))
    g = G * np.array([np.sin(np.radians(tilt)), 0.0, -np.cos(np.radians(tilt))])
    out = []
    for (ac, ar), (_, cr), (_, wr) in zip(A, C, W):
        row = {int(i): k for k, i in enumerate(ar[:, ac.index("id")])}
        m = ar[:, ac.index("mass")]
        F = m[:, None] * g
        for col, sign in ((6, 1), (7, -1)):
            np.add.at(F, [row[int(i)] for i in cr[:, col]], sign * cr[:, 9:12])
        np.add.at(F, [row[int(i)] for i in wr[:, 8]], wr[:, 9:12])
        f = ar[:, [ac.index(c) for c in ("fx", "fy", "fz")]]
        out.append(np.max(np.abs(f - F).max(axis=1) / (m * G)))
    return np.array(out)


def test_liggghts_contact_dumps_match_the_forces_only_at_a_runs_first_dump(mesh, flowing):
    """Measured, so that a LIGGGHTS release that changes it is noticed: per sphere the
    contacts + weight equal the dumped total force at the run's first dump to the %g
    rounding (< 1e-3 of its weight), not at the later ones (pile at rest: about 1% of
    the weight; flowing: many weights)."""
    rest, flow = per_sphere_misfit(mesh), per_sphere_misfit(flowing, 30.0)
    assert rest[0] < 1e-3 and flow[0] < 1e-2 * np.max(flow[1:]), (rest, flow)
    assert np.all(rest[1:] > 3e-3) and np.all(flow[1:] > 1.0), (rest, flow)


def test_the_force_split_by_liggghts_gives_the_stress_of_the_total_force(flowing,
                                                                          flowing_split):
    """``pos id force_normal force_tangential delta`` (LIGGGHTS' split, each part on
    the normal check) against ``pos id force delta`` (split by granavg along the line
    of the centres), same trajectory: every stress component within 1e-5 of the largest
    (both print 6 digits; measured 1e-7)."""
    split = average(flowing_split, keywords="pos id force_normal force_tangential delta",
                    quantities=["sigma"])
    total = average(flowing, quantities=["sigma"])
    names = [f"sigma_{i}{j}" for i in "xyz" for j in "xyz"]
    a, b = (np.array([p.values[n] for n in names]) for p in (split, total))
    scale = np.max(np.abs(b))
    assert np.max(np.abs(a - b)) < 1e-5 * scale, np.max(np.abs(a - b)) / scale


# -- VTK atoms -----------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", ["vtk", "vtp"])
def test_vtk_atoms_give_the_text_dumps_kinematic_fields(flowing, suffix):
    """dump custom/vtk (legacy and XML) of the flowing pile: nu, rho, v, omega as from
    the text dump within 1e-5 of each column's largest particle value (both print 6
    digits, the VTK points as floats: 6e-8); the box from LIGGGHTS' bounding-box files.
    A frame left out is told apart."""
    want = ["nu", "rho", "v", "omega"]
    cells = dict(SLABS)
    a = granavg.average(str(flowing / f"atoms_*.{suffix}"), dt=1e-5, units="si",
                        cells=cells, quantities=want)
    b = granavg.average(flowing / "atoms.dump", dt=1e-5, units="si", cells=cells,
                        quantities=want)
    rows, cols = last_rows(flowing / "atoms.dump")
    scale = {"nu": 1.0, "rho": 2500.0, "v": np.abs(rows[:, cols.index("vx")]).max(),
             "omega": np.abs(rows[:, [cols.index(f"omega{x}") for x in "xyz"]]).max()}
    assert a.meta["inputs"]["format"] == "vtk"
    for name in a.values:
        s = scale[name.split("_")[0]]
        assert np.array_equal(np.isnan(a.values[name]), np.isnan(b.values[name])), name
        assert np.nanmax(np.abs(a.values[name] - b.values[name])) < 1e-5 * s, name
    fewer = granavg.average(str(flowing / f"atoms_*.{suffix}"), dt=1e-5, units="si",
                            cells=cells, quantities=["v"], t_min=0.501)
    assert np.nanmax(np.abs(fewer.values["v_x"] - b.values["v_x"])) > 1e-3 * scale["v"]


# -- refusals ------------------------------------------------------------------------------

@pytest.mark.parametrize("keywords, needles", [
    ("pos id force", ["12 values per contact (pos 6, id 3, force 3)", "holds 13"]),
    ("pos id force delta torque", ["16 values per contact", "holds 13"]),
    ("pos id forces", ["forces: not a keyword"]),
    ("id force delta history vel", ["history at least 1", "holds 13"]),
])
def test_a_wrong_keyword_list_is_refused_in_one_line(capsys, mesh, tmp_path, keywords,
                                                     needles):
    code, err = cli(capsys, "average", "--atoms", mesh / "atoms.dump", "--contacts",
                    mesh / "contacts.dump", "--liggghts", keywords, "--dt", 1e-5,
                    "--slabs", "z", "--out", tmp_path / "p.csv")
    errors = [ln for ln in err if "error:" in ln]
    assert code == 2 and len(errors) == 1, err
    assert "--liggghts" in errors[0] and all(n in errors[0] for n in needles), errors[0]
    assert not list(tmp_path.iterdir())


def test_unnamed_contact_columns_without_keywords_say_which_option(capsys, mesh, tmp_path):
    """As LAMMPS dumps (no --liggghts), the c_ID[k] columns cannot be told: one line
    names --liggghts and --contact-columns."""
    code, err = cli(capsys, "average", "--atoms", mesh / "atoms.dump", "--contacts",
                    mesh / "contacts.dump", "--dt", 1e-5, "--slabs", "z",
                    "--out", tmp_path / "p.csv")
    errors = [ln for ln in err if "error:" in ln]
    assert code == 2 and len(errors) == 1
    assert re.search(r"--liggghts .*--contact-columns", errors[0]), errors[0]
