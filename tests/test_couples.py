"""The contact couples and the balance of the spins' angular momentum, checked against
LAMMPS itself.

- Each particle's contact forces' moments (with the law's own lever arm) plus its
  contact couples equal LAMMPS' torque on it: on granavg's deck in-process (full
  precision; gran/hooke/history, whose arm is the radius, and pair granular with rolling
  resistance, whose arm ends at the contact point), and on users' piles of our own decks
  (tests/decks/pile_rolling_2d.lmp, lj units; pile_rolling_3d.lmp, SI, rolling and
  twisting resistance), through their default-format dumps.
- On those piles at rest the balance of the spins closes in every slab (walls
  included) to round-off of the printed dumps, while the forces' moments alone are
  several % of the stress: leaving out the couple columns, or taking the wrong lever
  arm, makes it fail.
- The couple stress obeys its sum rule against a direct sum written here.
- The granular temperatures of a frame with known fluctuations.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from granavg.analysis.spin_balance import spin_balance
from granavg.engine.cell_average import CellAverage
from granavg.engine.spec import Averaging
from granavg.engine.cells.slabs import Slabs
from granavg.engine.cells.slabs3d import Slabs3D
from granavg.engine.channels import Layout
from granavg.engine.kernels import particle_channels
from granavg.io.frames import Frame
from granavg.io.dump_columns import parse_map
from granavg.io.lammps_dumps import LammpsDumps
from granavg.io.profiles_io import read_profiles
from granavg.sim.lammps_session import lammps_session

from .helpers import frames, live_frame_and_virial, run_cli

DECKS = Path(__file__).parent / "decks"
#: The piles' contact columns (pair/local dist dx dy [dz] fx fy [fz] p1 p2 [p3] p5 p6 [p7
#: p9]), with and without the rolling force and twisting torque.
BASE = {2: "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],fnx=c_pl[4],"
           "fny=c_pl[5],ftx=c_pl[6],fty=c_pl[7]",
        3: "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
           "fnx=c_pl[5],fny=c_pl[6],fnz=c_pl[7],ftx=c_pl[8],fty=c_pl[9],ftz=c_pl[10]"}
ROLLING = {2: ",frx=c_pl[8],fry=c_pl[9]",
           3: ",frx=c_pl[11],fry=c_pl[12],frz=c_pl[13],twist=c_pl[14]"}
#: Slabs across the piles' height: lj (2D, disks of diameter ~1, free surface ~11) and
#: SI (3D, spheres of ~2 mm, floor at 1 mm, free surface ~10 mm).
SLABS = {2: ["--thickness", 1, "--slabs", "y", "--range", 0, 14, "--bins", 7,
             "--gravity", 0, -1],
         3: ["--slabs", "z", "--range", 0, 0.016, "--bins", 8, "--gravity", 0, 0, -9.81]}
#: The cells' balance holds to the printed dumps' rounding (6 digits): measured at most
#: 1.5e-7 (2D) and 7e-7 (3D) of the stress scale.
ROUNDING = 1e-5

ONE = Averaging.of(t_min=0.0, block_time=1.0)


def run_pile(dim, out):
    out.mkdir(parents=True, exist_ok=True)
    with lammps_session(["-log", str(out / "log.lammps"), "-var", "out", str(out)]) as lmp:
        lmp.file(str(DECKS / f"pile_rolling_{dim}d.lmp"))
    return out


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def pile(request, tmp_path_factory):
    return request.param, run_pile(request.param, tmp_path_factory.mktemp(f"roll{request.param}"))


def powers(frame):
    """Per disk (2D): the power its contacts deliver with the arm to the contact point
    (pairs' and walls') and the lever moment's."""
    a = frame.atoms
    layout = Layout(("x", "y"))
    P = len(a["radius"])
    vol = np.pi * a["radius"] ** 2
    q = particle_channels(a, frame.contacts, layout, vol, vol / a["radius"] ** 2, 1.0,
                          {"ppow", "wpow", "lpow"}, np.tile(np.eye(2), (P, 1, 1)))
    return (q[:, layout.first("ppow")] + q[:, layout.first("wpow")],
            q[:, layout.first("lpow")])


