"""Kernel weights at circle nodes (rings, cylindrical shells): the kernel of the
distance in space averaged around the node's circle, with the moments that turn the
particles' polar components into the node's.

A node is the circle of radius R at height h about the axis. The field there is the
mean around the circle of the polar components of the coarse-grained (Cartesian) field,
so that the balance laws in polar form hold for the nodes' values exactly. A particle
at distance rho from the axis, azimuth phi_p, height z, carries its quantities in its
own polar basis; at the circle's point of azimuth alpha = phi_p + delta that basis is
turned by delta, and the node takes the moments

    mu_k = (1/pi) int_0^a0 phi(d(delta)) cos(k delta) d delta,  k = 0, 1, 2,
    d^2 = e^2 + 4 rho R sin^2(delta / 2),  e^2 = (rho - R)^2 + (z - h)^2,

(a0 where d reaches the support; the sine moments vanish by symmetry), and their
derivatives with respect to R and h: scalars take mu_0, vectors mu_1, a tensor's
isotropic part mu_0 and its deviator mu_2 (:mod:`granavg.engine.smoothing.rotation`).
Near the particle (delta < pi/2) the integral runs in sigma = 2 sqrt(rho R)
sin(delta/2) = e sinh u, where the integrand is smooth however close the particle is to
the circle; beyond, in delta (the compiled ``moments_at`` of
:mod:`granavg.engine.smoothing._kernels`).

In 2D the moments depend on rho alone: each ring tabulates them once
(:class:`RingTables`, Chebyshev pieces between the points where they are not smooth,
rho = R, R + c, |R - c|, in a variable that makes their half-integer powers
polynomials), and a branch segment's line integral of them, times the phase
exp(i k (phi(s) - phi_p)) of its points, runs between the segment's crossings of those
circles (roots of quadratics). In 3D the moments depend on rho and z - h: a segment's
pieces end where its distance e(s) to the circle reaches c, and at its closest approach,
found by sampling and bisection, and the moments are computed at each point.
"""

from __future__ import annotations

import numpy as np

from granavg.engine.smoothing._kernels import DEGREE, moments_at, table_at

#: The degree of a ring table's Chebyshev pieces, their most per interval, and the
#: size of the last two coefficients (over the kernel's scale N_2 / c^2, and N_2 / c^3
#: for the derivatives) below which an interval's pieces are fine enough (or when
#: halving the pieces no longer halves them: the moments' own round-off, near 1e-13 for
#: rings inside the support).
_DEGREE, _MOST, _TAIL = DEGREE, 256, 1e-14


# -- the rings' tables (2D) --------------------------------------------------------------

def _breakpoints(R, c):
    """Where a ring's moments are not smooth in rho: R - c (or 0), |c - R| (the whole
    circle within the support), R, R + c."""
    points = {max(R - c, 0.0), R, R + c}
    if c > R:
        points.add(c - R)
    points = sorted(points)
    keep = [points[0]]
    for p in points[1:]:
        if p - keep[-1] > 1e-12 * c:
            keep.append(p)
    return keep


def _chebyshev_nodes(n):
    return np.cos(np.pi * (np.arange(n) + 0.5) / n)


class RingTables:
    """The moments of every ring of a 2D set of rings as functions of rho, in Chebyshev
    pieces. Each interval between breakpoints b_i < b_i+1 is halved, and each half runs
    in v = sqrt(|rho - b| / half's length) from its breakpoint b (which makes
    (rho - b)^(n + 1/2) a polynomial in v), cut in equal pieces of degree
    :data:`_DEGREE`, twice as many until the last two coefficients of every piece are
    below :data:`_TAIL` of the kernel's scale or stop falling."""

    def __init__(self, kernel, c: float, radii):
        scale = kernel.norms[2] / c ** 2
        n = len(radii)
        self.points = np.full((n, 5), np.nan)
        self.count = np.zeros(n, np.int64)
        halves = []
        for j, R in enumerate(np.asarray(radii, float)):
            b = _breakpoints(float(R), c)
            self.points[j, :len(b)] = b
            self.count[j] = len(b) - 1
            row = []
            for i in range(len(b) - 1):
                mid = 0.5 * (b[i] + b[i + 1])
                row += [_half(kernel, scale, c, float(R), b[i], mid),
                        _half(kernel, scale, c, float(R), b[i + 1], mid)]
            halves.append(row)
        most = max(len(a) for row in halves for a in row)
        self.pieces = np.zeros((n, 8), np.int64)
        self.coef = np.zeros((n, 8, most, _DEGREE, 6))
        for j, row in enumerate(halves):
            for i, a in enumerate(row):
                self.pieces[j, i] = len(a)
                self.coef[j, i, :len(a)] = a

    def arrays(self):
        """What the compiled kernels take."""
        return self.points, self.count, self.pieces, self.coef

    def at(self, j, rho):
        """The six tabulated functions (mu_k, d mu_k / dR) of ring j at ``rho`` (numpy,
        for tests)."""
        out = np.zeros((len(rho), 6))
        for i, r in enumerate(np.asarray(rho, float)):
            table_at(*self.arrays(), j, r, 6, out[i])
        return out


def _half(kernel, scale, c, R, end, mid):
    """Chebyshev coefficients (pieces, degree, 6) of the six functions from the
    breakpoint ``end`` to ``mid``, in v: rho = end + (mid - end) v^2."""
    x = _chebyshev_nodes(_DEGREE)
    T = np.cos(np.outer(np.arange(_DEGREE), np.arccos(x)))          # T_n(x_m)
    size = np.r_[np.ones(3), np.full(3, 1.0 / c)] * scale
    pieces, last, before = 2, None, np.inf
    while True:
        v = ((np.arange(pieces)[:, None] + 0.5 * (1.0 + x[None, :])) / pieces).ravel()
        rho = end + (mid - end) * v * v
        f = moments_at(kernel.packed, scale, c, rho, np.zeros(len(rho)),
                       np.full(len(rho), R), True)[:, :6].reshape(pieces, _DEGREE, 6)
        a = 2.0 / _DEGREE * np.einsum("nm,pmf->pnf", T, f)
        a[:, 0] *= 0.5
        tail = np.max(np.max(np.abs(a[:, -2:]), axis=(0, 1)) / size)
        if tail > 0.5 * before:              # no better: the moments' round-off
            return last
        if tail < _TAIL or pieces >= _MOST:
            return a
        pieces, last, before = 2 * pieces, a, tail


#: A kink of a circle node's weight just beyond a segment's end spoils Gauss-Legendre
#: on the piece there: the piece is then taken to the kink, and the part beyond the end
#: subtracted. How near is too near depends on the kink's power n + 1/2, n the kernel's
#: edge order (16 points, (1 + eps - s)^p on [0, 1]: p = 1/2 at eps = 0.1 of the piece
#: 3e-12, 0.2 1e-15; p = 3/2 at 0.05 1e-11, 0.1 8e-14; p = 7/2 at 0 3e-11, 0.01 4e-12).
MARGINS = {0: 0.25, 1: 0.1, 3: 0.03}
