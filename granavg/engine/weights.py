"""Exact volume weights w_V^p of disks in rings, strips and grids (Eq. 1): the wrappers of
the kernels compiled ahead of time (:mod:`granavg.engine._weights`).

The weight of disk p in the ring [r_lo, r_hi) is the fraction of its area inside the
ring, from the closed-form area of a disk inside a circle centred on the cell's axis
(the lens of two intersecting circles); not the centre-in-ring rule. A disk fully inside
the rings' span has weights summing to 1; the part of a disk outside
[edges[0], edges[-1]] is in no ring.
"""

from __future__ import annotations

import numpy as np

from granavg.engine._weights import area, areas, cut, grid_triplets, segment, spans, triplets

__all__ = ["area", "area_inside_circle", "cut", "grid_weights", "ring_weights", "segment",
           "spans", "strip_weights"]

_f = np.ascontiguousarray


def area_inside_circle(d, a, R):
    """Area (m^2) of a disk of radius ``a`` centred at distance ``d`` from the origin that
    lies inside the circle of radius ``R`` about the origin; arrays broadcast.

    pi a^2 if the disk is inside, 0 if outside, pi R^2 if the circle is inside the disk,
    else the lens: the two circular segments cut off by the common chord, r^2 theta -
    chord x each with theta = atan2(chord, x) (a thin segment, chord / x < 0.1, by its
    series with no arctangent and no cancellation: 1e-14 relative). The chord's
    half-length comes from the factored product (-d+a+R)(d+a-R)(d-a+R)(d+a+R), so thin
    lenses (R >> a) keep full relative precision.
    """
    d, a, R = np.broadcast_arrays(*(np.asarray(v, float) for v in (d, a, R)))
    out = np.empty(d.shape)
    areas(_f(d.ravel()), _f(a.ravel()), _f(R.ravel()), out.reshape(-1))
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
    return triplets(_f(r, float), _f(a, float), _f(edges, float), 0)


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
    return triplets(_f(u, float), _f(a, float), _f(edges, float), 1)


def grid_weights(x, y, a, xedges, yedges):
    """Sparse weights of disks in the rectangles of a grid (cell k = i ny + j for column
    i of the x edges and row j of the y edges); the fraction of each disk's area in a
    rectangle, exact (corner areas in closed form, by inclusion-exclusion)."""
    return grid_triplets(_f(x, float), _f(y, float), _f(a, float), _f(xedges, float),
                         _f(yedges, float))