def moments(frame, dim, blocks=("sig", "cnet", "lever")):
    """Per particle, in Cartesian axes: the forces' moment about its centre with the
    branch to the contact point (from sum f (x) l), its contact couples and the moment
    (delta/2) n x f that an arm to the surface adds; each (P, 1 or 3)."""
    a, c = frame.atoms, frame.contacts
    axes = ("x", "y", "z")[:dim]
    layout = Layout(axes)
    P = len(a["radius"])
    vol = np.pi * a["radius"] ** 2 if dim == 2 else 4 / 3 * np.pi * a["radius"] ** 3
    q = particle_channels(a, c, layout, vol, vol / a["radius"] ** 2, 1.0, set(blocks),
                          np.tile(np.eye(dim), (P, 1, 1)))
    S = layout.block(q, "sig").reshape(P, dim, dim)
    tau = (S[:, 1, 0] - S[:, 0, 1])[:, None] if dim == 2 else np.column_stack(
        [S[:, 2, 1] - S[:, 1, 2], S[:, 0, 2] - S[:, 2, 0], S[:, 1, 0] - S[:, 0, 1]])
    return tau, layout.block(q, "cnet"), layout.block(q, "lever")


@pytest.mark.parametrize("sets, arm", [((), "surface"), (("mu_roll=0.2",), "contact")],
                         ids=["gran-hooke-history", "granular-rolling"])
def test_the_decks_contact_couples_sum_to_lammps_torques(tmp_path, sets, arm):
    """granavg's deck, in-process at full precision: sum_c (l x f + m) with the law's
    arm is LAMMPS' torque on every disk to 1e-10 of the largest moment; gran/hooke/history
    turns its disks with an arm to the surface (the lever term), pair granular with one
    to the contact point plus its rolling couples. The other arm misses by far more."""
    _, _, frame, _, forces, torques = live_frame_and_virial(tmp_path / "live", *sets)
    tau, cnet, lever = moments(frame, 2)
    ids = frame.atoms["id"].astype(int)
    lammps = np.array([torques[i] for i in ids])
    # the contacts' power on each disk is LAMMPS' f . v + torque . omega (the walls do
    # not move in the frame of the contact rows: the inner wall's velocity is the
    # scene's; their contacts' power is what they deliver to the disk)
    a = frame.atoms
    f = np.array([forces[i] for i in ids])
    delivered = f[:, 0] * a["vx"] + f[:, 1] * a["vy"] + lammps * a["omegaz"]
    power, lever_power = powers(frame)
    ours = power + (lever_power if arm == "surface" else 0.0)
    p_scale = np.abs(delivered).max()
    assert np.abs(ours - delivered).max() < 1e-9 * p_scale
    scale = np.abs(tau).max()
    right = tau[:, 0] + cnet[:, 0] + (lever[:, 0] if arm == "surface" else 0.0)
    wrong = tau[:, 0] + cnet[:, 0] + (lever[:, 0] if arm == "contact" else 0.0)
    assert np.abs(right - lammps).max() < 1e-10 * scale
    assert np.abs(wrong - lammps).max() > 1e-4 * scale
    couples = frame.contacts["mz"]
    assert (np.count_nonzero(couples) > 100) == (arm == "contact")


def test_a_users_pile_couples_sum_to_lammps_torques(pile):
    """The pile's default-format dumps through granavg's reader: tau + the couples (from
    pair granular's rolling force and twisting torque) equal the dumped torques to the
    printed rounding, on every particle of every frame; without the couples they miss by
    the couples themselves (the pile is at rest: LAMMPS' torques are round-off)."""
    dim, out = pile
    dumps = LammpsDumps(out / "atoms.dump", out / "contacts.dump", wall_types=[2],
                        contact_map=parse_map(BASE[dim] + ROLLING[dim]))
    torque_cols = ["tqz"] if dim == 2 else ["tqx", "tqy", "tqz"]
    raw = {}
    for head, names, rows in frames(out / "atoms.dump"):
        cols = [names.index(c) for c in torque_cols]
        raw[int(head[1])] = {int(r[names.index("id")]): r[cols] for r in rows}
    seen = 0
    for frame in dumps:
        tau, cnet, _ = moments(frame, dim)
        lammps = np.array([raw[frame.timestep][int(i)] for i in frame.atoms["id"]])
        scale = np.abs(tau).max()
        assert np.abs(tau + cnet - lammps).max() < 1e-4 * scale
        assert np.abs(tau - lammps).max() > 0.3 * scale
        seen += 1
    assert seen == 11


