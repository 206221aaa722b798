"""A small real Couette cell: dumps, contact law, drag by the inner wall, confinement."""

import json

import numpy as np
import pytest

from granavg.io.contacts import COLUMNS
from granavg.io.reader import DumpReader
from granavg.sim.scene import Scene

from .conftest import run_cli, small_cell_args

SPREAD = 0.1


@pytest.fixture(scope="module", params=["embedded", "mpirun-np2-spread", "mu_wall-0.3-plain"])
def run(request, small_run, tmp_path_factory):
    """The small cell in-process; under mpirun with 2 ranks and sizes spread by +-10%; with
    its own wall friction (the deck then uses pair hybrid) and plain-text dumps."""
    if request.param == "embedded":
        return small_run
    out = tmp_path_factory.mktemp(request.param) / "run"
    args = small_cell_args(out, f"size_spread={SPREAD}", np=2) \
        if request.param == "mpirun-np2-spread" else \
        small_cell_args(out, "mu_wall=0.3", "gzip=0")
    proc = run_cli(*args)
    assert proc.returncode == 0, proc.stderr
    return out


def load(run):
    manifest = json.loads((run / "manifest.json").read_text())
    scene = Scene.from_dict(manifest["scene"])
    ext = "dump.gz" if scene.gzip else "dump"
    atoms = list(DumpReader(run / f"atoms.{ext}"))
    contacts = list(DumpReader(run / f"contacts.{ext}"))
    return manifest, scene, atoms, contacts


def test_manifest_records_the_run(run):
    m, scene, _, _ = load(run)
    assert m["status"] == "complete"
    assert m["derived"]["dt_s"] == pytest.approx(m["derived"]["t_c_s"] / scene.n_per_tc)
    assert m["lammps_version"] >= 20250722
    assert m["contact_law"]["k_n_N_per_m"] == scene.law.k_n
    for key in ("preparation", "wall_model", "seeds", "started", "finished", "execution"):
        assert m[key]
    assert (run / "deck" / "couette.lmp").exists() and (run / "log.lammps").exists()
    assert "lmp -in deck/couette.lmp" in (run / "run.sh").read_text()


def test_frames_cover_the_dump_schedule(run):
    m, scene, atoms, contacts = load(run)
    d = m["derived"]
    expected = list(range(d["first_dump_step"], d["n_shear_steps"] + 1, d["dump_every_steps"]))
    assert [f.timestep for f in atoms] == expected
    assert [f.timestep for f in contacts] == expected
    for f in atoms:
        assert len(f.data) == scene.n_small + scene.n_large
        assert f.time is None                          # MDAnalysis-readable: no TIME item
        assert np.all(f.column("z") == 0) and np.all(f.column("vz") == 0)
    for f in contacts:
        assert f.time == pytest.approx(f.timestep * d["dt_s"], rel=1e-9)


def test_every_contact_row_is_a_real_contact_obeying_coulomb(run):
    _, scene, atoms, contacts = load(run)
    for fa, fc in zip(atoms, contacts):
        assert fc.columns == COLUMNS
        c = dict(zip(COLUMNS, fc.data.T))
        assert len(fc.data) > 0 and np.all(c["overlap"] > 0)
        fn = np.hypot(c["fnx"], c["fny"])
        ft = np.hypot(c["ftx"], c["fty"])
        mu = np.where(c["wall"] > 0, scene.law.mu_wall, scene.law.mu)
        assert np.all(ft <= mu * fn * (1 + 1e-6) + 1e-12)
        assert np.allclose(np.hypot(c["nx"], c["ny"]), 1.0)
        # the normal force is along the normal, the friction force across it
        assert np.allclose(c["fnx"] * c["ny"] - c["fny"] * c["nx"], 0, atol=1e-9 * fn.max())
        assert np.allclose(c["ftx"] * c["nx"] + c["fty"] * c["ny"], 0, atol=1e-9 * fn.max())
        # id1 is always a disk of the packing; both walls are touched
        assert np.isin(c["id1"], fa.column("id")).all()
        assert {1, 2} <= set(c["wall"].astype(int))


def test_sliding_contacts_sit_on_their_own_coulomb_cap(run):
    _, scene, _, contacts = load(run)
    ratio = {0: [], 1: []}
    for fc in contacts:
        c = dict(zip(COLUMNS, fc.data.T))
        r = np.hypot(c["ftx"], c["fty"]) / np.hypot(c["fnx"], c["fny"])
        ratio[0].append(r[c["wall"] == 0].max())
        ratio[1].append(r[c["wall"] > 0].max())
    assert max(ratio[0]) == pytest.approx(scene.law.mu, rel=1e-6)
    assert max(ratio[1]) == pytest.approx(scene.law.mu_wall, rel=1e-6)


