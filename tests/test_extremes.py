"""Numerically sound at the extremes: the time-step bound, blow-ups, soft springs, and
inertial flow. Real LAMMPS runs of the small cell and real two-disk collisions."""

import json

import pytest

from granavg.sim.collision import elastic_head_on
from granavg.io.reader import DumpReader
from granavg.sim.scene import MIN_STEPS_PER_CONTACT

from .conftest import run_cli, small_cell_args

PHASES = (0.1, 0.5, 0.9)


@pytest.mark.parametrize("engine", ["lammps", "reference"])
def test_the_refusal_bound_keeps_an_elastic_collision_elastic(engine):
    """At the launcher's bound (n = t_c/dt = 10) the energy of an elastic frictionless
    collision is kept to 1%; at n = 2, which the launcher refuses, it is not (up to
    +115% here: the time step, not the contact law, decides the outcome)."""
    safe = [elastic_head_on(MIN_STEPS_PER_CONTACT, engine, f) for f in PHASES]
    assert all(r["separated"] and abs(r["energy_ratio"] - 1) < 0.01 for r in safe), safe
    unsafe = [elastic_head_on(2.0, engine, f)["energy_ratio"] for f in PHASES]
    assert max(abs(e - 1) for e in unsafe) > 0.2, unsafe


def test_a_blow_up_stops_the_run_and_keeps_what_was_written(tmp_path):
    """The inner ring at 300 rad/s (12 m/s at its surface) throws disks out of the cell:
    the deck's blow-up guard (fix halt) stops LAMMPS, granavg says so in one line."""
    out = tmp_path / "run"
    proc = run_cli(*small_cell_args(out, "Omega=300", "t_dump_start=0", "dump_dt=0.01"))
    assert proc.returncode == 2 and "blew up near step" in proc.stderr
    # one line of error; the run had started, so the forecast's line came before it
    lines = proc.stderr.strip().splitlines()
    assert "Traceback" not in proc.stderr and len(lines) == 2 and "expected wall time" in lines[0]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "failed"
    frames = list(DumpReader(out / "atoms.dump.gz", ["id"]))
    assert len(frames) >= 2                       # the frames before the blow-up are kept
    assert (out / "prepared.data").exists()


def test_soft_springs_report_the_largest_overlap_and_warn(small_run, tmp_path):
    normal = json.loads((small_run / "manifest.json").read_text())["overlap"]
    assert 0.0 < normal["max_over_d_s"] < normal["warn_above"]
    out = tmp_path / "soft"
    proc = run_cli(*small_cell_args(out, "k_n=0.05", "n_per_tc=20", "t_end=2"))
    assert proc.returncode == 0, proc.stderr
    soft = json.loads((out / "manifest.json").read_text())["overlap"]
    assert soft["max_over_d_s"] > soft["warn_above"] and "largest overlap" in proc.stderr


def test_inertial_flow_is_flagged(tmp_path):
    """At 40 rad/s the dynamic stress is no longer small against the static one."""
    out = tmp_path / "fast"
    proc = run_cli(*small_cell_args(out, "Omega=40", "t_end=1", "t_dump_start=0.2",
                                    "dump_dt=0.05"), "--average", "8", "--t-min", "0.2")
    assert proc.returncode == 0, proc.stderr
    assert "the flow is inertial" in proc.stderr


def test_the_overlap_warning_judges_the_averaging_window(tmp_path, caplog):
    """Frames of the discarded transient (a start from a data file, or from a packing
    made by another law) do not count for the warning; with no frame in the window,
    every frame does; the largest of all frames is recorded beside it."""
    import logging
    from types import SimpleNamespace

    import numpy as np

    from granavg.io.contacts import COLUMNS
    from granavg.sim.run_monitor import Overlaps

    derived = SimpleNamespace(scene=SimpleNamespace(d_s=0.01), dt=0.1, t_discard=1.0)

    def table(overlap):
        t = np.zeros((1, len(COLUMNS)))
        t[0, COLUMNS.index("overlap")] = overlap
        return t
    for frames, window, warned in (([(0, 0.0025), (20, 0.001)], 0.1, False),
                                   ([(0, 0.0025), (20, 0.0021)], 0.21, True),
                                   ([(0, 0.0025), (5, 0.001)], 0.25, True)):
        run = tmp_path / f"run{len(list(tmp_path.iterdir()))}"
        run.mkdir()
        (run / "manifest.json").write_text("{}")
        o = Overlaps(derived)
        for step, overlap in frames:
            o.add(table(overlap), step)
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            o.record(run)
        got = json.loads((run / "manifest.json").read_text())["overlap"]
        assert got["max_over_d_s"] == pytest.approx(window)
        assert got["max_over_d_s_all_frames"] == pytest.approx(0.25)
        assert ("largest overlap" in caplog.text) == warned