def pile_balance(pile, tmp_path, name, contact_map, *extra):
    dim, out = pile
    dest = tmp_path / name
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", contact_map,
                   "--wall-types", 2, *SLABS[dim], "--out", dest, "--no-progress", *extra)
    assert proc.returncode == 0, proc.stderr
    return read_profiles(dest), proc.stderr


def test_the_spins_balance_in_every_slab_of_a_pile_at_rest(pile, tmp_path):
    """tau + the couples passed (+ the spins' flux) is nil in every slab, the floor's
    included, to the dumps' rounding (issue: < 1% of the scale in the bulk), while tau
    alone reaches several % of the stress scale. Without the couple columns the couples
    are taken as zero (sidecar and log say so) and the balance misses by tau; with the
    lever arm of gran/* styles it misses by the lever moment."""
    dim, _ = pile
    p, _ = pile_balance(pile, tmp_path, "roll.csv", BASE[dim] + ROLLING[dim])
    b = spin_balance(p, closed=True)
    assert b["form"] == "cells" and b["dynamic"]
    assert np.all(np.isfinite(b["residual"]))
    assert np.abs(b["residual"]).max() < ROUNDING, b["residual"]
    assert b["terms"]["tau"] > 0.02
    assert "taken_as_zero" not in p.meta
    wrong_arm = spin_balance(p, arm="surface", closed=True)
    assert np.abs(wrong_arm["residual"]).max() > 3 * ROUNDING
    # the stress's branch to the surface (Eq. 5 as printed) is turned into the law's arm
    paper, _ = pile_balance(pile, tmp_path, "paper.csv", BASE[dim] + ROLLING[dim],
                            "--branch", "paper")
    assert paper.meta["branch"] == "paper"
    assert np.abs(spin_balance(paper, closed=True)["residual"]).max() < ROUNDING
    bare, said = pile_balance(pile, tmp_path, "bare.csv", BASE[dim])
    couple = ["mz"] if dim == 2 else ["mx", "my", "mz"]
    assert set(bare.meta["taken_as_zero"]) == set(couple)
    assert "no contact couple" in said
    assert np.abs(spin_balance(bare, closed=True)["residual"]).max() > 0.02
    assert np.allclose(bare.values["sigma_" + "xy"], p.values["sigma_xy"], rtol=0, atol=0)


def test_the_couple_fields_divergence_does_not_stand_for_the_couples_in_one_packing(
        pile, tmp_path):
    """docs/profiles.md's measurement: in a packing at rest the couple stress field is
    the couples' frozen disorder; its finite-volume divergence misses the couples passed
    by a good part of tau in some slab (measured: residuals up to tau's size)."""
    dim, _ = pile
    p, _ = pile_balance(pile, tmp_path, "field.csv", BASE[dim] + ROLLING[dim])
    b = spin_balance(p, closed=True, form="field")
    assert np.nanmax(np.abs(b["residual"])) > 0.2 * b["terms"]["tau"]


