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
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def _segment(theta):
    """Area of a circular segment of half-angle theta over r^2: theta - sin cos.

    A series for thin segments, where the difference would cancel catastrophically.
    """
    if theta < 1e-2:
        t2 = theta * theta
        return theta * t2 * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (4.0 / 315.0)))
    return theta - math.sin(theta) * math.cos(theta)


@njit(cache=True, nogil=True, inline="always")
def _cut(r2, chord, x):
    """Area of the segment of a circle (radius^2 ``r2`` = chord^2 + x^2) cut off by a
    chord of half-length ``chord`` at distance ``x`` from its centre (x < 0: the larger
    part): r^2 theta - chord x with theta = atan2(chord, x), since sin theta cos theta =
    chord x / r^2. A thin segment (t = chord / x < 0.1, a ring's edge across a disk)
    takes the series (chord^3 / x) sum_k (-1)^k 2 t^2k / ((2k + 3)(2k + 1)) instead, with
    no arctangent and no cancellation (truncated after t^10: 1e-14 relative)."""
    if x > 10.0 * chord:
        t2 = (chord / x) * (chord / x)
        return chord * chord * chord / x * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (
            2.0 / 35.0 - t2 * (2.0 / 63.0 - t2 * (2.0 / 99.0 - t2 * (2.0 / 143.0))))))
    return r2 * math.atan2(chord, x) - chord * x


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
    return _cut(R * R, chord, x) + _cut(a * a, chord, d - x)


_area_scalar = njit(cache=True, nogil=True)(_area)


def area_inside_circle(d, a, R):
    """:func:`_area` over arrays (compiled on first use, not at import)."""
    return np.vectorize(_area_scalar, otypes=[float])(d, a, R)


area_inside_circle.__doc__ = _area.__doc__


@njit(cache=True, nogil=True, inline="always")
def _cumulative(mode, pos, a, edge):
    """Area of a disk (centre coordinate pos, radius a) on the inner side of a cell edge:
    inside the circle of radius ``edge`` (mode 0, rings) or below x = edge (mode 1,
    strips); mode 2: the volume of a sphere below x = edge (3D slabs)."""
    if mode == 0:
        return _area_scalar(pos, a, edge)
    if mode == 1:
        return _below(edge - pos, a)
    return _below_sphere(edge - pos, a)


@njit(cache=True, nogil=True)
def _triplets(pos, a, edges, mode):
    """(particle, cell, weight) of disks (or spheres, mode 2) in 1D cells, from
    differences of cumulative areas (volumes) at consecutive edges."""
    n = pos.shape[0]
    lo, hi = spans(edges, pos, a)
    particle, cell, w = buffers(np.sum(hi - lo) + n)
    t = 0
    for p in range(n):
        u, ap = pos[p], a[p]
        full = math.pi * ap * ap if mode < 2 else 4.0 / 3.0 * math.pi * ap * ap * ap
        inner = _cumulative(mode, u, ap, edges[lo[p]])
        for k in range(lo[p], hi[p] + 1):
            outer = _cumulative(mode, u, ap, edges[k + 1])
            wk = (outer - inner) / full
            inner = outer
            if wk > 0:
                particle[t], cell[t], w[t] = p, k, wk
                t += 1
    return particle[:t], cell[:t], w[:t]


@njit(cache=True, nogil=True, inline="always")
def buffers(size):
    """Empty (particle, cell, weight) arrays for at most ``size`` weights: the cells
    each particle's span reaches, counted beforehand, so the fill never grows them."""
    return np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)


@njit(cache=True, nogil=True, inline="always")
def span(edges, u, a):
    """The first and last cell of ``edges`` that [u - a, u + a] reaches (clamped)."""
    n = edges.shape[0] - 1
    lo = min(max(np.searchsorted(edges, u - a, side="right") - 1, 0), n - 1)
    hi = min(max(np.searchsorted(edges, u + a, side="left") - 1, 0), n - 1)
    return lo, hi


@njit(cache=True, nogil=True, inline="always")
def spans(edges, u, a):
    """:func:`span` of every particle: its first and last cell, shape (P,) each."""
    lo, hi = np.empty(u.shape[0], np.int64), np.empty(u.shape[0], np.int64)
    for p in range(u.shape[0]):
        lo[p], hi[p] = span(edges, u[p], a[p])
    return lo, hi


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
                     np.ascontiguousarray(edges, float), 0)


@njit(cache=True, nogil=True, inline="always")
def _below(u, a):
    """Area (m^2) of a disk of radius a (centre 0) with x < u: 0, a segment, or all of
    it; the smaller side is always the segment formula, so thin parts keep precision."""
    if u <= -a:
        return 0.0
    if u >= a:
        return math.pi * a * a
    if u < 0.0:
        return a * a * _segment(math.acos(-u / a))
    return math.pi * a * a - a * a * _segment(math.acos(u / a))


