"""The small Couette cell sheared by LAMMPS and by the reference DEM from one packing.

Both start from the ``prepared.data`` LAMMPS wrote for the shared small run (contacts
unloaded in both: data files hold no springs), with the rotating inner ring, and write
their dumps through the real CLI. Deterministic part: the two trajectories are the same
to dump precision until round-off differences (the order of force sums) grow
chaotically. Statistical part: after that horizon they are two realisations of one
experiment, and the ring profiles of the sheared band must agree within their standard
errors.
"""

import json
import math

import numpy as np
import pytest

from granavg.pipeline.runs import average_run
from granavg.io.reader import DumpReader

from .conftest import SMALL_CELL, run_cli, small_cell_args

#: Every test here reads two runs of the cell for 5 s (LAMMPS and the reference engine).
pytestmark = pytest.mark.slow

D = 0.00742
#: 5 s of shear at 0.5 rad/s, dumps every 0.05 s (the first at t = 0)
CELL = [*SMALL_CELL, "t_end=5", "t_dump_start=0", "dump_dt=0.05", "restart_dt=5"]


@pytest.fixture(scope="module")
def runs(small_run, tmp_path_factory):
    start = small_run / "prepared.data"
    assert start.is_file(), "the LAMMPS run wrote no prepared.data"
    out = {}
    for engine in ("lammps", "reference"):
        out[engine] = tmp_path_factory.mktemp(engine) / "run"
        proc = run_cli(*small_cell_args(out[engine], *CELL), "--start", start,
                       "--engine", engine)
        assert proc.returncode == 0, proc.stderr
    return out


def positions(run):
    frames = []
    for f in DumpReader(run / "atoms.dump.gz", ["id", "x", "y"]):
        assert np.all(np.diff(f.data[:, 0]) > 0)
        frames.append((f.timestep, f.data[:, 1:]))
    return frames


def test_same_start_same_trajectory_until_the_chaos_horizon(runs):
    lmp, ref = positions(runs["lammps"]), positions(runs["reference"])
    assert [s for s, _ in lmp] == [s for s, _ in ref] and len(lmp) == 101
    dev = np.array([np.abs(a - b).max() / D for (_, a), (_, b) in zip(lmp, ref)])
    t = 0.05 * np.arange(len(dev))
    horizon = t[np.argmax(dev > 1e-6)]
    print(f"max deviation / d: t <= 0.25 s {dev[t <= 0.25].max():.1e}; "
          f"1e-6 d at t = {horizon:.2f} s; at 5 s {dev[-1]:.2f}")
    assert dev[t <= 0.25].max() < 1e-9            # same trajectory (dumps hold 12 digits)
    assert horizon >= 0.5                           # round-off, not a physics difference
    assert dev[-1] > 1e-3                           # and chaos is real: a sheared packing


def canonical(rows):
    """Contact rows with id1 < id2 for disk pairs (either order is valid: swapping the
    disks flips the forces and the normal), sorted by (id1, id2)."""
    rows = rows.copy()
    swap = (rows[:, 2] == 0) & (rows[:, 0] > rows[:, 1])
    rows[swap, 0], rows[swap, 1] = rows[swap, 1], rows[swap, 0].copy()
    rows[swap, 3:9] *= -1.0
    return rows[np.lexsort((rows[:, 1], rows[:, 0]))]


def test_same_start_same_contact_forces(runs):
    """The first contact frame (t = 0, springs unloaded) and one 0.25 s later: the same
    contacts and the same forces (LAMMPS' pair/local against the reference's)."""
    def frames(run):
        return [f for f in DumpReader(run / "contacts.dump.gz") if f.timestep in (0, 1070)]
    pairs = list(zip(frames(runs["lammps"]), frames(runs["reference"])))
    assert len(pairs) == 2
    for a, b in pairs:
        assert a.columns == b.columns and len(a.data) > 100
        A, B = canonical(a.data), canonical(b.data)
        np.testing.assert_array_equal(A[:, :3], B[:, :3])          # id1 id2 wall
        scale = np.abs(A[:, 3:7]).max()
        assert np.abs(A[:, 3:7] - B[:, 3:7]).max() < 1e-8 * scale  # forces, N
        assert np.abs(A[:, 7:] - B[:, 7:]).max() < 1e-9            # normal; overlap / m


QUANTITIES = ["nu", "v_phi", "F_rr", "F_phiphi", "sigma_rr", "sigma_phiphi", "sigma_rphi",
              "coordination"]


def test_ring_profiles_of_the_shear_band_agree_within_standard_errors(runs):
    """Averaged from t = 1.5 s (past the horizon) in 8 rings, 0.35 s blocks. Compared in
    the rings that flow (v_phi > 0.1 Omega R_i): further out the packing hardly moves in
    5 s, so a time average there does not sample configurations and its standard error
    says nothing about another realisation."""
    prof = {k: average_run(run, bins=8, t_min=1.5, block_time=0.35, progress=False)
            for k, run in runs.items()}
    a, b = prof["lammps"], prof["reference"]
    scene = json.loads((runs["lammps"] / "manifest.json").read_text())["scene"]
    band = a.values["v_phi"] > 0.1 * scene["Omega"] * scene["R_i"]
    assert band.sum() >= 2 and band[0]
    worst = {}
    for q in QUANTITIES:
        z = (a.values[q] - b.values[q]) / np.hypot(a.sem[q], b.sem[q])
        worst[q] = float(np.abs(z[band]).max())
    print("largest |difference| / combined SEM in the band:",
          {q: round(w, 2) for q, w in worst.items()})
    assert all(math.isfinite(w) and w < 3.0 for w in worst.values()), worst
