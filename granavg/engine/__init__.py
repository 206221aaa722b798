"""The averaging engine: cells and exact weights (:mod:`granavg.engine.cells`, one
geometry per module), per-frame channels, time accumulators, profiles (Eqs. 1-7), the
quantities, errors and the verdict on steadiness. Pure numpy/numba over in-memory
arrays: it reads no file, knows no manifest, no LAMMPS and no scene.

Public API: :func:`average` over disks in :class:`Rings`, :class:`Slabs`, :class:`Grid` or
:class:`PolarGrid` (2D), or spheres in :class:`Slabs3D`, :class:`Boxes` or
:class:`Shells` (3D).
"""

from granavg.engine.api import average
from granavg.engine.cells.boxes import Boxes
from granavg.engine.cells.grid import Grid
from granavg.engine.cells.polar_grid import PolarGrid
from granavg.engine.cells.rings import Rings
from granavg.engine.cells.shells import Shells
from granavg.engine.cells.slabs import Slabs
from granavg.engine.cells.slabs3d import Slabs3D

__all__ = ["average", "Rings", "Slabs", "Grid", "PolarGrid", "Slabs3D", "Boxes", "Shells"]
