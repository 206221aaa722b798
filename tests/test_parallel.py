"""Averaging on dask: chunks of whole time blocks, merged, equal the serial pass bit for
bit; the chunk windows cover every frame once; the CLI path on a local cluster."""

import json

import numpy as np
import pandas as pd
import pytest

from granavg.pipeline.runs import average_run
from granavg.pipeline.on_dask import average_run_dask, chunk_windows
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.engine.spec import TimeAxis

from .conftest import run_cli


def test_chunk_windows_cover_every_frame_once_and_cut_at_blocks(small_run):
    m = read_manifest(small_run)
    steps = [f.timestep for f in DumpReader(small_run / "atoms.dump.gz", ["id"])]
    dt = m["derived"]["dt_s"]
    for t_min, block, n in ((1.0, 0.5, 3), (1.0, 0.25, 4), (2.0, 1.0, 8)):
        windows = chunk_windows(m, TimeAxis(t_min=t_min, block_time=block), n)
        assert 1 <= len(windows) <= n
        covered = [s for s in steps if any(a <= s <= b for a, b in windows)]
        assert covered == [s for s in steps if s * dt >= t_min]
        held = [[s for s in covered if a <= s <= b] for a, b in windows]
        assert sum(map(len, held)) == len(covered) and all(held)
        for one, two in zip(held[:-1], held[1:]):                  # no block split
            assert int((one[-1] * dt - t_min) / block + 1e-9) < int((two[0] * dt - t_min) / block + 1e-9)


def test_chunk_windows_hold_frames_off_the_manifests_dump_grid():
    """A frame between the dump interval's steps (a run continued with other dump
    settings) still falls in exactly one window: none is lost between two chunks."""
    m = {"derived": {"first_dump_step": 0, "n_shear_steps": 10_000, "dump_every_steps": 100,
                     "dt_s": 1e-3}}
    off = [50, 1050, 3333, 5001, 9999, 12_345]
    for t_min, n in ((0.0, 4), (0.04, 7), (1.0, 3)):
        windows = chunk_windows(m, TimeAxis(t_min=t_min, block_time=0.5), n)
        assert len(windows) == n
        for s in [*range(0, 10_001, 100), *off]:
            inside = sum(a <= s <= b for a, b in windows)
            assert inside == (s * 1e-3 >= t_min), (s, windows)


@pytest.mark.slow
def test_dask_chunks_equal_the_serial_average_bit_for_bit(small_run):
    opts = dict(bins=12, t_min=1.0, block_time=0.5)
    serial = average_run(small_run, progress=False, **opts)
    parallel = average_run_dask(small_run, workers=2, chunks=3, **opts)
    assert len(parallel.meta["dask"]["chunks"]) == 3
    assert parallel.n_frames == serial.n_frames
    for q in serial.values:
        assert np.array_equal(serial.values[q], parallel.values[q], equal_nan=True), q
        assert np.array_equal(serial.sem[q], parallel.sem[q], equal_nan=True), q
    assert np.array_equal(serial.flags, parallel.flags)
    # the frames' time series too (dask chunks cover the averaged window)
    window = serial.timeseries[serial.timeseries.t_s >= 1.0].reset_index(drop=True)
    assert parallel.timeseries.equals(window)


@pytest.mark.slow
def test_cli_average_on_local_workers(small_run, tmp_path):
    out = tmp_path / "p.csv"
    proc = run_cli("average", small_run, "--bins", "8", "--t-min", "1", "--workers", "2",
                   "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    serial = average_run(small_run, bins=8, t_min=1.0, progress=False).to_pandas()
    table = pd.read_csv(out)
    assert np.allclose(table["sigma_rr"], serial["sigma_rr"], rtol=1e-9, atol=0)
    meta = json.loads(out.with_name(out.name + ".json").read_text())
    assert meta["dask"]["workers"] == 2 and all(r > 0 for r in meta["dask"]["peak_rss_bytes_per_chunk"])