def test_the_couple_stress_sum_rule(pile, tmp_path):
    """sum_k V_k mu_k = sum_p sum_c l (x) m over slabs that hold every particle whole
    (the direct sum written here from the contact rows), and the couples on the particles
    sum to what the walls' contacts pass (the pairs' cancel)."""
    dim, out = pile
    dumps = LammpsDumps(out / "atoms.dump", out / "contacts.dump", wall_types=[2],
                        contact_map=parse_map(BASE[dim] + ROLLING[dim]))
    frame = next(iter(dumps))
    a, c = frame.atoms, frame.contacts
    up = a["y"] if dim == 2 else a["z"]
    edges = np.linspace(up.min() - 2 * a["radius"].max(), up.max() + 2 * a["radius"].max(), 6)
    cells = Slabs(edges, 1.0, "y", 20.0) if dim == 2 else Slabs3D(edges, "z", 0.012 ** 2)
    prof = CellAverage([frame], cells, ["mu", "couple_density"], 1.0, ONE).run(False)
    axes = cells.axes
    row = {int(i): k for k, i in enumerate(a["id"])}
    mcols = ["mz"] if dim == 2 else ["mx", "my", "mz"]
    direct, walls = np.zeros((dim, len(mcols))), np.zeros(len(mcols))
    for k in range(len(c["id1"])):
        n = np.array([c[f"n{x}"][k] for x in "xyz"[:dim]])
        m = np.array([c[col][k] for col in mcols])
        p1 = row[int(c["id1"][k])]
        direct += np.outer((a["radius"][p1] - 0.5 * c["overlap"][k]) * n, m)
        if c["wall"][k] == 0:
            p2 = row[int(c["id2"][k])]
            direct += np.outer((a["radius"][p2] - 0.5 * c["overlap"][k]) * -n, -m)
        else:
            walls += m
    V = cells.volume
    names = [f"mu_{i}" for i in axes] if dim == 2 else [f"mu_{i}{j}" for i in axes for j in axes]
    summed = np.array([np.sum(V * prof.values[k]) for k in names]).reshape(direct.shape)
    assert np.allclose(summed, direct, rtol=1e-10, atol=1e-12 * np.abs(direct).max())
    net = ["couple_density"] if dim == 2 else [f"couple_density_{i}" for i in axes]
    total = np.array([np.sum(V * prof.values[k]) for k in net])
    assert np.allclose(total, walls, rtol=1e-9, atol=1e-12 * np.abs(direct).max())


def test_granular_temperatures_of_known_fluctuations():
    """Four equal disks in one slab with velocities (+-u, 0), (0, +-u) about a mean flow
    U and spins W +- w: T = u^2 / 2, T_rot = I w^2 / m = a^2 w^2 / 2; the energy densities
    are the sums over the slab's volume."""
    u, U, w, W, a, h = 0.3, 1.1, 2.0, 5.0, 0.01, 1.0
    atoms = {"id": np.arange(1.0, 5.0), "x": np.array([0.2, 0.4, 0.6, 0.8]),
             "y": np.full(4, 0.5), "radius": np.full(4, a),
             "vx": U + np.array([u, -u, 0, 0]), "vy": np.array([0, 0, u, -u]),
             "omegaz": W + np.array([w, -w, w, -w])}
    cells = Slabs(np.array([0.0, 1.0]), h, "y", 1.0)
    rho = 1000.0
    p = CellAverage([Frame(0, 0.0, atoms, None)], cells,
                    ["temperature", "temperature_rot", "ekin", "erot", "spin_density"],
                    rho, ONE).run(False)
    m = rho * np.pi * h * a * a
    inertia = 0.5 * m * a * a
    assert p.values["temperature"][0] == pytest.approx(u * u / 2, rel=1e-12)
    assert p.values["temperature_rot"][0] == pytest.approx(inertia * w * w / m, rel=1e-12)
    V = cells.volume[0]
    vv = (U + u) ** 2 + (U - u) ** 2 + 2 * (U * U + u * u)
    assert p.values["ekin"][0] * V == pytest.approx(0.5 * m * vv, rel=1e-12)
    assert p.values["erot"][0] * V == pytest.approx(
        0.5 * inertia * (2 * (W + w) ** 2 + 2 * (W - w) ** 2), rel=1e-12)
    assert p.values["spin_density"][0] * V == pytest.approx(4 * inertia * W, rel=1e-12)


def test_the_sidecar_documents_the_couples(pile, tmp_path):
    """The sidecar says what the couple fields are, their sign conventions and units
    (the 2D pile's dumps do not say their units: LAMMPS' lj names none)."""
    dim, _ = pile
    p, _ = pile_balance(pile, tmp_path, "doc.csv", BASE[dim] + ROLLING[dim],
                        "--quantities", "mu,dmu,spin_density,couple_density")
    side = json.loads((tmp_path / "doc.csv.json").read_text())
    conventions = side["micropolar"]
    assert conventions["quantities"] == ["mu", "dmu", "spin_density", "couple_density"]
    assert "first index the branch vector's" in conventions["mu"]
    assert "sigma_yx - sigma_xy" in conventions["balance"]
    assert ("mu_y" in p.values if dim == 2 else "mu_zx" in p.values)
    unit = "force/length" if dim == 2 else "N/m"
    assert side["columns"]["mu_y" if dim == 2 else "mu_zx"] == unit


