"""In-situ averaging (no files) against averaging the dumps, and under MPI with 2 ranks.

Both runs shear the shared small run's prepared packing (``--start``) for 5 s, frames
every 0.05 s, averaged from t = 1.5 s over 8 rings. The serial run also writes dumps, so
its in-situ profiles can be held to the dump average of the same run; the 2-rank run
writes no dumps at all.
"""

import json

import numpy as np
import pytest

from granavg.pipeline.runs import average_run
from granavg.io.profiles_io import read_profiles

from .conftest import SMALL_CELL, run_cli, small_cell_args

CELL = [*SMALL_CELL, "t_end=5", "t_dump_start=0", "dump_dt=0.05", "restart_dt=5"]
AVERAGE = ["--average", "8", "--t-min", "1.5", "--block-time", "0.35"]


@pytest.fixture(scope="module")
def runs(small_run, tmp_path_factory):
    start = small_run / "prepared.data"
    out = {}
    for name, extra, np_, cli in (("serial", [], 1, []), ("mpi2", ["dumps=0"], 2, []),
                                  ("nu_v", ["dumps=0"], 1, ["--quantities", "nu,v"]),
                                  ("windows", [], 1, ["--windows", "1.0", "--t-max", "4.5"])):
        out[name] = tmp_path_factory.mktemp(name) / "run"
        proc = run_cli(*small_cell_args(out[name], *CELL, *extra, np=np_), "--start", start,
                       *AVERAGE, *cli)
        assert proc.returncode == 0, proc.stderr
    return out


def test_in_situ_equals_averaging_the_dumps_of_the_same_run(runs):
    insitu = read_profiles(runs["serial"] / "profiles_8.csv")
    dumps = average_run(runs["serial"], bins=8, t_min=1.5, block_time=0.35, progress=False)
    assert insitu.n_frames == dumps.n_frames > 60
    assert set(insitu.values) == set(dumps.values)
    for q, v in dumps.values.items():
        scale = np.nanmax(np.abs(v)) + 1e-300
        # the dumps hold 12 significant digits; in situ has LAMMPS' doubles
        assert np.nanmax(np.abs(insitu.values[q] - v)) < 1e-8 * scale, q
        assert np.nanmax(np.abs(insitu.sem[q] - dumps.sem[q])) < 1e-6 * scale, q
    # the same state frame by frame (time series), from LAMMPS' memory and from the dumps
    a, b = insitu.timeseries, dumps.timeseries
    assert list(a.step) == list(b.step) and len(a) > 60
    for col in ("C", "C_bulk", "rattler_fraction", "P_bulk_Pa", "psi6_bulk", "ke_J"):
        assert np.allclose(a[col], b[col], rtol=1e-6, atol=1e-12), col


def test_in_situ_windows_equal_the_windows_of_the_dumps(runs):
    """Fields in time in situ: the same windows as averaging the run's dumps with the
    same options (to the dumps' rounding)."""
    insitu = read_profiles(runs["windows"] / "profiles_8.csv")
    dumps = average_run(runs["windows"], bins=8, t_min=1.5, block_time=0.35,
                        windows=1.0, t_max=4.5, progress=False)
    assert insitu.dims == ("time", "r") and list(insitu.times) == [2.0, 3.0, 4.0]
    # the frames in [1.5, 2.5), [2.5, 3.5) and [3.5, 4.5] by their times (time step x dt)
    t = np.array(dumps.timeseries.t_s)
    expected = [np.sum((t >= 1.5) & (t < 2.5)), np.sum((t >= 2.5) & (t < 3.5)),
                np.sum((t >= 3.5) & (t <= 4.5))]
    assert list(insitu.n_frames) == list(dumps.n_frames) == expected
    assert 19 <= min(expected) <= max(expected) <= 21
    for q, v in dumps.values.items():
        scale = np.nanmax(np.abs(v)) + 1e-300
        assert np.nanmax(np.abs(insitu.values[q] - v)) < 1e-8 * scale, q


