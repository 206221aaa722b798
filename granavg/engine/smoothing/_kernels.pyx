# cython: boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The smoothing kernels' compiled loops (compiled ahead of time, the GIL released):
a kernel's profile and phi (:mod:`granavg.engine.smoothing.points`), the point nodes'
weights and the branch segments' line integrals, the circle nodes' moments, the rings'
tables and the cylindrical shells (:mod:`granavg.engine.smoothing.circles`), and the
turned sums (:mod:`granavg.engine.smoothing.rotation`); the circles' and the turned
sums' methods are documented in those modules.

Point nodes (grids, boxes, the polar grid) and planes (slabs: points in 1D):
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

import numpy as np

from libc.math cimport asin, asinh, ceil, cos, cosh, exp, fabs, hypot, sinh, sqrt, INFINITY

from granavg.engine.smoothing.quadrature import AW, AX, LW, LX, SW, SX

#: Below this share of the support radius the line passes through the node.
THROUGH = 1e-9
#: The degree of a ring table's Chebyshev pieces (:mod:`granavg.engine.smoothing.circles`).
DEGREE = 10
#: Samples along a segment to find its pieces about a circle in 3D.
SAMPLES = 16

cdef double PI = 3.141592653589793
cdef double _THROUGH = THROUGH
cdef int _DEGREE = DEGREE
cdef int _SAMPLES = SAMPLES
cdef const double[::1] _SX = np.ascontiguousarray(SX, float)
cdef const double[::1] _SW = np.ascontiguousarray(SW, float)
cdef const double[::1] _LX = np.ascontiguousarray(LX, float)
cdef const double[::1] _LW = np.ascontiguousarray(LW, float)
cdef const double[::1] _AX = np.ascontiguousarray(AX, float)
cdef const double[::1] _AW = np.ascontiguousarray(AW, float)