@pytest.mark.parametrize("cells", ["grid", "shells"])
def test_the_spins_balance_in_grids_and_shells_of_a_pile(pile, tmp_path, cells):
    """The cells' form closes in any geometry: a grid over the box (2D: 4 x 7
    rectangles; 3D: 3 x 3 x 8 boxes; its interior cells, whose every face has a
    neighbour) and cylindrical shells about the 3D pile's centre (the 2D pile: rings
    about its centre), every cell judged to the dumps' rounding; tau alone reaches more
    than 100 times that."""
    dim, _ = pile
    if cells == "grid":
        where = ["--grid", 4, 7, "--x-range", 0, 20, "--y-range", 0, 14] if dim == 2 else \
            ["--grid", 3, 3, 8, "--x-range", 0, 0.012, "--y-range", 0, 0.012, "--z-range",
             0, 0.016]
    else:
        where = ["--center", 10, 6, "--r-range", 0, 6, "--bins", 5] if dim == 2 else \
            ["--center", 0.006, 0.006, "--r-range", 0, 0.006, "--bins", 3, "--layers", 4,
             "--z-range", 0, 0.016]
    dest = tmp_path / "g.csv"
    _, out = pile
    gravity = ["--gravity", 0, -1] if dim == 2 else ["--gravity", 0, 0, -9.81]
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", BASE[dim] + ROLLING[dim],
                   "--wall-types", 2, *(["--thickness", 1] if dim == 2 else []), *where,
                   *gravity, "--out", dest, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(dest)
    b = spin_balance(p, closed=True)
    judged = (p.values["nu"] > 0) & np.all(np.isfinite(b["residual"]), axis=0)
    assert judged.sum() >= 5              # a grid judges its interior cells
    assert np.all(np.abs(b["residual"][:, judged]) < ROUNDING), b["residual"]
    assert b["terms"]["tau"] > 100 * ROUNDING


def test_the_decks_couples_under_mpirun_obey_the_rolling_coulomb_limit(tmp_path):
    """granavg's deck with rolling resistance under mpirun (2 ranks): LAMMPS writes the
    rolling force (contacts_raw), granavg converts it into each contact's couple. Many
    contacts carry one, none beyond the rolling friction's cap mu_roll R_eff |F_n|
    (R_eff from the radii of the atom dump, F_n from the row)."""
    from granavg.io.reader import DumpReader
    from .conftest import small_cell_args
    out = tmp_path / "run"
    proc = run_cli(*small_cell_args(out, "mu_roll=0.2", "t_end=2", np=2))
    assert proc.returncode == 0, proc.stderr
    radius = {}
    for frame in DumpReader(out / "atoms.dump.gz"):
        d = frame.as_dict()
        radius.update(zip(d["id"].astype(int), d["radius"]))
    scene = json.loads((out / "manifest.json").read_text())["scene"]
    wall_d = scene["wall_d"] or scene["d_s"]                    # 0: the small diameter
    rolling = 0
    for frame in DumpReader(out / "contacts.dump.gz"):
        c = frame.as_dict()
        r1 = np.array([radius[int(i)] for i in c["id1"]])
        r2 = np.array([radius.get(int(i), wall_d / 2) if w == 0 else wall_d / 2
                       for i, w in zip(c["id2"], c["wall"])])
        cap = 0.2 * r1 * r2 / (r1 + r2) * np.hypot(c["fnx"], c["fny"])
        assert np.all(np.abs(c["mz"]) <= cap * (1 + 1e-9) + 1e-15)
        rolling += int(np.sum(np.abs(c["mz"]) > 0.01 * cap))
    assert rolling > 100


#: Couple columns mapped in part: half the rolling force, or both forms at once.
PARTIAL = {2: (",frx=c_pl[8]", ",frx=c_pl[8],fry=c_pl[9],mz=c_pl[9]"),
           3: (",frx=c_pl[11],fry=c_pl[12]",
               ",frx=c_pl[11],fry=c_pl[12],frz=c_pl[13],mx=c_pl[11],my=c_pl[12],"
               "mz=c_pl[13]")}


