"""Kernel weights at point nodes (grids, boxes, the polar grid) and across planes
(slabs: points in 1D), of particles and of branch segments.

A particle's weight in node n is phi(|n - x|); its gradient with respect to the node's
position, projected on the node's basis, phi'(r) (n - x) / r. A branch segment
x(s) = x0 + s l, 0 <= s <= 1, gets the line integral int_0^1 phi(|n - x(s)|) ds
(Weinhart et al. 2012); its divergence needs no integral (the ends' weights,
:mod:`granavg.engine.smoothing.sums`). Along the line the distance is
r = sqrt(m^2 + A t^2), t = s - s0 from the point s0 closest to the node, m the distance
there and A = |l|^2: the part within the support is split at s0 and each side is
integrated in u, t = (m / sqrt A) sinh u, r = m cosh u, where the integrand is smooth
for every kernel however close the line passes (in t, odd powers of r have a kink of
width m at s0); in pieces of unit length in u, by Gauss-Legendre. When the line passes
through the node (m < 1e-9 c, and always across planes) t itself is the variable.
"""

from __future__ import annotations

import math

from numba import njit

from granavg.engine.smoothing.quadrature import SW, SX

#: Below this share of the support radius the line passes through the node.
_THROUGH = 1e-9


@njit(cache=True, nogil=True, inline="always")
def profile(K, q):
    """(g, dg/dq) at q of the kernel packed in K
    (:attr:`granavg.engine.smoothing.base.Kernel.packed`: pieces, row length, a, b, then
    per piece its start and coefficients)."""
    pieces, row = int(K[0]), int(K[1])
    p = 0
    while p + 1 < pieces and q >= K[4 + (p + 1) * row]:
        p += 1
    base = 4 + p * row
    g, dg = 0.0, 0.0
    for k in range(row - 1, 0, -1):              # Horner, with the derivative
        dg = dg * q + g
        g = g * q + K[base + k]
    if K[2] != 0.0:
        e = K[2] * math.exp(-K[3] * q * q)
        g += e
        dg -= 2.0 * K[3] * q * e
    return g, dg


@njit(cache=True, nogil=True, inline="always")
def phi(K, scale, c, r):
    """phi(r) and phi'(r) / r of the kernel packed in K (``scale`` = N_D / c^D; at
    r = 0, where it multiplies n - x = 0, phi'(r) / r is given as 0)."""
    if r >= c:
        return 0.0, 0.0
    g, dg = profile(K, r / c)
    return scale * g, (scale * dg / (c * r) if r > 0.0 else 0.0)


@njit(cache=True, nogil=True)
def point_pairs(x, nodes, basis, item, node, K, scale, c, deriv, w, dw):
    """w[t] = phi(|nodes[k] - x[i]|) and dw[t, j] its gradient along the node's basis
    vector j (rows of basis[k]), for each pair t = (i, k); D = x.shape[1]."""
    D = x.shape[1]
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        r2 = 0.0
        for a in range(D):
            d = nodes[k, a] - x[i, a]
            r2 += d * d
        v, dv = phi(K, scale, c, math.sqrt(r2))
        w[t] = v
        if deriv and dv != 0.0:
            for j in range(D):
                proj = 0.0
                for a in range(D):
                    proj += basis[k, j, a] * (nodes[k, a] - x[i, a])
                dw[t, j] = dv * proj


@njit(cache=True, nogil=True, inline="always")
def _side(K, scale, c, m, rootA, ta, tb):
    """The integral over t in [ta, tb] (0 <= ta < tb, t in units of s) of phi(r),
    r = sqrt(m^2 + A t^2)."""
    acc = 0.0
    if m > _THROUGH * c:
        ua = math.asinh(rootA * ta / m)
        ub = math.asinh(rootA * tb / m)
        pieces = max(int(math.ceil(ub - ua)), 1)
        step = (ub - ua) / pieces
        for p in range(pieces):
            for q in range(SX.shape[0]):
                u = ua + step * (p + SX[q])
                v, _ = phi(K, scale, c, m * math.cosh(u))
                acc += step * SW[q] * m / rootA * math.cosh(u) * v
        return acc
    span = tb - ta
    for q in range(SX.shape[0]):
        t = ta + span * SX[q]
        v, _ = phi(K, scale, c, math.sqrt(m * m + rootA * rootA * t * t))
        acc += span * SW[q] * v
    return acc


@njit(cache=True, nogil=True)
def point_segment_pairs(x0, l, nodes, item, node, K, scale, c, w):
    """The line integrals over s in [0, 1] of :func:`point_pairs`' weights at x0 + s l,
    for each pair t = (segment i, node k)."""
    D = x0.shape[1]
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        A, B, C0 = 0.0, 0.0, 0.0                  # |x0 + s l - n|^2 = A s^2 + 2 B s + C0
        for a in range(D):
            d = x0[i, a] - nodes[k, a]
            A += l[i, a] * l[i, a]
            B += l[i, a] * d
            C0 += d * d
        if A == 0.0:                              # a segment of length zero: a point
            w[t] = phi(K, scale, c, math.sqrt(C0))[0]
            continue
        s0 = -B / A
        m2 = max(C0 - B * B / A, 0.0)
        if m2 >= c * c:
            continue
        h = math.sqrt((c * c - m2) / A)
        lo, hi = max(0.0, s0 - h), min(1.0, s0 + h)
        if hi <= lo:
            continue
        m, rootA = math.sqrt(m2), math.sqrt(A)
        acc = 0.0
        if lo < s0:                               # the side s < s0, t = s0 - s
            acc += _side(K, scale, c, m, rootA, s0 - min(hi, s0), s0 - lo)
        if hi > s0:
            acc += _side(K, scale, c, m, rootA, max(lo - s0, 0.0), hi - s0)
        w[t] = acc
