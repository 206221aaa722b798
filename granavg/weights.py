"""Exact volume weights w_V^p of disks in rings (Eq. 1): pure numpy kernels.

The weight of disk p in the ring [r_lo, r_hi) is the fraction of its area inside the
ring, from the closed-form area of a disk inside a circle centred on the cell's axis
(the lens area of two intersecting circles); not the centre-in-ring rule. A disk fully
inside the rings' span has weights summing to 1; the part of a disk outside
[edges[0], edges[-1]] is in no ring.
"""

from __future__ import annotations

import numpy as np


def _segment(theta):
    """Area of a circular segment of half-angle theta over r^2: theta - sin(theta) cos(theta).

    A series for thin segments, where the difference would cancel catastrophically.
    """
    t2 = theta * theta
    series = theta * t2 * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (4.0 / 315.0)))
    return np.where(theta < 1e-2, series, theta - np.sin(theta) * np.cos(theta))


def area_inside_circle(d, a, R):
    """Area of a disk of radius ``a`` centred at distance ``d`` from the origin that lies
    inside the circle of radius ``R`` about the origin (m^2).

    Parameters
    ----------
    d, a, R : array_like
        Broadcastable; lengths in m, ``a > 0``, ``d >= 0``, ``R >= 0``.

    Returns
    -------
    ndarray
        pi a^2 if the disk is inside, 0 if outside, pi R^2 if the circle is inside the
        disk, else the lens: the two circular segments cut off by the common chord. The
        chord's half-length comes from the factored product
        (-d+a+R)(d+a-R)(d-a+R)(d+a+R) and the angles from atan2, so thin lenses
        (R >> a) keep full relative precision.
    """
    d, a, R = np.broadcast_arrays(np.asarray(d, float), np.asarray(a, float),
                                  np.asarray(R, float))
    out = np.where(d + a <= R, np.pi * a * a, 0.0)
    out = np.where(R <= a - d, np.pi * R * R, out)
    lens = (np.abs(R - a) < d) & (d < R + a)
    if np.any(lens):
        dl, al, Rl = d[lens], a[lens], R[lens]
        k = (-dl + al + Rl) * (dl + al - Rl) * (dl - al + Rl) * (dl + al + Rl)
        chord = 0.5 * np.sqrt(np.maximum(k, 0.0)) / dl       # half-length of the chord
        x = (dl * dl + Rl * Rl - al * al) / (2 * dl)        # origin -> chord distance
        out[lens] = (Rl * Rl * _segment(np.arctan2(chord, x))
                     + al * al * _segment(np.arctan2(chord, dl - x)))
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
    n_rings = len(edges) - 1
    lo = np.clip(np.searchsorted(edges, r - a, side="right") - 1, 0, n_rings - 1)
    hi = np.clip(np.searchsorted(edges, r + a, side="left") - 1, 0, n_rings - 1)
    count = np.maximum(hi - lo + 1, 0)
    particle = np.repeat(np.arange(len(r)), count)
    ring = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(count.sum())
    rp, ap = r[particle], a[particle]
    w = (area_inside_circle(rp, ap, edges[ring + 1])
         - area_inside_circle(rp, ap, edges[ring])) / (np.pi * ap * ap)
    keep = w > 0
    return particle[keep], ring[keep], w[keep]
