"""Settings that cannot run soundly are refused with one line and exit code 2."""

import json

import pytest

from .conftest import run_cli, small_cell_args


@pytest.mark.parametrize("args, message", [
    (["--set", "n_per_tc=3"], "above the safe bound"),
    (["--set", "n_small=6000"], "cannot fit"),
    (["--preset", "bogus"], "unknown preset"),
    (["--set", "kn=10"], "unknown key"),
    (["--set", "k_n=stiff"], "expected a float"),
    (["--set", "e_n=1.2"], "e_n must be in (0, 1]"),
    (["--set", "R_o=0.05"], "R_i < R_o"),
    (["--set", "size_spread=0.4"], "size_spread must be in [0, 0.3]"),
    (["--set", "mu_base=-0.1"], "need mu_base >= 0 and v_base > 0"),
    (["--set", "mu_base=0.5", "--set", "v_base=1e-5"], "integrated soundly only below 2 per step"),
    (["--np", "0"], "--np and --omp must be >= 1"),
])
def test_bad_settings_are_refused_in_one_line(tmp_path, args, message):
    out = tmp_path / "run"
    proc = run_cli("simulate", "--out", out, *args)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr
    assert not out.exists()          # nothing was started


def test_time_step_refusal_names_the_largest_safe_step(tmp_path):
    proc = run_cli("simulate", "--out", tmp_path / "r", "--set", "n_per_tc=3")
    assert "set n_per_tc >= 10" in proc.stderr


def test_a_directory_holding_a_run_is_not_overwritten(small_run):
    before = {p: p.stat().st_mtime_ns for p in small_run.rglob("*")}
    proc = run_cli("simulate", "--out", small_run)
    assert proc.returncode == 2 and "already holds a run" in proc.stderr
    assert {p: p.stat().st_mtime_ns for p in small_run.rglob("*")} == before


def test_a_non_empty_directory_is_not_used(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    proc = run_cli("simulate", "--out", tmp_path)
    assert proc.returncode == 2 and "not empty" in proc.stderr
    assert (tmp_path / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_disks_that_cannot_be_inserted_stop_the_run_and_mark_it_failed(tmp_path):
    """Inserted at full size, a packing at area fraction 0.81 cannot be placed at random."""
    out = tmp_path / "run"
    proc = run_cli(*small_cell_args(out, "grow_from=1"))
    assert proc.returncode == 2 and "could be inserted" in proc.stderr
    lines = proc.stderr.strip().splitlines()     # the forecast, then one line of error
    assert len(lines) == 2 and "expected wall time" in lines[0]
    assert json.loads((out / "manifest.json").read_text())["status"] == "failed"
