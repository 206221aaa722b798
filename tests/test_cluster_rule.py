"""`--workers` on one machine is never slower than one process (issue: all the cores):
where one process is as fast - frames of a whole engine chunk, a gzip stream, too little
work for the cluster's fixed cost (granavg.pipeline.on_dask's cost model) - the average
is done in this process, said in one line, with the same fields; the chunks are sized so
that each holds far more work than its own cost."""

import gzip
import json
import logging
import os

import numpy as np
import pytest

import granavg
from granavg.examples import couette_2d
from granavg.pipeline.on_dask import (CHUNK_WORK, CLUSTER_COST, ONE_CORE_RATE, chunk_count,
                                      one_process_reason, text_bytes)

from .helpers import run_cli


@pytest.fixture
def cost_model_on(monkeypatch):
    monkeypatch.setenv("GRANAVG_COST_MODEL", "on")


def sparse(path, size):
    """A file of ``size`` bytes that takes no disk (only its size is read)."""
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def test_a_gzip_files_text_size_comes_from_its_trailer(tmp_path):
    text = b"ITEM: TIMESTEP\n0\n" * 50_000
    gz = tmp_path / "a.dump.gz"
    gz.write_bytes(gzip.compress(text))
    plain = sparse(tmp_path / "b.dump", 12345)
    assert text_bytes([gz]) == len(text) and text_bytes([gz, plain]) == len(text) + 12345
    for k, size in enumerate((1000, 2500)):                  # one file per processor
        sparse(tmp_path / f"atoms.{k}.dump", size)
    assert text_bytes([tmp_path / "atoms.%.dump"]) == 3500


@pytest.mark.parametrize("workers", [2, 4, 16])
def test_the_cost_model_chooses_a_cluster_only_where_its_work_pays_its_cost(tmp_path, workers):
    """At the break-even size (work x (1 - 1/N) = a + b N) the answer flips: just below,
    one process (the line gives both seconds); just above, the cluster."""
    cost = CLUSTER_COST[0] + CLUSTER_COST[1] * workers
    even = cost / (1 - 1 / workers) * ONE_CORE_RATE
    below = sparse(tmp_path / "below.dump", int(0.98 * even))
    above = sparse(tmp_path / "above.dump", int(1.02 * even))
    said = one_process_reason([below], workers)
    assert said is not None and f"about {cost:.1f} s" in said
    assert one_process_reason([above], workers) is None
    assert "every core" in one_process_reason([above], workers, frame_particles=70_000)
    gz = tmp_path / "x.dump.gz"
    gz.write_bytes(gzip.compress(b"x"))
    assert "gzip stream" in one_process_reason([above, gz], workers)


def test_chunks_hold_at_least_a_chunks_worth_of_work(tmp_path, cost_model_on):
    def chunks(seconds, workers):
        path = sparse(tmp_path / f"{seconds}.dump", int(seconds * ONE_CORE_RATE))
        return chunk_count([path], workers)
    assert chunks(100 * CHUNK_WORK, 16) == 32                  # two per worker
    assert chunks(20 * CHUNK_WORK, 16) == 16                   # one per worker
    assert chunks(5.5 * CHUNK_WORK, 16) == 5                   # fewer than the workers
    assert chunks(0.2 * CHUNK_WORK, 16) == 1


def pile_series(tmp_path):
    """The example pile's frames as a dump.* series, and the CLI's arguments for it."""
    from granavg.examples import pile_3d

    frames = gzip.decompress(pile_3d.atoms.read_bytes()).decode().split("ITEM: TIMESTEP\n")
    for k, f in enumerate(frames[1:]):
        (tmp_path / f"dump.{k}.txt").write_text("ITEM: TIMESTEP\n" + f)
    return ["average", "--atoms", tmp_path / "dump.*.txt", "--slabs", "z", "--bins", 3,
            "--dt", 1e-5, "--quantities", "nu,v", "--no-progress"]


def test_a_small_series_on_workers_is_averaged_in_this_process_in_one_line(tmp_path,
                                                                          cost_model_on):
    """The example pile's frames as a dump.* series: far too little work for a cluster."""
    args = pile_series(tmp_path)
    one = run_cli(*args, "--out", tmp_path / "one.csv")
    two = run_cli(*args, "--workers", 2, "--out", tmp_path / "two.csv")
    assert one.returncode == two.returncode == 0, two.stderr
    said = [l for l in two.stderr.splitlines() if "averaging in this process" in l]
    assert len(said) == 1 and "s of work on one core" in said[0], two.stderr
    assert "--scheduler" in said[0]
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "two.csv").read_bytes()


def test_a_runs_gzip_dumps_on_workers_are_averaged_in_this_process(caplog, cost_model_on):
    with caplog.at_level(logging.INFO, logger="granavg"):
        two = granavg.average(couette_2d.run, workers=2, t_min=1.0, cells={"bins": 6})
    said = [m for m in caplog.messages if "averaging in this process" in m]
    assert len(said) == 1 and "one gzip stream" in said[0], caplog.messages
    assert "dask" not in two.meta
    one = granavg.average(couette_2d.run, t_min=1.0, cells={"bins": 6})
    for k in one.values:
        assert np.array_equal(one.values[k], two.values[k], equal_nan=True), k
        assert np.array_equal(one.sem[k], two.sem[k], equal_nan=True), k


@pytest.mark.slow
def test_a_running_cluster_is_used_by_scheduler_and_left_running(tmp_path):
    """--scheduler: the command averages on the given cluster's workers (the cost model
    does not overrule it) and leaves the cluster running for the next command."""
    from dask.distributed import Client, LocalCluster

    args = pile_series(tmp_path)
    one = run_cli(*args, "--out", tmp_path / "one.csv")
    assert one.returncode == 0, one.stderr
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        for k in range(2):
            proc = run_cli(*args, "--scheduler", cluster.scheduler_address,
                           "--out", tmp_path / f"c{k}.csv",
                           env=dict(os.environ, GRANAVG_COST_MODEL="on"))
            assert proc.returncode == 0, proc.stderr
            assert "averaging in this process" not in proc.stderr
            meta = json.loads((tmp_path / f"c{k}.csv.json").read_text())
            assert meta["dask"]["workers"] == 2, meta["dask"]
            a = granavg.read(tmp_path / "one.csv")
            b = granavg.read(tmp_path / f"c{k}.csv")
            for q in a.values:
                assert np.array_equal(a.values[q], b.values[q], equal_nan=True), q
        with Client(cluster) as client:                        # still there, both workers
            assert len(client.scheduler_info()["workers"]) == 2


def test_chunks_are_two_per_worker_with_the_cost_model_off(tmp_path):
    assert chunk_count([sparse(tmp_path / "a.dump", 1000)], 3) == 6


def test_the_cost_model_switch_is_checked_in_one_line(tmp_path):
    proc = run_cli(*pile_series(tmp_path), "--workers", 2, "--out", tmp_path / "x.csv",
                   env=dict(os.environ, GRANAVG_COST_MODEL="sometimes"))
    assert proc.returncode == 2, proc.stderr
    assert "GRANAVG_COST_MODEL='sometimes': give on" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
