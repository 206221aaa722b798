"""--resume continues an interrupted run to the same final step, frames neither lost nor doubled."""

import json
import signal
import subprocess
import sys
import time

import pytest

from granavg.io.run_directory import frame_steps

from .conftest import run_cli, small_cell_args

LONGER = ["t_end=6", "restart_dt=0.5"]


def start_and_stop(out, sig):
    """Start the small cell, and send ``sig`` once four restart files exist (t = 2 s)."""
    proc = subprocess.Popen([sys.executable, "-m", "granavg", *map(str, small_cell_args(out, *LONGER))],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    while len(list((out / "restart").glob("*.bin"))) < 4:
        assert proc.poll() is None, proc.communicate()[1]
        assert time.time() < deadline
        time.sleep(0.05)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_resume_after_interruption_reaches_the_same_final_step(tmp_path, sig):
    out = tmp_path / "run"
    code, err = start_and_stop(out, sig)
    manifest = json.loads((out / "manifest.json").read_text())
    if sig == signal.SIGTERM:            # a clean stop says so and how to continue
        assert code == 2 and "--resume" in err and "Traceback" not in err
        assert manifest["status"] == "interrupted"
    else:                                # a hard kill leaves the run marked as running
        assert code == -signal.SIGKILL and manifest["status"] == "running"
    assert frame_steps(out / "atoms.dump.gz")[-1] < manifest["derived"]["n_shear_steps"]

    proc = run_cli("simulate", "--out", out, "--resume", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    d = manifest["derived"]
    expected = list(range(d["first_dump_step"], d["n_shear_steps"] + 1, d["dump_every_steps"]))
    assert manifest["status"] == "complete" and len(manifest["resumed"]) == 1
    assert frame_steps(out / "atoms.dump.gz") == expected
    assert frame_steps(out / "contacts.dump.gz") == expected
    assert (out / "log.1.lammps").exists() and (out / "log.lammps").exists()


def test_resume_of_a_complete_run_is_refused(small_run):
    proc = run_cli("simulate", "--out", small_run, "--resume")
    assert proc.returncode == 2 and "already complete" in proc.stderr