@njit(cache=True, nogil=True, inline="always")
def _below_sphere(u, a):
    """Volume of a sphere of radius a (centre 0) with x < u: 0, a cap, or all of it; the
    smaller side is always the cap pi h^2 (3a - h) / 3, so thin parts keep precision."""
    if u <= -a:
        return 0.0
    if u >= a:
        return 4.0 / 3.0 * math.pi * a * a * a
    if u < 0.0:
        h = a + u
        return math.pi * h * h * (3.0 * a - h) / 3.0
    h = a - u
    return 4.0 / 3.0 * math.pi * a * a * a - math.pi * h * h * (3.0 * a - h) / 3.0


@njit(cache=True, nogil=True, inline="always")
def below_fraction(u, a, dim):
    """Fraction of a disk (dim 2) or sphere (dim 3) of radius a, centre 0, with x < u."""
    if dim == 2:
        return _below(u, a) / (math.pi * a * a)
    return _below_sphere(u, a) / (4.0 / 3.0 * math.pi * a * a * a)


@njit(cache=True, nogil=True, inline="always")
def _antideriv(x, a):
    """Integral of sqrt(a^2 - x^2) dx from 0 to x (|x| <= a)."""
    return 0.5 * (x * math.sqrt(max(a * a - x * x, 0.0)) + a * a * math.asin(x / a))


@njit(cache=True, nogil=True, inline="always")
def _corner(X, Y, a):
    """Area (m^2) of a disk of radius a (centre 0) with x < X and y < Y, in closed form:
    the integral over x of the chord's part below Y."""
    if X <= -a or Y <= -a:
        return 0.0
    if Y >= a:
        return _below(X, a)
    if X >= a:
        return _below(Y, a)
    x1 = min(X, a)
    c = math.sqrt(a * a - Y * Y)
    area = 0.0
    if Y >= 0.0:                                  # full chords where |x| > c
        lo = min(x1, -c)
        area += 2.0 * (_antideriv(lo, a) - _antideriv(-a, a))
        if x1 > c:
            area += 2.0 * (_antideriv(x1, a) - _antideriv(c, a))
    if x1 > -c:                                   # chords cut at Y where |x| < c
        hi = min(x1, c)
        area += Y * (hi + c) + _antideriv(hi, a) - _antideriv(-c, a)
    return area


@njit(cache=True, nogil=True)
def _grid_triplets(x, y, a, xe, ye):
    ny = ye.shape[0] - 1
    I0, I1 = spans(xe, x, a)
    J0, J1 = spans(ye, y, a)
    particle, cell, w = buffers(np.sum((I1 - I0 + 1) * (J1 - J0 + 1)))
    t = 0
    for p in range(x.shape[0]):
        full = math.pi * a[p] * a[p]
        for i in range(I0[p], I1[p] + 1):
            xl, xh = xe[i] - x[p], xe[i + 1] - x[p]
            for j in range(J0[p], J1[p] + 1):
                yl, yh = ye[j] - y[p], ye[j + 1] - y[p]
                area = (_corner(xh, yh, a[p]) - _corner(xl, yh, a[p])
                        - _corner(xh, yl, a[p]) + _corner(xl, yl, a[p]))
                wk = area / full
                if wk > 0:
                    particle[t], cell[t], w[t] = p, i * ny + j, wk
                    t += 1
    return particle[:t], cell[:t], w[:t]


def strip_weights(u, a, edges):
    """Sparse weights of disks in strips [e_k, e_k+1) of one Cartesian coordinate.

    Parameters
    ----------
    u : ndarray, shape (P,)
        The disks' centre coordinate across the strips, m.
    a : ndarray, shape (P,)
        Radii, m.
    edges : ndarray, shape (n + 1,)
        Increasing strip edges, m.

    Returns
    -------
    particle, cell, w : ndarray, shape (T,)
        Disk index, strip index and the fraction of the disk's area in it (exact:
        differences of circular segments).
    """
    return _triplets(np.ascontiguousarray(u, float), np.ascontiguousarray(a, float),
                     np.ascontiguousarray(edges, float), 1)


def grid_weights(x, y, a, xedges, yedges):
    """Sparse weights of disks in the rectangles of a grid (cell k = i ny + j for column
    i of the x edges and row j of the y edges); the fraction of each disk's area in a
    rectangle, exact (corner areas in closed form, by inclusion-exclusion)."""
    return _grid_triplets(np.ascontiguousarray(x, float), np.ascontiguousarray(y, float),
                          np.ascontiguousarray(a, float), np.ascontiguousarray(xedges, float),
                          np.ascontiguousarray(yedges, float))