def _f(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _i(a):
    return np.ascontiguousarray(a, dtype=np.int64)


# -- a kernel's profile ------------------------------------------------------------------

cdef inline void _profile(const double* K, double q, double* g_out, double* dg_out) noexcept nogil:
    cdef int pieces = <int>K[0]
    cdef int row = <int>K[1]
    cdef int p = 0
    cdef int base, k
    cdef double g = 0.0, dg = 0.0, e
    while p + 1 < pieces and q >= K[4 + (p + 1) * row]:
        p += 1
    base = 4 + p * row
    for k in range(row - 1, 0, -1):              # Horner, with the derivative
        dg = dg * q + g
        g = g * q + K[base + k]
    if K[2] != 0.0:
        e = K[2] * exp(-K[3] * q * q)
        g += e
        dg -= 2.0 * K[3] * q * e
    g_out[0] = g
    dg_out[0] = dg


def profile(K, double q):
    """(g, dg/dq) at q of the kernel packed in K."""
    cdef const double[::1] k = _f(K)
    cdef double g, dg
    _profile(&k[0], q, &g, &dg)
    return g, dg


cdef inline void _phi(const double* K, double scale, double c, double r, double* v,
                      double* dv) noexcept nogil:
    cdef double g, dg
    if r >= c:
        v[0] = 0.0
        dv[0] = 0.0
        return
    _profile(K, r / c, &g, &dg)
    v[0] = scale * g
    dv[0] = scale * dg / (c * r) if r > 0.0 else 0.0


# -- point nodes ---------------------------------------------------------------------------

def point_pairs(x, nodes, basis, item, node, K, double scale, double c, bint deriv, w, dw):
    """w[t] = phi(|nodes[k] - x[i]|) and dw[t, j] its gradient along the node's basis
    vector j (rows of basis[k]), for each pair t = (i, k); D = x.shape[1]."""
    cdef const double[:, ::1] X = _f(x)
    cdef const double[:, ::1] N = _f(nodes)
    cdef const double[:, :, ::1] B = _f(basis)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef const double[::1] k_ = _f(K)
    cdef const double* kp = &k_[0]
    cdef double[::1] W = w
    cdef double[:, ::1] dW = dw
    cdef Py_ssize_t D = X.shape[1], t, a, j
    cdef long long i, k
    cdef double r2, d, v, dv, proj
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            r2 = 0.0
            for a in range(D):
                d = N[k, a] - X[i, a]
                r2 += d * d
            _phi(kp, scale, c, sqrt(r2), &v, &dv)
            W[t] = v
            if deriv and dv != 0.0:
                for j in range(D):
                    proj = 0.0
                    for a in range(D):
                        proj += B[k, j, a] * (N[k, a] - X[i, a])
                    dW[t, j] = dv * proj


cdef inline double _side(const double* K, double scale, double c, double m, double rootA,
                         double ta, double tb) noexcept nogil:
    cdef double acc = 0.0, ua, ub, step, u, v, dv, span, t
    cdef int pieces, p, q
    if m > _THROUGH * c:
        ua = asinh(rootA * ta / m)
        ub = asinh(rootA * tb / m)
        pieces = <int>ceil(ub - ua)
        if pieces < 1:
            pieces = 1
        step = (ub - ua) / pieces
        for p in range(pieces):
            for q in range(_SX.shape[0]):
                u = ua + step * (p + _SX[q])
                _phi(K, scale, c, m * cosh(u), &v, &dv)
                acc += step * _SW[q] * m / rootA * cosh(u) * v
        return acc
    span = tb - ta
    for q in range(_SX.shape[0]):
        t = ta + span * _SX[q]
        _phi(K, scale, c, sqrt(m * m + rootA * rootA * t * t), &v, &dv)
        acc += span * _SW[q] * v
    return acc


def point_segment_pairs(x0, l, nodes, item, node, K, double scale, double c, w):
    """The line integrals over s in [0, 1] of :func:`point_pairs`' weights at x0 + s l,
    for each pair t = (segment i, node k)."""
    cdef const double[:, ::1] X0 = _f(x0)
    cdef const double[:, ::1] L = _f(l)
    cdef const double[:, ::1] N = _f(nodes)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef const double[::1] k_ = _f(K)
    cdef const double* kp = &k_[0]
    cdef double[::1] W = w
    cdef Py_ssize_t D = X0.shape[1], t, a
    cdef long long i, k
    cdef double A, B, C0, d, s0, m2, h, lo, hi, m, rootA, acc, v, dv
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            A = 0.0
            B = 0.0
            C0 = 0.0                              # |x0 + s l - n|^2 = A s^2 + 2 B s + C0
            for a in range(D):
                d = X0[i, a] - N[k, a]
                A += L[i, a] * L[i, a]
                B += L[i, a] * d
                C0 += d * d
            if A == 0.0:                          # a segment of length zero: a point
                _phi(kp, scale, c, sqrt(C0), &v, &dv)
                W[t] = v
                continue
            s0 = -B / A
            m2 = C0 - B * B / A
            if m2 < 0.0:
                m2 = 0.0
            if m2 >= c * c:
                continue
            h = sqrt((c * c - m2) / A)
            lo = s0 - h if s0 - h > 0.0 else 0.0
            hi = s0 + h if s0 + h < 1.0 else 1.0
            if hi <= lo:
                continue
            m = sqrt(m2)
            rootA = sqrt(A)
            acc = 0.0
            if lo < s0:                           # the side s < s0, t = s0 - s
                acc += _side(kp, scale, c, m, rootA, s0 - (hi if hi < s0 else s0), s0 - lo)
            if hi > s0:
                acc += _side(kp, scale, c, m, rootA, lo - s0 if lo - s0 > 0.0 else 0.0,
                             hi - s0)
            W[t] = acc


# -- circle nodes: the moments -------------------------------------------------------------

cdef inline void _add(double* out, double jac, double v, double dv, double c1, double gr,
                      double gz, bint deriv) noexcept nogil:
    cdef double c2 = 2.0 * c1 * c1 - 1.0
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


cdef void _moments(const double* K, double scale, double c, double rho, double dz,
                   double R, bint deriv, double* out) noexcept nogil:
    cdef int k, pieces, p, q
    cdef double base, v, dv, P, e2, e, gap, a0, sig1, U, step, u, sig, d, jac, c1, span
    cdef double delta, arg
    for k in range(9):
        out[k] = 0.0
    base = rho * rho + R * R + dz * dz
    if rho == 0.0 or R == 0.0:                    # every point of the circle alike
        _phi(K, scale, c, sqrt(base), &v, &dv)
        out[0] = v
        if deriv:
            out[3] = dv * R
            out[6] = -dv * dz
            if R == 0.0:
                out[4] = -0.5 * dv * rho
        return
    P = rho * R
    e2 = (rho - R) * (rho - R) + dz * dz
    e = sqrt(e2)
    # c^2 - e^2 = (c - R + rho)(c + R - rho) - dz^2, exact where the circle grazes
    # the support's edge (c - R exact as R -> c)
    gap = ((c - R) + rho) * ((c + R) - rho) - dz * dz
    if gap <= 0.0:
        return
    a0 = PI if gap >= 4.0 * P else 2.0 * asin(sqrt(gap / (4.0 * P)))
    sig1 = sqrt(gap) if a0 <= 0.5 * PI else sqrt(2.0 * P)
    if e > _THROUGH * c:
        U = asinh(sig1 / e)
        pieces = <int>ceil(U)
        if pieces < 1:
            pieces = 1
        step = U / pieces
        for p in range(pieces):
            for q in range(_SX.shape[0]):
                u = step * (p + _SX[q])
                sig = e * sinh(u)
                d = e * cosh(u)
                jac = step * _SW[q] * d * 2.0 / sqrt(4.0 * P - sig * sig)
                _phi(K, scale, c, d, &v, &dv)
                c1 = 1.0 - sig * sig / (2.0 * P)
                _add(out, jac, v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    else:
        for q in range(_SX.shape[0]):
            sig = sig1 * _SX[q]
            jac = sig1 * _SW[q] * 2.0 / sqrt(4.0 * P - sig * sig)
            _phi(K, scale, c, sqrt(e2 + sig * sig), &v, &dv)
            c1 = 1.0 - sig * sig / (2.0 * P)
            _add(out, jac, v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    if a0 > 0.5 * PI:                             # delta in [pi/2, a0]
        span = a0 - 0.5 * PI
        for q in range(_AX.shape[0]):
            delta = 0.5 * PI + span * _AX[q]
            c1 = cos(delta)
            arg = base - 2.0 * P * c1
            _phi(K, scale, c, sqrt(arg if arg > 0.0 else 0.0), &v, &dv)
            _add(out, span * _AW[q], v, dv, c1, dv * (R - rho * c1), -dv * dz, deriv)
    for k in range(9):
        out[k] /= PI


def moments_at(K, double scale, double c, rho, dz, R, bint deriv):
    """The moments (mu_k, d mu_k / dR, d mu_k / dh; k = 0, 1, 2) at many points: shape
    (n, 9)."""
    cdef const double[::1] k_ = _f(K)
    cdef const double* kp = &k_[0]
    cdef const double[::1] r_ = _f(rho)
    cdef const double[::1] z_ = _f(dz)
    cdef const double[::1] R_ = _f(R)
    out = np.zeros((r_.shape[0], 9))
    cdef double[:, ::1] o = out
    cdef Py_ssize_t i
    with nogil:
        for i in range(r_.shape[0]):
            _moments(kp, scale, c, r_[i], z_[i], R_[i], deriv, &o[i, 0])
    return out


# -- the rings' tables (2D) ----------------------------------------------------------------

cdef struct Tables:
    # a set of rings' tables (:class:`~granavg.engine.smoothing.circles.RingTables`),
    # C-contiguous: points (n, npts), count (n,), pieces (n, npcs), coef (n, npcs, most,
    # DEGREE, 6)
    const double* points
    long long npts
    const long long* count
    const long long* pieces
    long long npcs
    const double* coef
    long long most


cdef inline bint _table(Tables T, long long j, double rho, int nf, double* out) noexcept nogil:
    cdef long long n = T.count[j], i = 0, S, p, side
    cdef int k
    cdef const double* pts = T.points + j * T.npts
    cdef const double* row
    cdef double lo, hi, v, y, x, x2
    cdef double p0 = 0.0, p1 = 0.0, p2 = 0.0, p3 = 0.0, p4 = 0.0, p5 = 0.0
    cdef double q0 = 0.0, q1 = 0.0, q2 = 0.0, q3 = 0.0, q4 = 0.0, q5 = 0.0, tmp
    if not (rho > pts[0] and rho < pts[n]):
        for k in range(6):
            out[k] = 0.0
        return False
    while rho >= pts[i + 1]:
        i += 1
    lo = pts[i]
    hi = pts[i + 1]
    if rho - lo < hi - rho:
        side = 2 * i
        v = sqrt(2.0 * (rho - lo) / (hi - lo))
    else:
        side = 2 * i + 1
        v = sqrt(2.0 * (hi - rho) / (hi - lo))
    S = T.pieces[j * T.npcs + side]
    y = (v if v < 1.0 else 1.0) * S
    p = <long long>y
    if p > S - 1:
        p = S - 1
    x = 2.0 * (y - p) - 1.0
    x2 = 2.0 * x
    row = T.coef + ((j * T.npcs + side) * T.most + p) * _DEGREE * 6   # row[k * 6 + f]
    for k in range(_DEGREE - 1, 0, -1):           # Clenshaw, the functions side by side
        tmp = p0
        p0 = x2 * p0 - q0 + row[k * 6 + 0]
        q0 = tmp
        tmp = p1
        p1 = x2 * p1 - q1 + row[k * 6 + 1]
        q1 = tmp
        tmp = p2
        p2 = x2 * p2 - q2 + row[k * 6 + 2]
        q2 = tmp
        if nf > 3:
            tmp = p3
            p3 = x2 * p3 - q3 + row[k * 6 + 3]
            q3 = tmp
            tmp = p4
            p4 = x2 * p4 - q4 + row[k * 6 + 4]
            q4 = tmp
            tmp = p5
            p5 = x2 * p5 - q5 + row[k * 6 + 5]
            q5 = tmp
    out[0] = x * p0 - q0 + row[0]
    out[1] = x * p1 - q1 + row[1]
    out[2] = x * p2 - q2 + row[2]
    if nf > 3:
        out[3] = x * p3 - q3 + row[3]
        out[4] = x * p4 - q4 + row[4]
        out[5] = x * p5 - q5 + row[5]
    return True


cdef Tables _tables(const double[:, ::1] P, const long long[::1] C,
                    const long long[:, ::1] S, const double[:, :, :, :, ::1] F):
    cdef Tables T
    if F.shape[3] != _DEGREE or F.shape[4] != 6 or F.shape[1] != S.shape[1]:
        raise ValueError("ring tables of another shape than RingTables makes")
    T.points = &P[0, 0]
    T.npts = P.shape[1]
    T.count = &C[0]
    T.pieces = &S[0, 0]
    T.npcs = S.shape[1]
    T.coef = &F[0, 0, 0, 0, 0]
    T.most = F.shape[2]
    return T


def table_at(points, count, pieces, coef, long long j, double rho, int nf, out):
    """The first ``nf`` of ring j's six tabulated functions at rho into ``out`` (shape
    (6,)); False (and zeros) outside."""
    cdef const double[:, ::1] P = _f(points)
    cdef const long long[::1] C = _i(count)
    cdef const long long[:, ::1] S = _i(pieces)
    cdef const double[:, :, :, :, ::1] F = _f(coef)
    cdef double[::1] o = out
    return _table(_tables(P, C, S, F), j, rho, nf, &o[0])


def ring_pairs(x, y, double cx, double cy, points, count, pieces, coef, item, node,
               bint deriv, w, dw):
    """Points (particles, contact points) at rings: w[t] the moments (mu_0, mu_1, 0,
    mu_2, 0) and dw[t, :, 0] their derivatives along r."""
    cdef const double[::1] X = _f(x)
    cdef const double[::1] Y = _f(y)
    cdef const double[:, ::1] P = _f(points)
    cdef const long long[::1] C = _i(count)
    cdef const long long[:, ::1] S = _i(pieces)
    cdef const double[:, :, :, :, ::1] F = _f(coef)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef double[:, ::1] W = w
    cdef double[:, :, ::1] dW = dw
    cdef double out[6]
    cdef int nf = 6 if deriv else 3
    cdef Py_ssize_t t
    cdef long long i, k
    cdef Tables T = _tables(P, C, S, F)
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            if _table(T, k, hypot(X[i] - cx, Y[i] - cy), nf, out):
                W[t, 0] = out[0]
                W[t, 1] = out[1]
                W[t, 3] = out[2]
                if deriv:
                    dW[t, 0, 0] = out[3]
                    dW[t, 1, 0] = out[4]
                    dW[t, 3, 0] = out[5]


cdef inline void _phase_add(double* W, double jac, double m0, double m1, double m2,
                            double ur, double ui) noexcept nogil:
    W[0] += jac * m0
    W[1] += jac * m1 * ur
    W[2] += jac * m1 * ui
    W[3] += jac * m2 * (ur * ur - ui * ui)
    W[4] += jac * m2 * 2.0 * ur * ui


cdef inline void _sorted_cuts(double* cuts, int n) noexcept nogil:
    cdef int a, b
    cdef double s
    for a in range(1, n):
        s = cuts[a]
        b = a - 1
        while b >= 0 and cuts[b] > s:
            cuts[b + 1] = cuts[b]
            b -= 1
        cuts[b + 1] = s


cdef inline int _cut(double s, double* cuts, int n, double* before, double* after) noexcept nogil:
    """A kink at s along the segment: a cut inside it, else the nearest before or after
    it; returns the new n."""
    if 0.0 < s < 1.0:
        cuts[n] = s
        return n + 1
    if s <= 0.0:
        if s > before[0]:
            before[0] = s
        return n
    if s < after[0]:
        after[0] = s
    return n


cdef inline void _quadrature(double lo, double hi, double x, bint left, bint right,
                             double* s, double* ds) noexcept nogil:
    """:func:`granavg.engine.smoothing.quadrature.piece_point`."""
    cdef double span = hi - lo, y
    if left and right:
        s[0] = lo + span * x * x * (3.0 - 2.0 * x)
        ds[0] = span * 6.0 * x * (1.0 - x)
    elif left:
        s[0] = lo + span * x * x
        ds[0] = span * 2.0 * x
    elif right:
        y = 1.0 - x
        s[0] = hi - span * y * y
        ds[0] = span * 2.0 * y
    else:
        s[0] = lo + span * x
        ds[0] = span


cdef int _pieces(double* cuts, int n, double before, double after, double margin,
                 double* lo_, double* hi_, bint* left_, bint* right_,
                 double* sign_) noexcept nogil:
    cdef int m = 0, p
    cdef double lo, hi, L, elo, ehi
    cdef bint near_lo, near_hi
    for p in range(n - 1):
        lo = cuts[p]
        hi = cuts[p + 1]
        if hi <= lo:
            continue
        L = hi - lo
        near_lo = p == 0 and before > -margin * L
        near_hi = p == n - 2 and after < 1.0 + margin * L
        elo = before if near_lo else lo
        ehi = after if near_hi else hi
        lo_[m] = elo
        hi_[m] = ehi
        sign_[m] = 1.0
        left_[m] = p > 0 or near_lo
        right_[m] = p < n - 2 or near_hi
        m += 1
        if elo < lo:
            lo_[m] = elo
            hi_[m] = lo
            left_[m] = True
            right_[m] = False
            sign_[m] = -1.0
            m += 1
        if ehi > hi:
            lo_[m] = hi
            hi_[m] = ehi
            left_[m] = False
            right_[m] = True
            sign_[m] = -1.0
            m += 1
    return m


cdef inline int _closed_pieces(double* cuts, int n, double before, double after,
                               double margin, double* lo_, double* hi_, bint* left_,
                               bint* right_, double* sign_) noexcept nogil:
    cuts[n] = 1.0
    _sorted_cuts(cuts, n + 1)
    return _pieces(cuts, n + 1, before, after, margin, lo_, hi_, left_, right_, sign_)


def ring_segment_pairs(x0, y0, lx, ly, double cx, double cy, points, count, pieces, coef,
                       double margin, item, node, w):
    """Segments at rings: the line integrals over s in [0, 1] of the tabulated moments at
    x0 + s l, turned by the phase of each point against the segment's start."""
    cdef const double[::1] X0 = _f(x0)
    cdef const double[::1] Y0 = _f(y0)
    cdef const double[::1] LX_ = _f(lx)
    cdef const double[::1] LY_ = _f(ly)
    cdef const double[:, ::1] P = _f(points)
    cdef const long long[::1] C = _i(count)
    cdef const long long[:, ::1] S = _i(pieces)
    cdef const double[:, :, :, :, ::1] F = _f(coef)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef double[:, ::1] Wout = w
    cdef double out[6]
    cdef double cuts[12]
    cdef double lo_[16]
    cdef double hi_[16]
    cdef double sign_[16]
    cdef bint left_[16]
    cdef bint right_[16]
    cdef double W[5]
    cdef Py_ssize_t t
    cdef long long i, k, b
    cdef int n, m, piece, q, j, r_
    cdef double px, py, rho0, er, ei, A, B, C0, before, after, r, disc, root, s
    cdef double lo, hi, sm, rm, jac, qx, qy, rho, ux, uy, ur, ui
    cdef Tables T = _tables(P, C, S, F)
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            px = X0[i] - cx
            py = Y0[i] - cy
            rho0 = hypot(px, py)
            if rho0 > 0.0:
                er = px / rho0
                ei = py / rho0
            else:
                er = 1.0
                ei = 0.0
            A = LX_[i] * LX_[i] + LY_[i] * LY_[i]
            B = LX_[i] * px + LY_[i] * py
            C0 = px * px + py * py
            n = 1
            cuts[0] = 0.0
            before = -INFINITY
            after = INFINITY
            if A > 0.0:
                for b in range(C[k] + 1):
                    r = P[k, b]
                    if r <= 0.0:
                        continue
                    disc = B * B - A * (C0 - r * r)
                    if disc > 0.0:
                        root = sqrt(disc)
                        n = _cut((-B - root) / A, cuts, n, &before, &after)
                        n = _cut((-B + root) / A, cuts, n, &before, &after)
            m = _closed_pieces(cuts, n, before, after, margin, lo_, hi_, left_, right_, sign_)
            for j in range(5):
                W[j] = 0.0
            for piece in range(m):
                lo = lo_[piece]
                hi = hi_[piece]
                sm = 0.5 * (lo + hi)
                rm = hypot(px + sm * LX_[i], py + sm * LY_[i])
                if not (rm > P[k, 0] and rm < P[k, C[k]]):
                    continue                     # outside the ring's support
                for q in range(_LX.shape[0]):
                    _quadrature(lo, hi, _LX[q], left_[piece], right_[piece], &s, &jac)
                    qx = px + s * LX_[i]
                    qy = py + s * LY_[i]
                    rho = sqrt(qx * qx + qy * qy)
                    if not _table(T, k, rho, 3, out):
                        continue
                    if rho > 0.0:
                        ux = qx / rho
                        uy = qy / rho
                    else:
                        ux = er
                        uy = ei
                    # exp(i (phi(s) - phi_p)) = (ux + i uy) (er - i ei)
                    ur = ux * er + uy * ei
                    ui = uy * er - ux * ei
                    _phase_add(W, sign_[piece] * jac * _LW[q], out[0], out[1], out[2], ur,
                               ui)
            for j in range(5):
                Wout[t, j] = W[j]


# -- cylindrical shells (3D) ---------------------------------------------------------------

def shell_pairs(x, y, z, double cx, double cy, radii, heights, long long nz, item, node, K,
                double scale, double c, bint deriv, w, dw):
    """Points at the circles of cylindrical shells (node k = ring * nz + layer): w[t]
    the moments, dw[t, :, 0] and dw[t, :, 2] their derivatives along r and z."""
    cdef const double[::1] X = _f(x)
    cdef const double[::1] Y = _f(y)
    cdef const double[::1] Z = _f(z)
    cdef const double[::1] Rs = _f(radii)
    cdef const double[::1] Hs = _f(heights)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef const double[::1] k_ = _f(K)
    cdef const double* kp = &k_[0]
    cdef double[:, ::1] W = w
    cdef double[:, :, ::1] dW = dw
    cdef double out[9]
    cdef Py_ssize_t t
    cdef long long i, k
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            _moments(kp, scale, c, hypot(X[i] - cx, Y[i] - cy), Z[i] - Hs[k % nz],
                     Rs[k // nz], deriv, out)
            W[t, 0] = out[0]
            W[t, 1] = out[1]
            W[t, 3] = out[2]
            if deriv:
                dW[t, 0, 0] = out[3]
                dW[t, 1, 0] = out[4]
                dW[t, 3, 0] = out[5]
                dW[t, 0, 2] = out[6]
                dW[t, 1, 2] = out[7]
                dW[t, 3, 2] = out[8]


cdef inline double _gap(double px, double py, double pz, double R, double c,
                        double* e2_out) noexcept nogil:
    cdef double rho = hypot(px, py)
    cdef double e2 = (rho - R) * (rho - R) + pz * pz
    e2_out[0] = e2
    return (e2 - c * c) * ((rho + R) * (rho + R) + pz * pz - c * c)


cdef inline double _kink(double px, double py, double pz, double lx, double ly, double lz,
                         double R, double c, double a, double b, double fa) noexcept nogil:
    cdef int it
    cdef double mid, fm, e
    for it in range(60):
        mid = 0.5 * (a + b)
        fm = _gap(px + mid * lx, py + mid * ly, pz + mid * lz, R, c, &e)
        if (fm < 0.0) == (fa < 0.0):
            a = mid
            fa = fm
        else:
            b = mid
    return 0.5 * (a + b)


def shell_segment_pairs(x0, y0, z0, lx, ly, lz, double cx, double cy, radii, heights,
                        long long nz, item, node, K, double scale, double c, double margin,
                        w):
    """Segments at the circles of cylindrical shells: the line integrals of the moments
    (turned by the phase of each point), in pieces between the kinks and the closest
    approach to the circle."""
    cdef const double[::1] X0 = _f(x0)
    cdef const double[::1] Y0 = _f(y0)
    cdef const double[::1] Z0 = _f(z0)
    cdef const double[::1] LX_ = _f(lx)
    cdef const double[::1] LY_ = _f(ly)
    cdef const double[::1] LZ_ = _f(lz)
    cdef const double[::1] Rs = _f(radii)
    cdef const double[::1] Hs = _f(heights)
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef const double[::1] k_ = _f(K)
    cdef const double* kp = &k_[0]
    cdef double[:, ::1] Wout = w
    cdef int extra = <int>ceil(margin * _SAMPLES)
    cdef int size = 2 * (_SAMPLES + 2 * extra) + 4
    cuts_a = np.empty(size)
    lo_a, hi_a, sign_a = np.empty(size + 4), np.empty(size + 4), np.empty(size + 4)
    left_a, right_a = np.zeros(size + 4, np.intc), np.zeros(size + 4, np.intc)
    cdef double[::1] cuts = cuts_a
    cdef double[::1] lo_ = lo_a
    cdef double[::1] hi_ = hi_a
    cdef double[::1] sign_ = sign_a
    cdef int[::1] left_i = left_a
    cdef int[::1] right_i = right_a
    cdef double out[9]
    cdef double W[5]
    cdef double g = 0.5 * (sqrt(5.0) - 1.0)
    cdef Py_ssize_t t
    cdef long long i, k
    cdef int n, m, best, pieces, piece, q, j, rep
    cdef double R, h, px, py, pz, rho0, er, ei, before, after, s, prev, cur, e2, best_e2
    cdef double r, a, b, m1, m2, e1, e2b, u_, jac, qx, qy, qz, rho, ux, uy, ur, ui
    cdef bint* left_
    cdef bint* right_
    # bint is an int in C: the int arrays serve as the flags
    left_ = <bint*>&left_i[0]
    right_ = <bint*>&right_i[0]
    with nogil:
        for t in range(it.shape[0]):
            i = it[t]
            k = nd[t]
            R = Rs[k // nz]
            h = Hs[k % nz]
            px = X0[i] - cx
            py = Y0[i] - cy
            pz = Z0[i] - h
            rho0 = hypot(px, py)
            if rho0 > 0.0:
                er = px / rho0
                ei = py / rho0
            else:
                er = 1.0
                ei = 0.0
            n = 1
            cuts[0] = 0.0
            before = -INFINITY
            after = INFINITY
            s = -(<double>extra) / _SAMPLES
            prev = _gap(px + s * LX_[i], py + s * LY_[i], pz + s * LZ_[i], R, c, &e2)
            best_e2 = INFINITY
            best = 0
            for m in range(-extra + 1, _SAMPLES + extra + 1):
                s = (<double>m) / _SAMPLES
                cur = _gap(px + s * LX_[i], py + s * LY_[i], pz + s * LZ_[i], R, c, &e2)
                if 0 <= m <= _SAMPLES and e2 < best_e2:
                    best_e2 = e2
                    best = m
                if (prev < 0.0) != (cur < 0.0):       # a kink between the samples
                    r = _kink(px, py, pz, LX_[i], LY_[i], LZ_[i], R, c,
                              (<double>(m - 1)) / _SAMPLES, s, prev)
                    n = _cut(r, &cuts[0], n, &before, &after)
                prev = cur
            if best_e2 < c * c:                       # the closest approach: golden section
                a = (<double>(best - 1 if best - 1 > 0 else 0)) / _SAMPLES
                b = (<double>(best + 1 if best + 1 < _SAMPLES else _SAMPLES)) / _SAMPLES
                for rep in range(60):
                    m1 = b - g * (b - a)
                    m2 = a + g * (b - a)
                    _gap(px + m1 * LX_[i], py + m1 * LY_[i], pz + m1 * LZ_[i], R, c, &e1)
                    _gap(px + m2 * LX_[i], py + m2 * LY_[i], pz + m2 * LZ_[i], R, c, &e2b)
                    if e1 < e2b:
                        b = m2
                    else:
                        a = m1
                s = 0.5 * (a + b)
                if 0.0 < s < 1.0:
                    cuts[n] = s
                    n += 1
            pieces = _closed_pieces(&cuts[0], n, before, after, margin, &lo_[0], &hi_[0],
                                    left_, right_, &sign_[0])
            for j in range(5):
                W[j] = 0.0
            for piece in range(pieces):
                for q in range(_LX.shape[0]):
                    _quadrature(lo_[piece], hi_[piece], _LX[q], left_[piece], right_[piece],
                                &s, &jac)
                    qx = px + s * LX_[i]
                    qy = py + s * LY_[i]
                    qz = pz + s * LZ_[i]
                    rho = hypot(qx, qy)
                    _moments(kp, scale, c, rho, qz, R, False, out)
                    if rho > 0.0:
                        ux = qx / rho
                        uy = qy / rho
                    else:
                        ux = er
                        uy = ei
                    ur = ux * er + uy * ei
                    ui = uy * er - ux * ei
                    _phase_add(W, sign_[piece] * jac * _LW[q], out[0], out[1], out[2], ur,
                               ui)
            for j in range(5):
                Wout[t, j] = W[j]


# -- the turned sums -----------------------------------------------------------------------

def mixed(item, node, W, q, t_out, t_in, t_m, t_f, sector, share, long long k, out):
    """out[row, t_out] += t_f W[t, t_m] q[item[t], t_in] for each pair t and term, row
    the node (k = 0) or node * k + sector with the sectors' shares."""
    cdef const long long[::1] it = _i(item)
    cdef const long long[::1] nd = _i(node)
    cdef const double[:, ::1] W_ = _f(W)
    cdef const double[:, ::1] Q = _f(q)
    cdef const long long[::1] to = _i(t_out)
    cdef const long long[::1] ti = _i(t_in)
    cdef const long long[::1] tm = _i(t_m)
    cdef const double[::1] tf = _f(t_f)
    cdef const long long[:, ::1] sec = _i(sector)
    cdef const double[:, ::1] sh = _f(share)
    cdef double[:, ::1] o = out
    cdef Py_ssize_t t, u, n_terms = to.shape[0]
    cdef long long p, row
    cdef int j3, reps = 3 if k > 0 else 1
    cdef double f
    cdef double* orow
    cdef const double* wrow
    cdef const double* qrow
    with nogil:
        for t in range(it.shape[0]):
            p = it[t]
            wrow = &W_[t, 0]
            qrow = &Q[p, 0]
            for j3 in range(reps):
                f = sh[p, j3] if k > 0 else 1.0
                if f == 0.0:
                    continue
                row = nd[t] * k + sec[p, j3] if k > 0 else nd[t]
                orow = &o[row, 0]
                for u in range(n_terms):
                    orow[to[u]] += f * tf[u] * wrow[tm[u]] * qrow[ti[u]]
