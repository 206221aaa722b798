"""The averaging engine: cells and exact weights (:mod:`granavg.engine.cells`, one
geometry per module; :mod:`granavg.cells` names them), smoothing kernels, per-frame
channels, time accumulators, fields (Eqs. 1-7), the quantities, errors and the verdict
on steadiness. Pure numpy and compiled kernels over in-memory arrays: it reads no file,
knows no manifest, no LAMMPS and no scene.

Public entry: :func:`average` of frames in memory over any cells.
"""

from granavg.engine.api import average

__all__ = ["average"]