@pytest.mark.parametrize("which", [0, 1], ids=["part-of-the-force", "both-forms"])
def test_a_couple_mapped_in_part_is_refused_in_one_line(pile, tmp_path, which):
    """One line, exit 2, nothing written: never a couple made of what is there."""
    dim, out = pile
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", BASE[dim] + PARTIAL[dim][which],
                   "--wall-types", 2, *SLABS[dim], "--out", tmp_path / "x.csv",
                   "--no-progress")
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "the contact couple needs all of" in lines[0], lines
    assert "Traceback" not in proc.stderr and not list(tmp_path.iterdir())


SPINNING = """
units           lj
dimension       2
atom_style      sphere
boundary        p p p
region          box block 0 20 0 20 -0.5 0.5
create_box      1 box
create_atoms    1 random 120 4417 NULL overlap 1.25 maxtry 200
variable        d atom 0.8+0.4*random(0,1,4417)
set             type 1 diameter v_d
set             type 1 density 1.0
velocity        all create 1.0 8812 dist gaussian
variable        w atom 2.0*(random(0,1,91)-0.5)
set             type 1 omega 0.0 0.0 v_w
pair_style      zero 1.0
pair_coeff      * *
fix             1 all nve/sphere
fix             2 all enforce2d
compute         rot all erotate/sphere
thermo_style    custom step c_rot
thermo_modify   norm no
dump            a all custom 1 {out}/atoms.dump id type diameter mass x y vx vy omegaz
dump_modify     a format float %.15g
run             0
"""


def test_2d_sphere_masses_turn_as_spheres_as_in_lammps(tmp_path):
    """A 2D run of sphere masses integrated by fix nve/sphere (no disc), as fix pour
    gives: granavg sees the masses scale as a^3 and takes I = 2/5 m a^2 (said in the
    sidecar); the rotational energy over a slab spanning the periodic box (every disk,
    through its images) is LAMMPS' own compute erotate/sphere. Taken as disks (--inertia
    disk) it is 5/4 of it."""
    deck = tmp_path / "spin.lmp"
    deck.write_text(SPINNING.format(out=tmp_path))
    with lammps_session(["-log", str(tmp_path / "log.lammps")]) as lmp:
        lmp.file(str(deck))
        lammps_erot = lmp.last_thermo()["c_rot"]
    base = ["average", "--atoms", tmp_path / "atoms.dump", "--thickness", 1, "--slabs", "y",
            "--bins", 1, "--quantities", "erot,spin_density",
            "--dt", 1, "--no-progress"]
    proc = run_cli(*base, "--out", tmp_path / "a.csv")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(tmp_path / "a.csv")
    assert p.meta["inputs"]["inertia"]["shape"] == "sphere"
    assert "a^3" in p.meta["inputs"]["inertia"]["why"] and "turn as spheres" in proc.stderr
    total = float(p.values["erot"][0] * p.cells.volume[0])
    assert total == pytest.approx(lammps_erot, rel=1e-9)
    proc = run_cli(*base, "--inertia", "disk", "--out", tmp_path / "d.csv")
    assert proc.returncode == 0, proc.stderr
    disk = read_profiles(tmp_path / "d.csv")
    assert disk.meta["inputs"]["inertia"] == {"shape": "disk", "I": "m a^2 / 2",
                                              "why": "given"}
    assert float(disk.values["erot"][0] * disk.cells.volume[0]) == pytest.approx(
        1.25 * lammps_erot, rel=1e-9)


@pytest.mark.slow
def test_analyze_shows_the_spins_balance_beside_the_forces(pile, tmp_path):
    """``granavg analyze`` on the pile's slabs: the report and summary hold the spins'
    balance beside the force balance, closed to the dumps' rounding with the contact
    point's lever arm, and missing by the lever moment with --torque-arm surface."""
    dim, _ = pile
    pile_balance(pile, tmp_path, "s.csv", BASE[dim] + ROLLING[dim])
    for arm in ("contact", "surface"):
        out = tmp_path / f"report-{arm}"
        drawn = arm == "contact"                   # the other: the numbers alone
        proc = run_cli("analyze", tmp_path / "s.csv", "--closed", "--torque-arm", arm,
                       "--out", out, *([] if drawn else ["--no-figures"]))
        assert proc.returncode == 0, proc.stderr
        summary = json.loads((out / "summary.json").read_text())
        sb = summary["profiles"][0]["spin_balance"]
        assert sb["form"] == "cells" and sb["arm"] == arm
        assert summary["profiles"][0]["balance"]["max_abs_residual"] is not None
        html = (out / "report.html").read_text()
        assert "Balance of the spins" in html
        assert (out / "figures" / "spin_balance0.png").exists() == drawn
        assert ("<img" in html) == drawn
        if arm == "contact":
            assert sb["max_abs_residual"] < ROUNDING
        else:
            assert sb["max_abs_residual"] > 3 * ROUNDING


