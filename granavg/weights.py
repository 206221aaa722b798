"""Exact volume weights w_V^p of disks in rings (Eq. 1): compiled kernels.

The weight of disk p in the ring [r_lo, r_hi) is the fraction of its area inside the
ring, from the closed-form area of a disk inside a circle centred on the cell's axis
(the lens of two intersecting circles); not the centre-in-ring rule. A disk fully inside
the rings' span has weights summing to 1; the part of a disk outside
[edges[0], edges[-1]] is in no ring.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize


@njit(cache=True, nogil=True, inline="always")
def _segment(theta):
    """Area of a circular segment of half-angle theta over r^2: theta - sin cos.

    A series for thin segments, where the difference would cancel catastrophically.
    """
    if theta < 1e-2:
        t2 = theta * theta
        return theta * t2 * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (4.0 / 315.0)))
    return theta - math.sin(theta) * math.cos(theta)


def _area(d, a, R):
    """Area (m^2) of a disk of radius ``a`` centred at distance ``d`` from the origin that
    lies inside the circle of radius ``R`` about the origin; a numpy ufunc.

    pi a^2 if the disk is inside, 0 if outside, pi R^2 if the circle is inside the disk,
    else the lens: the two circular segments cut off by the common chord. The chord's
    half-length comes from the factored product (-d+a+R)(d+a-R)(d-a+R)(d+a+R) and the
    angles from atan2, so thin lenses (R >> a) keep full relative precision.
    """
    if d + a <= R:
        return math.pi * a * a
    if R <= a - d:
        return math.pi * R * R
    if d >= R + a or d <= abs(R - a):
        return 0.0
    k = (-d + a + R) * (d + a - R) * (d - a + R) * (d + a + R)
    chord = 0.5 * math.sqrt(max(k, 0.0)) / d
    x = (d * d + R * R - a * a) / (2.0 * d)
    return (R * R * _segment(math.atan2(chord, x))
            + a * a * _segment(math.atan2(chord, d - x)))


_area_scalar = njit(cache=True, nogil=True)(_area)
area_inside_circle = vectorize(["float64(float64, float64, float64)"], cache=True)(_area)
area_inside_circle.__doc__ = _area.__doc__


@njit(cache=True, nogil=True)
def _triplets(r, a, edges):
    n_rings = edges.shape[0] - 1
    cap = r.shape[0] * 4
    particle = np.empty(cap, np.int64)
    ring = np.empty(cap, np.int64)
    w = np.empty(cap)
    t = 0
    for p in range(r.shape[0]):
        lo = np.searchsorted(edges, r[p] - a[p], side="right") - 1
        hi = np.searchsorted(edges, r[p] + a[p], side="left") - 1
        lo = min(max(lo, 0), n_rings - 1)
        hi = min(max(hi, 0), n_rings - 1)
        full = math.pi * a[p] * a[p]
        inner = _area_scalar(r[p], a[p], edges[lo])
        for k in range(lo, hi + 1):
            outer = _area_scalar(r[p], a[p], edges[k + 1])
            wk = (outer - inner) / full
            inner = outer
            if wk > 0:
                if t == cap:                     # more rings per disk than expected
                    cap *= 2
                    particle = _grow(particle, cap)
                    ring = _grow(ring, cap)
                    w = _grow(w, cap)
                particle[t], ring[t], w[t] = p, k, wk
                t += 1
    return particle[:t], ring[:t], w[:t]


@njit(cache=True, nogil=True)
def _grow(arr, cap):
    out = np.empty(cap, arr.dtype)
    out[:arr.shape[0]] = arr
    return out


def ring_weights(r, a, edges):
    """Sparse weights of disks in rings.

    Parameters
    ----------
    r : ndarray, shape (P,)
        Distance of each disk's centre from the axis, m.
    a : ndarray, shape (P,)
        Disk radii, m.
    edges : ndarray, shape (n_rings + 1,)
        Increasing ring edges, m.

    Returns
    -------
    particle, ring : ndarray of int, shape (T,)
        Disk index and ring index of each non-zero weight.
    w : ndarray, shape (T,)
        Fraction of the disk's area in that ring (0 < w <= 1).
    """
    return _triplets(np.ascontiguousarray(r, float), np.ascontiguousarray(a, float),
                     np.ascontiguousarray(edges, float))
