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
the circle; beyond, in delta (:func:`moments`).

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

import math

import numpy as np
from numba import njit

from granavg.engine.smoothing.points import _THROUGH, phi
from granavg.engine.smoothing.quadrature import AW, AX, LW, LX, SW, SX, piece_point
from granavg.engine.smoothing.rotation import MOMENTS

#: The degree of a ring table's Chebyshev pieces, their most per interval, and the
#: size of the last two coefficients (over the kernel's scale N_2 / c^2, and N_2 / c^3
#: for the derivatives) below which an interval's pieces are fine enough (or when
#: halving the pieces no longer halves them: the moments' own round-off, near 1e-13 for
#: rings inside the support).
_DEGREE, _MOST, _TAIL = 10, 256, 1e-14
#: Samples along a segment to find its pieces about a circle in 3D.
_SAMPLES = 16


@njit(cache=True, nogil=True, inline="always")
def _add(out, jac, v, dv, c1, gr, gz, deriv):
    c2 = 2.0 * c1 * c1 - 1.0
    out[0] += jac * v
    out[1] += jac * v * c1
    out[2] += jac * v * c2
    if deriv:
        out[3] += jac * gr
        out[4] += jac * gr * c1
        out[5] += jac * gr * c2
        out[6] += jac * gz
        out[7] += jac * gz * c1
        out[8] += jac * gz * c2


