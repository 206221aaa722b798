"""Averaging at its edges, on the real small run: rings narrower than a disk, rings with
no disk (also rings outside the annulus), one frame only. Each gives a defined result:
a value, or NaN with a flag. (Rings without contacts and a singular fabric:
tests/test_engine_analytic.py; 10^4 frames in flat memory: benchmarks/averaging.py.)"""

import math

import numpy as np

from granavg.pipeline.runs import average_run
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest


def last_frame_time(run):
    dt = read_manifest(run)["derived"]["dt_s"]
    return list(DumpReader(run / "atoms.dump.gz", ["id"]))[-1].timestep * dt


def test_rings_narrower_than_a_disk_keep_the_exact_area_sum(small_run):
    """200 rings of 0.28 mm (a disk spans up to 33), from a diameter inside the inner
    wall to one outside the outer (disks overlap the wall disks a little): the sum of
    nu V is the disks' volume."""
    m = read_manifest(small_run)["scene"]
    t = last_frame_time(small_run)
    edges = np.linspace(m["R_i"] - m["d_s"], m["R_o"] + m["d_s"], 201)
    p = average_run(small_run, edges=edges, t_min=t, quantities=["nu"], progress=False)
    frame = list(DumpReader(small_run / "atoms.dump.gz", ["radius"]))[-1]
    disks = math.pi * m["h"] * np.sum(frame.data[:, 0] ** 2)
    assert (p.cells.edges[1] - p.cells.edges[0]) < 0.05 * m["d_s"]
    assert abs(np.sum(p.values["nu"] * p.cells.volume) / disks - 1) < 1e-12


def test_rings_without_disks_and_outside_the_annulus_are_nan_and_flagged(small_run):
    m = read_manifest(small_run)["scene"]
    edges = [0.0, 0.5 * m["R_i"], m["R_i"] - 0.004, *np.linspace(m["R_i"], m["R_o"], 5),
             m["R_o"] + 0.004, m["R_o"] + 0.02]
    p = average_run(small_run, edges=edges, t_min=1.0, progress=False)
    empty = np.array(["empty" in f for f in p.flags])
    assert list(np.flatnonzero(empty)) == [0, 1, 8]
    # 4 mm into the walls: only the parts of disks sitting in the dimples between the
    # wall disks (rough walls), a few percent
    assert 0 < p.values["nu"][2] < 0.1 and 0 < p.values["nu"][7] < 0.1
    for q in ("v_phi", "coordination", "eps_rr", "omega"):
        assert np.all(np.isnan(p.values[q][empty])) and np.all(np.isfinite(p.values[q][~empty])), q
    assert np.all(p.values["nu"][empty] == 0.0)            # no disk: zero density, defined


def test_one_frame_gives_values_without_errors_flagged(small_run):
    p = average_run(small_run, bins=8, t_min=last_frame_time(small_run), progress=False)
    assert p.n_frames == 1
    assert np.all(np.isfinite(p.values["nu"])) and np.all(np.isfinite(p.values["sigma_rr"]))
    assert np.all(np.isnan(p.sem["nu"])) and all("one_block" in f for f in p.flags)