SQUEEZED_3D = """
units           si
dimension       3
boundary        p p p
atom_style      sphere
atom_modify     map array
comm_modify     vel yes
newton          on
region          box block 0 0.05 0 0.05 0 0.05
create_box      1 box
create_atoms    1 random 150 123 NULL overlap 0.004
variable        dd atom 0.0075+0.002*random(0,1,77)
set             group all diameter v_dd
set             group all density 1000
velocity        all create 1e-4 4321 dist gaussian
pair_style      granular
pair_coeff      * * hooke 10 18 tangential linear_history 2.857 0.5 0.8 damping mass_velocity rolling sds 2.857 0.001 0.3 twisting sds 3e-5 1e-9 0.3
fix             1 all nve/sphere
fix             2 all deform 1 x scale 0.8 y scale 0.8 z scale 0.8 remap x
timestep        2e-4
run             3000
unfix           2
run             200
compute         pp all property/local patom1 patom2
compute         pl all pair/local dist dx dy dz fx fy fz p1 p2 p3 p5 p6 p7 p9
dump            a all custom 1 {out}/atoms.dump id type diameter mass x y z vx vy vz omegax omegay omegaz fx fy fz tqx tqy tqz
dump_modify     a format float %.16g
dump            c all local 1 {out}/contacts.dump c_pp[1] c_pp[2] c_pl[*]
dump_modify     c format float %.16g
run             0
"""


def test_3d_contacts_power_and_moments_are_lammps_own(tmp_path):
    """A squeezed, moving 3D packing with rolling and twisting resistance, dumped at full
    precision: per sphere the contacts' moments plus couples are LAMMPS' torque and
    their power is its f . v + torque . omega (to 1e-9 of the largest)."""
    deck = tmp_path / "squeeze.lmp"
    deck.write_text(SQUEEZED_3D.format(out=tmp_path))
    with lammps_session(["-log", str(tmp_path / "log.lammps")]) as lmp:
        lmp.file(str(deck))
    dumps = LammpsDumps(tmp_path / "atoms.dump", tmp_path / "contacts.dump",
                        contact_map=parse_map(BASE[3] + ROLLING[3]), dt=1.0)
    frame = next(iter(dumps))
    head, names, rows = frames(tmp_path / "atoms.dump")[0]
    by_id = {int(r[names.index("id")]): r for r in rows}
    a = frame.atoms

    def dumped(cols):
        return np.array([[by_id[int(i)][names.index(c)] for c in cols] for i in a["id"]])
    f, tq = dumped(["fx", "fy", "fz"]), dumped(["tqx", "tqy", "tqz"])
    v = np.column_stack([a["vx"], a["vy"], a["vz"]])
    w = np.column_stack([a["omegax"], a["omegay"], a["omegaz"]])
    tau, cnet, _ = moments(frame, 3)
    assert np.abs(tau + cnet - tq).max() < 1e-9 * np.abs(tau).max()
    layout = Layout(("x", "y", "z"))
    P = len(a["radius"])
    vol = 4 / 3 * np.pi * a["radius"] ** 3
    q = particle_channels(a, frame.contacts, layout, vol, vol / a["radius"] ** 2, 1.0,
                          {"ppow", "wpow"}, np.tile(np.eye(3), (P, 1, 1)))
    delivered = np.sum(f * v, axis=1) + np.sum(tq * w, axis=1)
    ours = q[:, layout.first("ppow")] + q[:, layout.first("wpow")]
    assert np.abs(ours - delivered).max() < 1e-9 * np.abs(delivered).max()
