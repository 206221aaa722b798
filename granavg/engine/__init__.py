"""The averaging engine: cell geometry and exact weights, per-frame channels, time
accumulators, profiles (Eqs. 1-7), errors and the per-frame state. Pure numpy/numba over
in-memory arrays: it reads no file, knows no manifest and no LAMMPS.

Public API: :func:`average` over disks in :class:`Rings`, :class:`Slabs` or
:class:`Grid` (2D), or spheres in :class:`Slabs3D`, :class:`Boxes` or :class:`Shells`
(3D).
"""

from granavg.engine.api import average
from granavg.engine.cells3d import Boxes, Shells, Slabs3D
from granavg.engine.geometry import Grid, Rings, Slabs

__all__ = ["average", "Rings", "Slabs", "Grid", "Slabs3D", "Boxes", "Shells"]
