"""The sectors of a cell for the errors' spatial replicas: kernels (compiled ahead of time,
:mod:`granavg.engine.cells._sectors`) giving each particle's sector, its two neighbours
and its exact volume share in each (:meth:`~granavg.engine.cells.base.Cells.sector_shares`).

A particle's share beyond a sector boundary is the exact fraction of its volume beyond
that boundary (a circular segment of a disk, a spherical cap of a sphere): the boundary
is a ray from the axis (a plane through it in 3D) for rings, shells and the polar grid,
a line (a plane) across a slab for its segments. The shares of a particle sum to 1, so
the sums over a cell's sectors are the cell's sums. A particle wider than a sector (or
around the axis) goes whole to its centre's sector, as does a point (radius 0: a wall's
contact point).
"""

from __future__ import annotations

import numpy as np

from granavg.engine.cells._sectors import ring_shares, segment_shares

__all__ = ["about_axis", "along_line", "ring_shares", "segment_shares"]


def about_axis(pos, a, center, k, dim):
    """:func:`ring_shares` of the particles at ``pos`` (x and y first) about ``center``."""
    x, y, a = (np.ascontiguousarray(v, float) for v in (pos[0], pos[1], a))
    return ring_shares(x, y, a, float(center[0]), float(center[1]), int(k), dim)


def along_line(u, a, span, k, dim):
    """:func:`segment_shares` of the coordinates ``u`` over ``span`` = (lo, hi)."""
    u, a = (np.ascontiguousarray(v, float) for v in (u, a))
    lo, hi = span
    return segment_shares(u, a, float(lo), float(hi - lo), int(k), dim)
