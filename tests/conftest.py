"""Shared fixtures: one small real Couette run, each LAMMPS deck of tests/decks run once
per session for every set of variables that several modules read, and granavg's wheel
built once. The helpers (the real CLI in a subprocess, the decks' runners, dumps read
without granavg) live in tests/helpers.py and are re-exported here.

A session fixture's directory is read, never written, by the tests: they write their
outputs into their own tmp_path.

The tests' small dumps are averaged faster in one process than on a local dask cluster,
which `--workers` then skips (said in one line); GRANAVG_COST_MODEL=off keeps the
cluster (two chunks per worker) so that the tests of the dask path test it (the rule's
own tests set it on)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from .helpers import (SMALL_CELL, SMALL_PRESET, dump_positions, run_cli, run_pile2d,  # noqa: F401
                      run_pile3d, small_cell_args)

ROOT = Path(__file__).resolve().parent.parent
os.environ["GRANAVG_COST_MODEL"] = "off"


@pytest.fixture(scope="session")
def small_run(tmp_path_factory) -> Path:
    """One real LAMMPS run of the small cell (embedded mode), shared by several tests."""
    out = tmp_path_factory.mktemp("small") / "run"
    proc = run_cli(*small_cell_args(out))
    assert proc.returncode == 0, proc.stderr
    return out


# -- tests/decks/pile_2d_lj.lmp ------------------------------------------------------------

@pytest.fixture(scope="session")
def pile2d_run(tmp_path_factory):
    """tests/decks/pile_2d_lj.lmp with its defaults (k_n = 2000, a fix wall/gran floor, no
    ITEM: UNITS): (directory, LAMMPS' summed pair virial of the last dumped frame)."""
    out = tmp_path_factory.mktemp("pile2d")
    return out, run_pile2d(out)


@pytest.fixture(scope="session")
def pile2d(pile2d_run) -> Path:
    """The directory of :func:`pile2d_run`."""
    return pile2d_run[0]


@pytest.fixture(scope="session")
def pile2d_on_disks(tmp_path_factory) -> Path:
    """tests/decks/pile_2d_lj.lmp on a floor of fixed type-2 disks (k_n = 2000)."""
    out = tmp_path_factory.mktemp("pile2d_on_disks")
    run_pile2d(out, floor="disks")
    return out


# -- tests/decks/pile_3d_si.lmp ------------------------------------------------------------

@pytest.fixture(scope="session")
def pile3d_soft_run(tmp_path_factory):
    """tests/decks/pile_3d_si.lmp at rest with k_n = 20 N/m (overlaps of 1-3% of a
    diameter near the floor), default %g dumps: (directory, LAMMPS' summed pair virial
    of the last dumped frame)."""
    out = tmp_path_factory.mktemp("pile3d_soft")
    return out, run_pile3d(out, kn=20.0)


@pytest.fixture(scope="session")
def pile3d_soft(pile3d_soft_run) -> Path:
    """The directory of :func:`pile3d_soft_run`: one run per session."""
    return pile3d_soft_run[0]


@pytest.fixture(scope="session")
def pile3d_one(tmp_path_factory) -> Path:
    """tests/decks/pile_3d_si.lmp with k_n = 100 N/m, single dumps (atoms.dump,
    contacts.dump)."""
    out = tmp_path_factory.mktemp("pile3d_one")
    run_pile3d(out, kn=100.0)
    return out


@pytest.fixture(scope="session")
def pile3d_series(tmp_path_factory) -> Path:
    """The same run as :func:`pile3d_one` written one file per frame (atoms.<step>.txt,
    contacts.<step>.txt)."""
    out = tmp_path_factory.mktemp("pile3d_series")
    run_pile3d(out, series="yes", kn=100.0)
    return out


# -- granavg's wheel -----------------------------------------------------------------------

@pytest.fixture(scope="session")
def wheel(tmp_path_factory) -> Path:
    """granavg's wheel, built once per session (``pip wheel --no-deps``)."""
    wheels = tmp_path_factory.mktemp("wheels")
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w",
                            str(wheels), str(ROOT)], capture_output=True, text=True,
                           timeout=600)
    assert build.returncode == 0, build.stderr
    return next(wheels.glob("granavg-*.whl"))
