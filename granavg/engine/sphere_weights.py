"""Exact volume weights w_V^p of spheres in 3D cells (Eq. 1): the wrappers of the kernels
compiled ahead of time (:mod:`granavg.engine._sphere_weights`).

The weight of sphere p in a cell is the fraction of its volume inside the cell:

- **slabs** (cells between parallel planes): differences of spherical caps, closed form
  (:func:`layer_weights`);
- **boxes**: differences, over the box's 8 corners, of the volume of the sphere with
  x < X, y < Y, z < Z, in closed form: by inclusion-exclusion from the volumes beyond
  one, two and three planes, the last two the integral over z of the area of a disk
  beyond two lines (antiderivatives with acos, asin and atan; ``_beyond3`` of
  ``_sphere_weights.pyx``);
- **cylindrical shells** (rings about the z axis times layers in z): the integral over
  z of the exact area of the sphere's slice, a disk of radius sqrt(a^2 - t^2), inside
  each ring (the 2D lens of :mod:`granavg.engine.weights`), by Gauss-Legendre quadrature
  on the pieces between the layers' edges and the heights where the slice touches a ring
  edge, each mapped by t = t0 + (t1 - t0)(1 - cos(pi s))/2 so that the square-root
  kinks at the piece's ends become smooth: converged to below 1e-10 of the sphere's
  volume with :data:`NODES` nodes (tests/test_sphere_weights.py).

Every weight is a difference of cumulative volumes at consecutive cell edges, so the
weights of a sphere fully inside the cells' span sum to 1 to round-off.
"""

from __future__ import annotations

import numpy as np

from granavg.engine._sphere_weights import below3, box_triplets, shell_triplets
from granavg.engine._weights import triplets

__all__ = ["NODES", "below3", "box_weights", "layer_weights", "shell_weights"]

#: Gauss-Legendre nodes per piece of the shells' quadrature: 32 agree with 64 to 6e-11
#: of a sphere's volume (16: 1e-8; tests/test_sphere_weights.py).
NODES = 32
_GL_X, _GL_W = np.polynomial.legendre.leggauss(NODES)
#: The nodes and weights on [0, 1] after the map s -> (1 - cos(pi s)) / 2.
_MAP_T = 0.5 * (1.0 - np.cos(np.pi * 0.5 * (_GL_X + 1.0)))
_MAP_W = 0.5 * _GL_W * 0.5 * np.pi * np.sin(np.pi * 0.5 * (_GL_X + 1.0))


def layer_weights(u, a, edges):
    """Sparse weights of spheres in slabs [e_k, e_k+1) of one Cartesian coordinate:
    differences of spherical caps (exact).

    Parameters
    ----------
    u : ndarray, shape (P,)
        The spheres' centre coordinate across the slabs.
    a : ndarray, shape (P,)
        Radii.
    edges : ndarray, shape (n + 1,)

    Returns
    -------
    particle, cell, w : ndarray, shape (T,)
    """
    f = np.ascontiguousarray
    return triplets(f(u, float), f(a, float), f(edges, float), 2)


def box_weights(x, y, z, a, xedges, yedges, zedges):
    """Sparse weights of spheres in the boxes of a 3D grid (cell k = (i ny + j) nz + l
    for column i of the x edges, row j of the y edges, layer l of the z edges): the
    fraction of each sphere's volume in a box, exact (closed form).

    Returns
    -------
    particle, cell, w : ndarray, shape (T,)
    """
    f = np.ascontiguousarray
    return box_triplets(f(x, float), f(y, float), f(z, float), f(a, float),
                        f(xedges, float), f(yedges, float), f(zedges, float))


def shell_weights(d, z, a, redges, zedges, nodes=None):
    """Sparse weights of spheres in cylindrical shells (cell k = i nz + l for ring i of
    the radial edges about the axis, layer l of the z edges).

    Parameters
    ----------
    d : ndarray, shape (P,)
        Distance of each sphere's centre from the axis.
    z : ndarray, shape (P,)
        Its coordinate along the axis.
    a : ndarray, shape (P,)
        Radii.
    redges, zedges : ndarray
        Increasing radial and axial edges.
    nodes : int, optional
        Quadrature nodes per piece (default :data:`NODES`; for convergence tests).

    Returns
    -------
    particle, cell, w : ndarray, shape (T,)
    """
    if nodes is None:
        mt, mw = _MAP_T, _MAP_W
    else:
        x, gw = np.polynomial.legendre.leggauss(nodes)
        mt = 0.5 * (1.0 - np.cos(np.pi * 0.5 * (x + 1.0)))
        mw = 0.5 * gw * 0.5 * np.pi * np.sin(np.pi * 0.5 * (x + 1.0))
    f = np.ascontiguousarray
    return shell_triplets(f(d, float), f(z, float), f(a, float), f(redges, float),
                          f(zedges, float), f(mt, float), f(mw, float))