def test_inner_wall_drags_and_no_disk_leaves_the_annulus(run):
    m, scene, atoms, _ = load(run)
    dt = m["derived"]["dt_s"]
    wall_speed = scene.Omega * scene.R_i
    inner, outer = [], []
    for f in atoms:
        x, y, vx, vy, rad = (f.column(k) for k in ("x", "y", "vx", "vy", "radius"))
        r = np.hypot(x, y)
        # disks press into the bumpy walls by their contact overlap (a few % of d, set by
        # the fixed area fraction), but a centre closer than half a radius to a wall
        # surface would mean the disk is passing through it
        assert np.all(r - scene.R_i > 0.5 * rad)
        assert np.all(scene.R_o - r > 0.5 * rad)
        v_phi = (x * vy - y * vx) / r
        if f.timestep * dt >= 2.0:
            inner.append(v_phi[r < scene.R_i + 1.5 * scene.d_l].mean())
            outer.append(v_phi[r > scene.R_o - 1.5 * scene.d_l].mean())
    # clear drag at the inner wall; the outer wall's neighbours at rest relative to it
    # (a packing turning as a body with a slipping wall would fail the second check)
    assert np.mean(inner) > 0.1 * wall_speed
    assert abs(np.mean(outer)) < 0.2 * np.mean(inner)


def test_the_run_records_where_its_time_went(small_run):
    """The manifest's timing: one entry per frame taken from LAMMPS (the contact dump's
    frames), and the parts never add up to more than the run's own wall time."""
    from datetime import datetime
    m, _, _, contacts = load(small_run)
    t = m["timing"]
    assert t["frames"] == len(contacts)
    assert t["lammps_steps_s"] > 0 and t["frames_s"] > 0
    wall = (datetime.fromisoformat(m["finished"]) - datetime.fromisoformat(m["started"]))
    assert t["lammps_steps_s"] + t["frames_s"] <= wall.total_seconds() + 1.0   # 1 s: clock resolution


def test_each_overlap_is_the_two_disks_own_radii_minus_their_distance(run):
    """Geometry: overlap = r_1 + r_2 - |x_1 - x_2| from the atom dump's own positions and
    radii (sizes spread or not); wrong per-type radii would miss by up to 20% of d."""
    _, _, atoms, contacts = load(run)
    for fa, fc in zip(atoms[::4], contacts[::4]):
        c = dict(zip(COLUMNS, fc.data[fc.column("wall") == 0].T))
        row = {int(i): k for k, i in enumerate(fa.column("id"))}
        i1 = np.array([row[int(i)] for i in c["id1"]])
        i2 = np.array([row[int(i)] for i in c["id2"]])
        x, y, r = fa.column("x"), fa.column("y"), fa.column("radius")
        dist = np.hypot(x[i1] - x[i2], y[i1] - y[i2])
        assert np.allclose(c["overlap"], r[i1] + r[i2] - dist, rtol=0, atol=1e-9)


def test_sizes_follow_the_scene(run):
    """Each type's diameters are its nominal one (size_spread 0) or spread uniformly over
    d (1 +- size_spread): bounds respected and the spread used (the extremes are reached
    within 5% of the range for 250 disks)."""
    _, scene, atoms, _ = load(run)
    f = atoms[0]
    for typ, d in ((1, scene.d_s), (2, scene.d_l)):
        diam = 2 * f.column("radius")[f.column("type") == typ] / d
        s = scene.size_spread
        assert diam.min() >= 1 - s - 1e-12 and diam.max() <= 1 + s + 1e-12
        if s and typ == 1:
            assert diam.min() < 1 - 0.9 * s and diam.max() > 1 + 0.9 * s
        if not s:
            assert np.all(diam == 1.0)


def test_the_area_fraction_counts_the_spread(run):
    """The manifest's area fraction is the expected one, sum pi d^2 / 4 with <d^2> = d^2
    (1 + s^2 / 3) for a uniform spread s: the dumped disks cover it exactly with the
    nominal sizes, and to within 3 sampling errors of N random sizes (relative error of
    a mean d^2: 2 s / sqrt(3 N)) with a spread."""
    m, scene, atoms, _ = load(run)
    r = atoms[0].column("radius")
    measured = np.pi * np.sum(r**2) / (np.pi * (scene.R_o**2 - scene.R_i**2))
    tolerance = 3 * 2 * scene.size_spread / np.sqrt(3 * len(r)) + 1e-9
    assert m["derived"]["area_fraction"] == pytest.approx(measured, rel=tolerance)