def test_two_ranks_write_no_dumps_and_the_same_manifest(runs):
    files = {p.name for p in runs["mpi2"].iterdir()}
    assert "profiles_8.csv" in files and not any(".dump" in f for f in files)
    m1, m2 = (json.loads((runs[k] / "manifest.json").read_text()) for k in ("serial", "mpi2"))
    assert m2["status"] == "complete" and m2["execution"]["np"] == 2
    differ = {k for k in m1 if m1[k] != m2[k]}
    # the largest overlap is a maximum over two realisations: recorded in both; the
    # forecast differs with the processes and the frames written
    assert differ <= {"execution", "started", "finished", "scene", "files", "overlap",
                      "timing", "forecast"}, differ
    assert 0 < m2["overlap"]["max_over_d_s"] < m2["overlap"]["warn_above"]
    assert {k for k in m1["scene"] if m1["scene"][k] != m2["scene"][k]} == {"dumps"}


def test_a_run_for_density_and_velocity_takes_no_contacts_and_gets_the_same_answer(runs):
    """--quantities nu,v: LAMMPS computes no contact output (contacts off in the scene,
    no overlap record, no contact frames), only nu and v are averaged, and they are the
    full run's values: the trajectory does not depend on what is taken from it."""
    m = json.loads((runs["nu_v"] / "manifest.json").read_text())
    assert m["scene"]["contacts"] is False and "overlap" not in m
    assert m["average"]["spec"]["quantities"] == ["nu", "v"]
    slim = read_profiles(runs["nu_v"] / "profiles_8.csv")
    full = read_profiles(runs["serial"] / "profiles_8.csv")
    assert set(slim.values) == {"nu", "v_r", "v_phi"}
    for q, v in slim.values.items():
        np.testing.assert_array_equal(v, full.values[q], err_msg=q)
        np.testing.assert_array_equal(slim.sem[q], full.sem[q], err_msg=q)


QUANTITIES = ["nu", "v_phi", "F_rr", "F_phiphi", "sigma_rr", "sigma_phiphi", "sigma_rphi",
              "coordination"]


def test_two_ranks_give_the_same_profiles_within_standard_errors(runs):
    """Same start: equal until round-off (a different order of force sums across ranks)
    grows chaotically; then two realisations, compared in the flowing band as in
    tests/test_refdem_couette.py."""
    a, b = (read_profiles(runs[k] / "profiles_8.csv") for k in ("serial", "mpi2"))
    m = json.loads((runs["serial"] / "manifest.json").read_text())["scene"]
    band = a.values["v_phi"] > 0.1 * m["Omega"] * m["R_i"]
    assert band.sum() >= 2
    worst = {q: float(np.nanmax(np.abs((a.values[q] - b.values[q])
                                        / np.hypot(a.sem[q], b.sem[q]))[band]))
             for q in QUANTITIES}
    print("largest |1 rank - 2 ranks| / combined SEM in the band:",
          {q: round(w, 2) for q, w in worst.items()})
    assert max(worst.values()) < 3.0, worst


@pytest.mark.parametrize("args,message", [
    (["--set", "dumps=0"], "add --average"),
    (["--average", "8", "--t-min", "100"], "after the end of shear"),
    (["--average", "0"], "ring counts must be >= 1"),
    (["--quantities", "nu,pressure"], "unknown quantity 'pressure'"),
    (["--quantities", "sigma", "--set", "contacts=0"], "sigma needs contact forces"),
])
def test_in_situ_refusals(tmp_path, args, message):
    proc = run_cli(*small_cell_args(tmp_path / "r"), *args)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
def test_in_situ_with_base_plate_friction_gives_the_body_force_of_the_dumps(tmp_path):
    """The demo scene's base-plate friction (a body force computed from the disks'
    velocities, with masses from the rings' disk volumes) averaged in situ equals the
    same run's dump average: the in-situ averager carries the cells it weighs with."""
    out = tmp_path / "run"
    proc = run_cli("simulate", "--preset", "demo", "--out", out, "--set", "t_end=1.5",
                   "--set", "dump_dt=0.25", "--average", "6", "--t-min", "0.5",
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    insitu = read_profiles(out / "profiles_6.csv")
    dumps = average_run(out, bins=6, t_min=0.5, progress=False)
    assert "body_phi" in insitu.values and np.all(insitu.values["body_phi"] != 0)
    scale = np.max(np.abs(dumps.values["body_phi"]))
    assert np.max(np.abs(insitu.values["body_phi"] - dumps.values["body_phi"])) < 1e-8 * scale
