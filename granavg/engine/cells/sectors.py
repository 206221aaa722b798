"""The sectors of a cell for the errors' spatial replicas: compiled kernels giving each
particle's sector, its two neighbours and its exact volume share in each
(:meth:`~granavg.engine.cells.base.Cells.sector_shares`).

A particle's share beyond a sector boundary is the exact fraction of its volume beyond
that boundary (a circular segment of a disk, a spherical cap of a sphere): the boundary
is a ray from the axis (a plane through it in 3D) for rings, shells and the polar grid,
a line (a plane) across a slab for its segments. The shares of a particle sum to 1, so
the sums over a cell's sectors are the cell's sums. A particle wider than a sector (or
around the axis) goes whole to its centre's sector, as does a point (radius 0: a wall's
contact point).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from granavg.engine.weights import below_fraction


@njit(cache=True, nogil=True)
def ring_shares(x, y, a, cx, cy, k, dim):
    """Sector (of ``k`` equal angles about the axis through (cx, cy), from the +x
    direction counter-clockwise) of each particle's centre and its neighbours, and the
    particle's share in each; shapes (P, 3)."""
    n = x.shape[0]
    sector = np.empty((n, 3), np.int64)
    share = np.zeros((n, 3))
    width = 2.0 * math.pi / k
    narrow2 = math.sin(0.5 * width) ** 2   # a disk wider than this (a / r) spans a sector
    cos_b = np.cos(np.arange(k + 1) * width)             # the boundary rays
    sin_b = np.sin(np.arange(k + 1) * width)
    for p in range(n):
        dx, dy = x[p] - cx, y[p] - cy
        phi = math.atan2(dy, dx)
        s = min(int((phi + 2.0 * math.pi if phi < 0.0 else phi) / width), k - 1)
        sector[p, 0], sector[p, 1], sector[p, 2] = s, (s - 1) % k, (s + 1) % k
        share[p, 0] = 1.0
        r2, a2 = dx * dx + dy * dy, a[p] * a[p]
        if a[p] <= 0.0 or r2 <= a2 or a2 >= narrow2 * r2:
            continue
        d_lo = dy * cos_b[s] - dx * sin_b[s]               # distances to the two rays
        d_hi = dx * sin_b[s + 1] - dy * cos_b[s + 1]
        if d_lo >= a[p] and d_hi >= a[p]:              # inside its sector (most disks)
            continue
        lo, hi = below_fraction(-d_lo, a[p], dim), below_fraction(-d_hi, a[p], dim)
        share[p, 0], share[p, 1], share[p, 2] = 1.0 - lo - hi, lo, hi
    return sector, share


@njit(cache=True, nogil=True)
def segment_shares(u, a, lo, length, k, dim):
    """As :func:`ring_shares` for segments [lo + i L/K, lo + (i+1) L/K) of a line; the
    first and last segments extend to infinity, so every disk's shares sum to 1."""
    n = u.shape[0]
    sector = np.empty((n, 3), np.int64)
    share = np.zeros((n, 3))
    width = length / k
    for p in range(n):
        s = min(max(int(math.floor((u[p] - lo) / width)), 0), k - 1)
        sector[p, 0], sector[p, 1], sector[p, 2] = s, max(s - 1, 0), min(s + 1, k - 1)
        if a[p] <= 0.0 or 2.0 * a[p] >= width:
            share[p, 0] = 1.0
            continue
        below = below_fraction(lo + s * width - u[p], a[p], dim) if s > 0 else 0.0
        above = below_fraction(u[p] - lo - (s + 1) * width, a[p], dim) if s < k - 1 else 0.0
        share[p, 0], share[p, 1], share[p, 2] = 1.0 - below - above, below, above
    return sector, share


def about_axis(pos, a, center, k, dim):
    """:func:`ring_shares` of the particles at ``pos`` (x and y first) about ``center``."""
    x, y, a = (np.ascontiguousarray(v, float) for v in (pos[0], pos[1], a))
    return ring_shares(x, y, a, float(center[0]), float(center[1]), int(k), dim)


def along_line(u, a, span, k, dim):
    """:func:`segment_shares` of the coordinates ``u`` over ``span`` = (lo, hi)."""
    u, a = (np.ascontiguousarray(v, float) for v in (u, a))
    lo, hi = span
    return segment_shares(u, a, float(lo), float(hi - lo), int(k), dim)
