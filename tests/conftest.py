"""Shared helpers: the real CLI in a subprocess, and one small real Couette run."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

#: The preset the small cell derives from: the plain gran/hooke/history law, grown from
#: random positions (the shipped sheared packings are of the full cell).
SMALL_PRESET = "paper-hooke"
#: A few hundred disks at the paper's area fraction (0.8136) in a smaller annulus,
#: sheared faster (Omega = 0.5 rad/s) for 4 s so the drag shows in a short run.
SMALL_CELL = ["R_i=0.04", "R_o=0.0826", "n_small=250", "n_large=40", "Omega=0.5",
              "t_grow=1", "t_relax=1", "t_end=4", "t_dump_start=1", "dump_dt=0.25",
              "restart_dt=1"]


def run_cli(*args, timeout=600, **kwargs):
    """Run ``python -m granavg ARGS`` for real; returns the CompletedProcess."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.run([sys.executable, "-m", "granavg", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, env=env, **kwargs)


def dump_positions(run):
    """The disks' (x, y) in every frame of a run's atom dump, ordered by id; shape
    (frames, disks, 2)."""
    import numpy as np

    from granavg.io.reader import DumpReader

    out = []
    for frame in DumpReader(Path(run) / "atoms.dump.gz"):
        a = frame.as_dict()
        order = np.argsort(a["id"])
        out.append(np.stack([a["x"][order], a["y"][order]], axis=1))
    return np.asarray(out)


def small_cell_args(out, *extra_sets, np=1):
    sets = [a for s in (*SMALL_CELL, *extra_sets) for a in ("--set", s)]
    return ["simulate", "--preset", SMALL_PRESET, "--out", out, "--no-progress", "--np", np, *sets]


@pytest.fixture(scope="session")
def small_run(tmp_path_factory) -> Path:
    """One real LAMMPS run of the small cell (embedded mode), shared by several tests."""
    out = tmp_path_factory.mktemp("small") / "run"
    proc = run_cli(*small_cell_args(out))
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="session")
def pile3d_soft(tmp_path_factory) -> Path:
    """tests/decks/pile_3d_si.lmp at rest with k_n = 20 N/m (overlaps of 1-3% of a
    diameter near the floor), default %g dumps: one run per session."""
    from .test_3d_dumps import run_deck

    out = tmp_path_factory.mktemp("pile3d_soft")
    run_deck(out, kn=20.0)
    return out
