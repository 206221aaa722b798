"""Exact volume weights w_V^p of spheres in 3D cells (Eq. 1): compiled kernels.

The weight of sphere p in a cell is the fraction of its volume inside the cell:

- **slabs** (cells between parallel planes): differences of spherical caps, closed form
  (:func:`layer_weights`);
- **boxes**: differences, over the box's 8 corners, of the volume of the sphere with
  x < X, y < Y, z < Z, in closed form: by inclusion-exclusion from the volumes beyond
  one, two and three planes, the last two the integral over z of the area of a disk
  beyond two lines (antiderivatives with acos, asin and atan; :func:`_beyond3`);
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

import math

import numpy as np
from numba import njit

from granavg.engine.weights import _area_scalar, _below_sphere, _triplets, buffers, spans

#: Gauss-Legendre nodes per piece of the shells' quadrature: 32 agree with 64 to 6e-11
#: of a sphere's volume (16: 1e-8; tests/test_sphere_weights.py).
NODES = 32
_GL_X, _GL_W = np.polynomial.legendre.leggauss(NODES)
#: The nodes and weights on [0, 1] after the map s -> (1 - cos(pi s)) / 2.
_MAP_T = 0.5 * (1.0 - np.cos(np.pi * 0.5 * (_GL_X + 1.0)))
_MAP_W = 0.5 * _GL_W * 0.5 * np.pi * np.sin(np.pi * 0.5 * (_GL_X + 1.0))


@njit(cache=True, nogil=True, inline="always")
def _beyond1(p, a):
    """Volume of the sphere (radius a, centre 0) with x >= p."""
    return 4.0 / 3.0 * math.pi * a * a * a - _below_sphere(p, a)


@njit(cache=True, nogil=True)
def _antiderivative(z, m, p, q, a):
    """F(z): the integral from 0 to z of the area of the disk of radius sqrt(a^2 - t^2)
    with x >= p and y >= q (p, q >= 0, |z| <= sqrt(a^2 - p^2 - q^2)); odd in z. ``m`` is
    a^2 - z^2, given by the caller without cancellation (p^2 + q^2 at the top)."""
    a2 = a * a
    poly = a2 * z - z * z * z / 3.0
    rho = math.sqrt(max(m, 0.0))
    out = -0.25 * math.pi * poly + p * q * z
    for c in (p, q):
        b2 = a2 - c * c
        w = math.sqrt(max(m - c * c, 0.0))                 # sqrt(b^2 - z^2)
        asin = math.atan2(z, w)                           # asin(z / b), also for b -> 0
        # G_c = int (a^2 - t^2) acos(c / rho) dt, by parts (module docstring)
        g = poly * (math.atan2(w, c) if rho > 0.0 else 0.5 * math.pi)
        g += c / 3.0 * (0.5 * b2 * asin - 0.5 * z * w - 2.0 * a2 * asin)
        g += 2.0 * a2 * a / 3.0 * math.atan2(c * z, a * w)
        # K_c = int sqrt(a^2 - c^2 - t^2) dt
        k = 0.5 * (z * w + b2 * asin)
        out += 0.5 * g - 0.5 * c * k
    return out


@njit(cache=True, nogil=True)
def _core(p, q, r, a):
    """Volume with x >= p, y >= q, z >= r for p, q >= 0 (r of any sign)."""
    m_top = p * p + q * q                                  # a^2 - top^2
    z2 = a * a - m_top
    if z2 <= 0.0:
        return 0.0
    top = math.sqrt(z2)
    if r >= top:
        return 0.0
    if r <= -top:
        return 2.0 * _antiderivative(top, m_top, p, q, a)
    return (_antiderivative(top, m_top, p, q, a)
            - _antiderivative(r, (a - r) * (a + r), p, q, a))


@njit(cache=True, nogil=True)
def _beyond2(p, q, a):
    """Volume of the sphere with x >= p and y >= q (any signs)."""
    if p >= 0.0 and q >= 0.0:
        return _core(p, q, -a, a)
    if p < 0.0 <= q:
        return _beyond1(q, a) - _core(-p, q, -a, a)
    if q < 0.0 <= p:
        return _beyond1(p, a) - _core(p, -q, -a, a)
    return (4.0 / 3.0 * math.pi * a * a * a - _beyond1(-p, a) - _beyond1(-q, a)
            + _core(-p, -q, -a, a))


@njit(cache=True, nogil=True)
def _beyond3(p, q, r, a):
    """Volume of the sphere with x >= p, y >= q and z >= r (any signs)."""
    if p >= 0.0 and q >= 0.0:
        return _core(p, q, r, a)
    if p < 0.0 <= q:
        return _beyond2(q, r, a) - _core(-p, q, r, a)
    if q < 0.0 <= p:
        return _beyond2(p, r, a) - _core(p, -q, r, a)
    return _beyond1(r, a) - _beyond2(-p, r, a) - _beyond2(-q, r, a) + _core(-p, -q, r, a)


@njit(cache=True, nogil=True)
def below3(X, Y, Z, a):
    """Volume of the sphere (radius a, centre 0) with x < X, y < Y and z < Z, by
    inclusion-exclusion of the volumes beyond the planes that cut it (a plane at or
    beyond the sphere's extent drops out)."""
    if X <= -a or Y <= -a or Z <= -a:
        return 0.0
    full = 4.0 / 3.0 * math.pi * a * a * a
    cx, cy, cz = X < a, Y < a, Z < a
    out = full
    if cx:
        out -= _beyond1(X, a)
    if cy:
        out -= _beyond1(Y, a)
    if cz:
        out -= _beyond1(Z, a)
    if cx and cy:
        out += _beyond2(X, Y, a)
    if cx and cz:
        out += _beyond2(X, Z, a)
    if cy and cz:
        out += _beyond2(Y, Z, a)
    if cx and cy and cz:
        out -= _beyond3(X, Y, Z, a)
    return out


@njit(cache=True, nogil=True)
def _box_triplets(x, y, z, a, xe, ye, ze):
    ny, nz = ye.shape[0] - 1, ze.shape[0] - 1
    I0, I1 = spans(xe, x, a)
    J0, J1 = spans(ye, y, a)
    K0, K1 = spans(ze, z, a)
    particle, cell, w = buffers(np.sum((I1 - I0 + 1) * (J1 - J0 + 1) * (K1 - K0 + 1)))
    t = 0
    corners = np.empty(64)
    for p in range(x.shape[0]):
        ap = a[p]
        i0, i1, j0, j1, k0, k1 = I0[p], I1[p], J0[p], J1[p], K0[p], K1[p]
        mi, mj, mk = i1 - i0 + 2, j1 - j0 + 2, k1 - k0 + 2
        if (mi == 2 and mj == 2 and mk == 2
                and xe[i0] <= x[p] - ap and x[p] + ap <= xe[i0 + 1]
                and ye[j0] <= y[p] - ap and y[p] + ap <= ye[j0 + 1]
                and ze[k0] <= z[p] - ap and z[p] + ap <= ze[k0 + 1]):
            particle[t], cell[t], w[t] = p, (i0 * ny + j0) * nz + k0, 1.0   # inside one box
            t += 1                                                         # (most spheres)
            continue
        xin = mi == 2 and xe[i0] <= x[p] - ap and x[p] + ap <= xe[i0 + 1]
        yin = mj == 2 and ye[j0] <= y[p] - ap and y[p] + ap <= ye[j0 + 1]
        zin = mk == 2 and ze[k0] <= z[p] - ap and z[p] + ap <= ze[k0 + 1]
        if xin + yin + zin == 2:
            # cut by the planes of one axis only: differences of spherical caps
            if not zin:
                u, e, m0, m1 = z[p], ze, k0, k1
            elif not yin:
                u, e, m0, m1 = y[p], ye, j0, j1
            else:
                u, e, m0, m1 = x[p], xe, i0, i1
            full = 4.0 / 3.0 * math.pi * ap * ap * ap
            inner = _below_sphere(e[m0] - u, ap)
            for m in range(m0, m1 + 1):
                outer = _below_sphere(e[m + 1] - u, ap)
                wk = (outer - inner) / full
                inner = outer
                if wk > 0:
                    i, j, k = (m if not xin else i0), (m if not yin else j0), \
                        (m if not zin else k0)
                    particle[t], cell[t], w[t] = p, (i * ny + j) * nz + k, wk
                    t += 1
            continue
        if mi * mj * mk > corners.shape[0]:
            corners = np.empty(mi * mj * mk)
        # the cumulative volume at every corner of the boxes the sphere touches, once
        for i in range(mi):
            for j in range(mj):
                for k in range(mk):
                    corners[(i * mj + j) * mk + k] = below3(
                        xe[i0 + i] - x[p], ye[j0 + j] - y[p], ze[k0 + k] - z[p], ap)
        full = 4.0 / 3.0 * math.pi * ap * ap * ap
        for i in range(mi - 1):
            for j in range(mj - 1):
                for k in range(mk - 1):
                    c000 = (i * mj + j) * mk + k
                    di, dj = mj * mk, mk
                    vol = (corners[c000 + di + dj + 1] - corners[c000 + dj + 1]
                           - corners[c000 + di + 1] + corners[c000 + 1]
                           - corners[c000 + di + dj] + corners[c000 + dj]
                           + corners[c000 + di] - corners[c000])
                    wk = vol / full
                    if wk > 0:
                        particle[t], cell[t], w[t] = p, ((i0 + i) * ny + j0 + j) * nz + k0 + k, wk
                        t += 1
    return particle[:t], cell[:t], w[:t]


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
    return _triplets(np.ascontiguousarray(u, float), np.ascontiguousarray(a, float),
                     np.ascontiguousarray(edges, float), 2)


def box_weights(x, y, z, a, xedges, yedges, zedges):
    """Sparse weights of spheres in the boxes of a 3D grid (cell k = (i ny + j) nz + l
    for column i of the x edges, row j of the y edges, layer l of the z edges): the
    fraction of each sphere's volume in a box, exact (closed form).

    Returns
    -------
    particle, cell, w : ndarray, shape (T,)
    """
    f = np.ascontiguousarray
    return _box_triplets(f(x, float), f(y, float), f(z, float), f(a, float),
                         f(xedges, float), f(yedges, float), f(zedges, float))


@njit(cache=True, nogil=True)
def _shell_triplets(d, z, a, re, ze, mt, mw):
    nz = ze.shape[0] - 1
    I0, I1 = spans(re, d, a)
    K0, K1 = spans(ze, z, a)
    particle, cell, w = buffers(np.sum((I1 - I0 + 1) * (K1 - K0 + 1)))
    t = 0
    for p in range(d.shape[0]):
        ap = a[p]
        full = 4.0 / 3.0 * math.pi * ap * ap * ap
        i0, i1, k0, k1 = I0[p], I1[p], K0[p], K1[p]
        acc = np.zeros((i1 - i0 + 1, k1 - k0 + 1))
        if i0 == i1 and re[i0] <= d[p] - ap and d[p] + ap <= re[i0 + 1]:
            # radially inside one ring: caps between the layers' edges
            inner = _below_sphere(ze[k0] - z[p], ap)
            for k in range(k0, k1 + 1):
                outer = _below_sphere(ze[k + 1] - z[p], ap)
                acc[0, k - k0] = outer - inner
                inner = outer
        else:
            # the pieces of [-a, a] in t = z - z_p: layer edges and tangent heights
            cuts = [-ap, ap]
            for k in range(k0, k1 + 2):
                tk = ze[k] - z[p]
                if -ap < tk < ap:
                    cuts.append(tk)
            for i in range(i0, i1 + 2):
                for c in (abs(re[i] - d[p]), re[i] + d[p]):
                    if c < ap:
                        h = math.sqrt(ap * ap - c * c)
                        cuts.append(h)
                        cuts.append(-h)
            cuts.sort()
            for m in range(len(cuts) - 1):
                t0, t1 = cuts[m], cuts[m + 1]
                if t1 - t0 <= 0.0:
                    continue
                mid = z[p] + 0.5 * (t0 + t1)
                k = min(max(np.searchsorted(ze, mid, side="right") - 1, 0), nz - 1)
                if not (ze[0] <= mid < ze[nz]):
                    continue
                for n in range(mt.shape[0]):
                    tn = t0 + (t1 - t0) * mt[n]
                    rho = math.sqrt(max(ap * ap - tn * tn, 0.0))
                    wn = (t1 - t0) * mw[n]
                    inner = _area_scalar(d[p], rho, re[i0])
                    for i in range(i0, i1 + 1):
                        outer = _area_scalar(d[p], rho, re[i + 1])
                        acc[i - i0, k - k0] += wn * (outer - inner)
                        inner = outer
        for i in range(i0, i1 + 1):
            for k in range(k0, k1 + 1):
                wk = acc[i - i0, k - k0] / full
                if wk > 0:
                    particle[t], cell[t], w[t] = p, i * nz + k, wk
                    t += 1
    return particle[:t], cell[:t], w[:t]


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
    return _shell_triplets(f(d, float), f(z, float), f(a, float), f(redges, float),
                           f(zedges, float), mt, mw)