@njit(cache=True, nogil=True)
def moments(K, scale, c, rho, dz, R, deriv, out):
    """out[0:3] = mu_k, out[3:6] = d mu_k / dR, out[6:9] = d mu_k / dh (k = 0, 1, 2) of
    a point at distance rho from the axis and height dz above the circle of radius R."""
    out[:] = 0.0
    base = rho * rho + R * R + dz * dz
    if rho == 0.0 or R == 0.0:                    # every point of the circle alike
        v, dv = phi(K, scale, c, math.sqrt(base))
        out[0] = v
        if deriv:
            out[3] = dv * R
            out[6] = -dv * dz
            if R == 0.0:
                out[4] = -0.5 * dv * rho
        return
    P = rho * R
    e2 = (rho - R) ** 2 + dz * dz
    e = math.sqrt(e2)
    # c^2 - e^2 = (c - R + rho)(c + R - rho) - dz^2, exact where the circle grazes
    # the support's edge (c - R exact as R -> c)
    gap = ((c - R) + rho) * ((c + R) - rho) - dz * dz
    if gap <= 0.0:
        return
    # d = c at sin^2(a0 / 2) = (c^2 - e^2) / (4 P); below pi/2, delta runs in
    # sigma = 2 sqrt(P) sin(delta / 2), up to sigma1
    a0 = math.pi if gap >= 4.0 * P else 2.0 * math.asin(math.sqrt(gap / (4.0 * P)))
    sig1 = math.sqrt(gap) if a0 <= 0.5 * math.pi else math.sqrt(2.0 * P)
    if e > _THROUGH * c:
        U = math.asinh(sig1 / e)
        pieces = max(int(math.ceil(U)), 1)
        step = U / pieces
        for p in range(pieces):
            for q in range(SX.shape[0]):
                u = step * (p + SX[q])
                sig, d = e * math.sinh(u), e * math.cosh(u)
                jac = step * SW[q] * d * 2.0 / math.sqrt(4.0 * P - sig * sig)
                v, dv = phi(K, scale, c, d)
                c1 = 1.0 - sig * sig / (2.0 * P)
                _add(out, jac, v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    else:
        for q in range(SX.shape[0]):
            sig = sig1 * SX[q]
            jac = sig1 * SW[q] * 2.0 / math.sqrt(4.0 * P - sig * sig)
            v, dv = phi(K, scale, c, math.sqrt(e2 + sig * sig))
            c1 = 1.0 - sig * sig / (2.0 * P)
            _add(out, jac, v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    if a0 > 0.5 * math.pi:                      # delta in [pi/2, a0]
        span = a0 - 0.5 * math.pi
        for q in range(AX.shape[0]):
            delta = 0.5 * math.pi + span * AX[q]
            c1 = math.cos(delta)
            v, dv = phi(K, scale, c, math.sqrt(max(base - 2.0 * P * c1, 0.0)))
            _add(out, span * AW[q], v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    for k in range(9):
        out[k] /= math.pi


@njit(cache=True, nogil=True)
def moments_at(K, scale, c, rho, dz, R, deriv):
    """:func:`moments` at many points (tables, tests): shape (n, 9)."""
    out = np.zeros((rho.shape[0], 9))
    for i in range(rho.shape[0]):
        moments(K, scale, c, rho[i], dz[i], R[i], deriv, out[i])
    return out


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
            _table(*self.arrays(), j, r, 6, out[i])
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


@njit(cache=True, nogil=True, inline="always")
def _table(points, count, pieces, coef, j, rho, nf, out):
    """The first ``nf`` of the six functions of ring j at rho into out (mu_k, and with
    nf = 6 d mu_k / dR); False (and zeros) outside."""
    n = count[j]
    if not (rho > points[j, 0] and rho < points[j, n]):
        out[:] = 0.0
        return False
    i = 0
    while rho >= points[j, i + 1]:
        i += 1
    lo, hi = points[j, i], points[j, i + 1]
    if rho - lo < hi - rho:
        side, v = 2 * i, math.sqrt(2.0 * (rho - lo) / (hi - lo))
    else:
        side, v = 2 * i + 1, math.sqrt(2.0 * (hi - rho) / (hi - lo))
    S = pieces[j, side]
    y = min(v, 1.0) * S
    p = min(int(y), S - 1)
    x = 2.0 * (y - p) - 1.0
    x2 = 2.0 * x
    # Clenshaw, the functions side by side in scalars (indexing the table directly: no
    # array views in the inner loop)
    p0 = p1 = p2 = p3 = p4 = p5 = 0.0
    q0 = q1 = q2 = q3 = q4 = q5 = 0.0
    for k in range(_DEGREE - 1, 0, -1):
        p0, q0 = x2 * p0 - q0 + coef[j, side, p, k, 0], p0
        p1, q1 = x2 * p1 - q1 + coef[j, side, p, k, 1], p1
        p2, q2 = x2 * p2 - q2 + coef[j, side, p, k, 2], p2
        if nf > 3:
            p3, q3 = x2 * p3 - q3 + coef[j, side, p, k, 3], p3
            p4, q4 = x2 * p4 - q4 + coef[j, side, p, k, 4], p4
            p5, q5 = x2 * p5 - q5 + coef[j, side, p, k, 5], p5
    out[0] = x * p0 - q0 + coef[j, side, p, 0, 0]
    out[1] = x * p1 - q1 + coef[j, side, p, 0, 1]
    out[2] = x * p2 - q2 + coef[j, side, p, 0, 2]
    if nf > 3:
        out[3] = x * p3 - q3 + coef[j, side, p, 0, 3]
        out[4] = x * p4 - q4 + coef[j, side, p, 0, 4]
        out[5] = x * p5 - q5 + coef[j, side, p, 0, 5]
    return True


@njit(cache=True, nogil=True)
def ring_pairs(x, y, cx, cy, points, count, pieces, coef, item, node, deriv, w, dw):
    """Points (particles, contact points) at rings: w[t] the moments (mu_0, mu_1, 0,
    mu_2, 0) and dw[t, :, 0] their derivatives along r."""
    out = np.zeros(6)
    nf = 6 if deriv else 3
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        if _table(points, count, pieces, coef, k, math.hypot(x[i] - cx, y[i] - cy), nf, out):
            w[t, 0], w[t, 1], w[t, 3] = out[0], out[1], out[2]
            if deriv:
                dw[t, 0, 0], dw[t, 1, 0], dw[t, 3, 0] = out[3], out[4], out[5]


@njit(cache=True, nogil=True, inline="always")
def _phase_add(W, jac, m0, m1, m2, ur, ui):
    """Adds jac times (m0, m1 cos, m1 sin, m2 cos 2, m2 sin 2) of the phase ur + i ui."""
    W[0] += jac * m0
    W[1] += jac * m1 * ur
    W[2] += jac * m1 * ui
    W[3] += jac * m2 * (ur * ur - ui * ui)
    W[4] += jac * m2 * 2.0 * ur * ui


#: A kink of a circle node's weight just beyond a segment's end spoils Gauss-Legendre
#: on the piece there: the piece is then taken to the kink, and the part beyond the end
#: subtracted. How near is too near depends on the kink's power n + 1/2, n the kernel's
#: edge order (16 points, (1 + eps - s)^p on [0, 1]: p = 1/2 at eps = 0.1 of the piece
#: 3e-12, 0.2 1e-15; p = 3/2 at 0.05 1e-11, 0.1 8e-14; p = 7/2 at 0 3e-11, 0.01 4e-12).
MARGINS = {0: 0.25, 1: 0.1, 3: 0.03}


@njit(cache=True, nogil=True, inline="always")
def _sorted_cuts(cuts, n):
    for a in range(1, n):
        s = cuts[a]
        b = a - 1
        while b >= 0 and cuts[b] > s:
            cuts[b + 1] = cuts[b]
            b -= 1
        cuts[b + 1] = s


@njit(cache=True, nogil=True, inline="always")
def _cut(s, cuts, n, before, after):
    """A kink at s along the segment: a cut inside it, else the nearest before or after
    it; the new (n, before, after)."""
    if 0.0 < s < 1.0:
        cuts[n] = s
        return n + 1, before, after
    if s <= 0.0:
        return n, max(before, s), after
    return n, before, min(after, s)


@njit(cache=True, nogil=True)
def _pieces(cuts, n, before, after, margin, lo_, hi_, left_, right_, sign_):
    """The pieces of the segment between sorted ``cuts`` (cuts[0] = 0, cuts[n-1] = 1,
    the others kinks), with the kinks ``before`` (<= 0) and ``after`` (>= 1) nearest
    outside it, those within ``margin`` of a piece's length taken in (:data:`MARGINS`):
    (lo, hi, singular left end, singular right end, sign); returns their number."""
    m = 0
    for p in range(n - 1):
        lo, hi = cuts[p], cuts[p + 1]
        if hi <= lo:
            continue
        L = hi - lo
        near_lo = p == 0 and before > -margin * L
        near_hi = p == n - 2 and after < 1.0 + margin * L
        elo = before if near_lo else lo
        ehi = after if near_hi else hi
        lo_[m], hi_[m], sign_[m] = elo, ehi, 1.0
        left_[m], right_[m] = p > 0 or near_lo, p < n - 2 or near_hi
        m += 1
        if elo < lo:
            lo_[m], hi_[m], left_[m], right_[m], sign_[m] = elo, lo, True, False, -1.0
            m += 1
        if ehi > hi:
            lo_[m], hi_[m], left_[m], right_[m], sign_[m] = hi, ehi, False, True, -1.0
            m += 1
    return m


@njit(cache=True, nogil=True, inline="always")
def _closed_pieces(cuts, n, before, after, margin, lo_, hi_, left_, right_, sign_):
    """The segment's end s = 1 added to its ``n`` cuts, sorted, and :func:`_pieces`."""
    cuts[n] = 1.0
    _sorted_cuts(cuts, n + 1)
    return _pieces(cuts, n + 1, before, after, margin, lo_, hi_, left_, right_, sign_)


@njit(cache=True, nogil=True)
def ring_segment_pairs(x0, y0, lx, ly, cx, cy, points, count, pieces, coef, margin, item,
                       node, w):
    """Segments at rings: the line integrals over s in [0, 1] of the tabulated moments at
    x0 + s l, turned by the phase of each point against the segment's start (the
    particle: its polar basis is the one its quantities are in), in pieces between the
    segment's crossings of the ring's breakpoint circles (:func:`_pieces`)."""
    out = np.zeros(6)
    cuts = np.empty(12)
    lo_, hi_, sign_ = np.empty(16), np.empty(16), np.empty(16)
    left_, right_ = np.zeros(16, np.bool_), np.zeros(16, np.bool_)
    W = np.zeros(MOMENTS)
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        px, py = x0[i] - cx, y0[i] - cy
        rho0 = math.hypot(px, py)
        er, ei = (px / rho0, py / rho0) if rho0 > 0.0 else (1.0, 0.0)
        A = lx[i] * lx[i] + ly[i] * ly[i]
        B = lx[i] * px + ly[i] * py
        C0 = px * px + py * py
        n = 1
        cuts[0] = 0.0
        before, after = -np.inf, np.inf
        if A > 0.0:
            for b in range(count[k] + 1):
                r = points[k, b]
                if r <= 0.0:
                    continue
                disc = B * B - A * (C0 - r * r)
                if disc > 0.0:
                    root = math.sqrt(disc)
                    for s in ((-B - root) / A, (-B + root) / A):
                        n, before, after = _cut(s, cuts, n, before, after)
        m = _closed_pieces(cuts, n, before, after, margin, lo_, hi_, left_, right_, sign_)
        W[:] = 0.0
        for piece in range(m):
            lo, hi = lo_[piece], hi_[piece]
            sm = 0.5 * (lo + hi)
            rm = math.hypot(px + sm * lx[i], py + sm * ly[i])
            if not (rm > points[k, 0] and rm < points[k, count[k]]):
                continue                         # outside the ring's support
            for q in range(LX.shape[0]):
                s, jac = piece_point(lo, hi, LX[q], left_[piece], right_[piece])
                qx, qy = px + s * lx[i], py + s * ly[i]
                rho = math.sqrt(qx * qx + qy * qy)
                if not _table(points, count, pieces, coef, k, rho, 3, out):
                    continue
                ux, uy = (qx / rho, qy / rho) if rho > 0.0 else (er, ei)
                # exp(i (phi(s) - phi_p)) = (ux + i uy) (er - i ei)
                ur, ui = ux * er + uy * ei, uy * er - ux * ei
                _phase_add(W, sign_[piece] * jac * LW[q], out[0], out[1], out[2], ur, ui)
        for j in range(MOMENTS):
            w[t, j] = W[j]


# -- cylindrical shells (3D) --------------------------------------------------------------

@njit(cache=True, nogil=True)
def shell_pairs(x, y, z, cx, cy, radii, heights, nz, item, node, K, scale, c,
                deriv, w, dw):
    """Points at the circles of cylindrical shells (node k = ring * nz + layer): w[t]
    the moments, dw[t, :, 0] and dw[t, :, 2] their derivatives along r and z."""
    out = np.zeros(9)
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        moments(K, scale, c, math.hypot(x[i] - cx, y[i] - cy), z[i] - heights[k % nz],
                radii[k // nz], deriv, out)
        w[t, 0], w[t, 1], w[t, 3] = out[0], out[1], out[2]
        if deriv:
            dw[t, 0, 0], dw[t, 1, 0], dw[t, 3, 0] = out[3], out[4], out[5]
            dw[t, 0, 2], dw[t, 1, 2], dw[t, 3, 2] = out[6], out[7], out[8]


@njit(cache=True, nogil=True, inline="always")
def _gap(px, py, pz, R, c):
    """e^2 - c^2 (the support's edge) and (rho + R)^2 + dz^2 - c^2 (the whole circle
    within it), as one function whose sign changes are a segment's kinks, and e^2."""
    rho = math.hypot(px, py)
    e2 = (rho - R) ** 2 + pz * pz
    return (e2 - c * c) * ((rho + R) ** 2 + pz * pz - c * c), e2


@njit(cache=True, nogil=True, inline="always")
def _kink(px, py, pz, lx, ly, lz, R, c, a, b, fa):
    """The sign change of :func:`_gap` between a and b (bisection)."""
    for _ in range(60):
        mid = 0.5 * (a + b)
        fm, _e = _gap(px + mid * lx, py + mid * ly, pz + mid * lz, R, c)
        if (fm < 0.0) == (fa < 0.0):
            a, fa = mid, fm
        else:
            b = mid
    return 0.5 * (a + b)


@njit(cache=True, nogil=True)
def shell_segment_pairs(x0, y0, z0, lx, ly, lz, cx, cy, radii, heights, nz, item, node,
                        K, scale, c, margin, w):
    """Segments at the circles of cylindrical shells: the line integrals of the moments
    (turned by the phase of each point), in pieces (:func:`_pieces`) between the kinks
    (sign changes of :func:`_gap` sampled along the segment and ``margin`` beyond it,
    found by bisection) and the closest approach to the circle (a golden-section
    refinement of the sampled minimum of e^2)."""
    out = np.zeros(9)
    extra = int(math.ceil(margin * _SAMPLES))
    cuts = np.empty(2 * (_SAMPLES + 2 * extra) + 4)
    lo_, hi_, sign_ = np.empty(cuts.size + 4), np.empty(cuts.size + 4), np.empty(cuts.size + 4)
    left_, right_ = np.zeros(cuts.size + 4, np.bool_), np.zeros(cuts.size + 4, np.bool_)
    W = np.zeros(MOMENTS)
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for t in range(item.shape[0]):
        i, k = item[t], node[t]
        R, h = radii[k // nz], heights[k % nz]
        px, py, pz = x0[i] - cx, y0[i] - cy, z0[i] - h
        rho0 = math.hypot(px, py)
        er, ei = (px / rho0, py / rho0) if rho0 > 0.0 else (1.0, 0.0)
        n = 1
        cuts[0] = 0.0
        before, after = -np.inf, np.inf
        s = -extra / _SAMPLES
        prev, _e = _gap(px + s * lx[i], py + s * ly[i], pz + s * lz[i], R, c)
        best_e2, best = np.inf, 0
        for m in range(-extra + 1, _SAMPLES + extra + 1):
            s = m / _SAMPLES
            cur, e2 = _gap(px + s * lx[i], py + s * ly[i], pz + s * lz[i], R, c)
            if 0 <= m <= _SAMPLES and e2 < best_e2:
                best_e2, best = e2, m
            if (prev < 0.0) != (cur < 0.0):           # a kink between the samples
                r = _kink(px, py, pz, lx[i], ly[i], lz[i], R, c, (m - 1) / _SAMPLES, s, prev)
                n, before, after = _cut(r, cuts, n, before, after)
            prev = cur
        if best_e2 < c * c:                           # the closest approach: golden section
            a, b = max(best - 1, 0) / _SAMPLES, min(best + 1, _SAMPLES) / _SAMPLES
            for _ in range(60):
                m1, m2 = b - g * (b - a), a + g * (b - a)
                _u, e1 = _gap(px + m1 * lx[i], py + m1 * ly[i], pz + m1 * lz[i], R, c)
                _u, e2 = _gap(px + m2 * lx[i], py + m2 * ly[i], pz + m2 * lz[i], R, c)
                if e1 < e2:
                    b = m2
                else:
                    a = m1
            s = 0.5 * (a + b)
            if 0.0 < s < 1.0:
                cuts[n] = s
                n += 1
        pieces = _closed_pieces(cuts, n, before, after, margin, lo_, hi_, left_, right_,
                                sign_)
        W[:] = 0.0
        for piece in range(pieces):
            for q in range(LX.shape[0]):
                s, jac = piece_point(lo_[piece], hi_[piece], LX[q], left_[piece],
                                     right_[piece])
                qx, qy, qz = px + s * lx[i], py + s * ly[i], pz + s * lz[i]
                rho = math.hypot(qx, qy)
                moments(K, scale, c, rho, qz, R, False, out)
                ux, uy = (qx / rho, qy / rho) if rho > 0.0 else (er, ei)
                ur, ui = ux * er + uy * ei, uy * er - ux * ei
                _phase_add(W, sign_[piece] * jac * LW[q], out[0], out[1], out[2], ur, ui)
        for j in range(MOMENTS):
            w[t, j] = W[j]
