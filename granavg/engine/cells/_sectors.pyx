# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The sector kernels of :mod:`granavg.engine.cells.sectors`, compiled ahead of time (the
loops run with the GIL released)."""

import numpy as np

from libc.math cimport M_PI, atan2, cos, floor, sin
from libc.stdint cimport int64_t

from granavg.engine._geometry cimport below_fraction


def ring_shares(const double[::1] x, const double[::1] y, const double[::1] a, double cx,
                double cy, Py_ssize_t k, int dim):
    """Sector (of ``k`` equal angles about the axis through (cx, cy), from the +x
    direction counter-clockwise) of each particle's centre and its neighbours, and the
    particle's share in each; shapes (P, 3)."""
    cdef Py_ssize_t n = x.shape[0], p, s, b
    sector_, share_ = np.empty((n, 3), np.int64), np.zeros((n, 3))
    bounds_ = np.empty((k + 1, 2))
    cdef int64_t[:, ::1] sector = sector_
    cdef double[:, ::1] share = share_, bounds = bounds_
    cdef double width = 2.0 * M_PI / k
    cdef double narrow2 = sin(0.5 * width) ** 2   # a disk wider than this (a / r) spans a sector
    cdef double dx, dy, phi, r2, a2, d_lo, d_hi, lo, hi
    with nogil:
        for b in range(k + 1):                         # the boundary rays
            bounds[b, 0], bounds[b, 1] = cos(b * width), sin(b * width)
        for p in range(n):
            dx, dy = x[p] - cx, y[p] - cy
            phi = atan2(dy, dx)
            s = min(<Py_ssize_t>((phi + 2.0 * M_PI if phi < 0.0 else phi) / width), k - 1)
            sector[p, 0], sector[p, 1], sector[p, 2] = s, (s - 1 + k) % k, (s + 1) % k
            share[p, 0] = 1.0
            r2, a2 = dx * dx + dy * dy, a[p] * a[p]
            if a[p] <= 0.0 or r2 <= a2 or a2 >= narrow2 * r2:
                continue
            d_lo = dy * bounds[s, 0] - dx * bounds[s, 1]       # distances to the two rays
            d_hi = dx * bounds[s + 1, 1] - dy * bounds[s + 1, 0]
            if d_lo >= a[p] and d_hi >= a[p]:              # inside its sector (most disks)
                continue
            lo, hi = below_fraction(-d_lo, a[p], dim), below_fraction(-d_hi, a[p], dim)
            share[p, 0], share[p, 1], share[p, 2] = 1.0 - lo - hi, lo, hi
    return sector_, share_


def segment_shares(const double[::1] u, const double[::1] a, double lo, double length,
                   Py_ssize_t k, int dim):
    """As :func:`ring_shares` for segments [lo + i L/K, lo + (i+1) L/K) of a line; the
    first and last segments extend to infinity, so every disk's shares sum to 1."""
    cdef Py_ssize_t n = u.shape[0], p, s
    sector_, share_ = np.empty((n, 3), np.int64), np.zeros((n, 3))
    cdef int64_t[:, ::1] sector = sector_
    cdef double[:, ::1] share = share_
    cdef double width = length / k, below, above
    with nogil:
        for p in range(n):
            s = min(max(<Py_ssize_t>floor((u[p] - lo) / width), 0), k - 1)
            sector[p, 0], sector[p, 1], sector[p, 2] = s, max(s - 1, 0), min(s + 1, k - 1)
            if a[p] <= 0.0 or 2.0 * a[p] >= width:
                share[p, 0] = 1.0
                continue
            below = below_fraction(lo + s * width - u[p], a[p], dim) if s > 0 else 0.0
            above = below_fraction(u[p] - lo - (s + 1) * width, a[p], dim) if s < k - 1 else 0.0
            share[p, 0], share[p, 1], share[p, 2] = 1.0 - below - above, below, above
    return sector_, share_
