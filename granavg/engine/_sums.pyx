# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The per-particle channels and the cell sums of :mod:`granavg.engine.kernels` (Eqs. 1-7),
compiled ahead of time; the loops run with the GIL released, so that chunks of a frame's
particles can be summed on several threads."""

import numpy as np

from libc.stdint cimport int64_t

# the positions of the blocks in the offsets (Layout.offsets, in channels.BLOCKS order)
cdef enum:
    VOL, MASS, MOM, SPIN, NC, FAB, SIG, KIN, DEFORM, WALL, BODY
#: The order the positions above assume (granavg.engine.kernels checks it on import).
BLOCK_ORDER = ("vol", "mass", "mom", "spin", "ncontact", "fab", "sig", "kin", "def", "wall",
               "body")


cdef inline void _project(const double[:, ::1] x, Py_ssize_t c, const double[:, :, ::1] E,
                          Py_ssize_t p, double s, int D, double *out) noexcept nogil:
    """out_i = s (x[c] . e_i) for every axis i of the basis E[p]."""
    cdef int i, j
    cdef double acc
    for i in range(D):
        acc = 0.0
        for j in range(D):
            acc = acc + x[c, j] * E[p, i, j]
        out[i] = s * acc


cdef inline Py_ssize_t _side_row(const int64_t[::1] i1, const int64_t[::1] i2, Py_ssize_t c,
                                   int side, Py_ssize_t lo, Py_ssize_t hi) noexcept nogil:
    """The chunk row (row - lo) of contact c's particle on ``side`` (0: i1, 1: i2); -1 when
    there is none (a wall's side 1, i2 < 0) or it lies outside the chunk [lo, hi)."""
    cdef Py_ssize_t row = i1[c] if side == 0 else i2[c]
    if row < lo or row >= hi:
        return -1
    return row - lo


def fill_particles(double[:, ::1] q, const double[::1] vol, const double[::1] mass,
                   const double[:, ::1] v, const double[:, ::1] w, const double[:, ::1] b,
                   const double[:, :, ::1] E, bint moving, bint kinetic, bint spin,
                   bint body, const int64_t[::1] off):
    """The particles' own channels in one pass: volume, mass, momentum m v, the kinetic
    tensor m v (x) v, the mass-weighted spin m omega and the body force, in the basis E
    (rows e_i), shape (P, D, D);
    ``off`` the blocks' first channels (:attr:`~granavg.engine.channels.Layout.offsets`)."""
    cdef int D = E.shape[1], i, j
    cdef Py_ssize_t p
    cdef double vb[3]
    cdef double wb[3]
    cdef double bb[3]
    cdef double m
    with nogil:
        for p in range(q.shape[0]):
            q[p, off[VOL]], q[p, off[MASS]] = vol[p], mass[p]
            if moving:
                _project(v, p, E, p, 1.0, D, vb)
                if off[MOM] >= 0:                   # the kinetic tensor may come alone
                    for i in range(D):
                        q[p, off[MOM] + i] = mass[p] * vb[i]
                if kinetic:
                    m = mass[p]
                    for i in range(D):
                        for j in range(D):
                            q[p, off[KIN] + i * D + j] = m * vb[i] * vb[j]
            if spin:
                if D == 2:                                    # omega_z, a scalar
                    q[p, off[SPIN]] = mass[p] * w[p, 0]
                else:
                    _project(w, p, E, p, 1.0, D, wb)
                    for i in range(D):
                        q[p, off[SPIN] + i] = mass[p] * wb[i]
            if body:
                _project(b, p, E, p, 1.0, D, bb)
                for i in range(D):
                    q[p, off[BODY] + i] = bb[i]


def spin_energy(double[:, ::1] q, const double[::1] mass, const double[::1] inertia,
                const double[:, ::1] v, const double[:, ::1] w, const double[:, ::1] b,
                const double[:, :, ::1] E, const int64_t[::1] off):
    """The particles' micropolar and energy channels in one pass: I (``inertia``),
    I omega (``ispin``), I |omega|^2 / 2 (``erot``), m |v|^2 / 2 (``ekin``), the spin's flux
    v (x) I omega (``kcpl``, row-major D x S) and the body force's power b . v (``bpow``);
    vectors in the basis E (rows e_i), 2D spins scalars, the energies and powers from the
    lab-frame v, omega and b. ``off``: the first channels of ispin, inertia, erot, ekin,
    kcpl, bpow (-1: not kept)."""
    cdef int D = E.shape[1], S = w.shape[1], i, j
    cdef Py_ssize_t p
    cdef double vb[3]
    cdef double wb[3]
    cdef double acc, I
    with nogil:
        for p in range(q.shape[0]):
            I = inertia[p]
            if off[1] >= 0:
                q[p, off[1]] = I
            if off[0] >= 0 or off[4] >= 0:
                if S == 1:
                    wb[0] = w[p, 0]
                else:
                    _project(w, p, E, p, 1.0, D, wb)
            if off[0] >= 0:
                for i in range(S):
                    q[p, off[0] + i] = I * wb[i]
            if off[2] >= 0:
                acc = 0.0
                for i in range(S):
                    acc = acc + w[p, i] * w[p, i]
                q[p, off[2]] = 0.5 * I * acc
            if off[3] >= 0:
                acc = 0.0
                for i in range(D):
                    acc = acc + v[p, i] * v[p, i]
                q[p, off[3]] = 0.5 * mass[p] * acc
            if off[4] >= 0:
                _project(v, p, E, p, 1.0, D, vb)
                for i in range(D):
                    for j in range(S):
                        q[p, off[4] + i * S + j] = vb[i] * (I * wb[j])
            if off[5] >= 0:
                acc = 0.0
                for i in range(D):
                    acc = acc + b[p, i] * v[p, i]
                q[p, off[5]] = acc


def accumulate_contacts(const int64_t[::1] i1, const int64_t[::1] i2, const double[:, ::1] f,
                        const double[:, ::1] n, const double[::1] overlap,
                        const double[:, :, ::1] E, const double[::1] a,
                        const double[::1] vol, const double[::1] dfac, double shorten,
                        bint count, bint fabric, bint stress, bint deform,
                        double[:, ::1] q, Py_ssize_t lo, const int64_t[::1] off):
    """Add to each particle's channels the sums over its contacts (side 2 sees -f and -n;
    i2 < 0: wall contact), the kept ones of: V^p x count, V^p sum n (x) n,
    sum f (x) l with l = (a - shorten overlap) n, (V^p / a^2) sum Delta (x) l with
    Delta = -overlap n; tensors in the particle's basis E (rows e_i). Only the rows
    lo .. lo + len(q) of the frame's particles are this call's (q, E, a, vol, dfac hold
    those rows); ``off`` the blocks' first channels."""
    cdef int D = E.shape[1], i, j, side
    cdef Py_ssize_t c, p, hi = lo + q.shape[0]
    cdef double nb[3]
    cdef double fb[3]
    cdef double s, length, d, v
    with nogil:
        for c in range(i1.shape[0]):
            for side in range(2):
                p = _side_row(i1, i2, c, side, lo, hi)
                if p < 0:
                    continue
                s = 1.0 if side == 0 else -1.0
                _project(n, c, E, p, s, D, nb)
                _project(f, c, E, p, s, D, fb)
                length = a[p] - shorten * overlap[c]
                d = -dfac[p] * overlap[c] * length
                v = vol[p]
                if count:
                    q[p, off[NC]] += v
                if fabric:
                    for i in range(D):
                        for j in range(D):
                            q[p, off[FAB] + i * D + j] += v * nb[i] * nb[j]
                if stress:
                    for i in range(D):
                        for j in range(D):
                            q[p, off[SIG] + i * D + j] += length * fb[i] * nb[j]
                if deform:
                    for i in range(D):
                        for j in range(D):
                            q[p, off[DEFORM] + i * D + j] += d * nb[i] * nb[j]


def table_rows(ids, wanted, Py_ssize_t top):
    """Row of each wanted id through a table indexed by id (0 <= ids <= top, integers
    or floats holding them, truncated as astype does); -1 if unknown."""
    cdef const int64_t[::1] I = np.ascontiguousarray(ids).astype(np.int64, copy=False)
    cdef const double[::1] Wf
    cdef const int64_t[::1] Wi
    table_ = np.full(top + 1, -1, np.int64)
    rows_ = np.full(len(wanted), -1, np.int64)
    cdef int64_t[::1] table = table_, rows = rows_
    cdef Py_ssize_t p, c, k
    cdef double x
    with nogil:
        for p in range(I.shape[0]):
            table[I[p]] = p
    wanted = np.ascontiguousarray(wanted)
    if wanted.dtype.kind == "f":                  # floats: in range before truncation
        Wf = wanted.astype(np.float64, copy=False)
        with nogil:
            for c in range(Wf.shape[0]):
                x = Wf[c]
                if 0 <= x < top + 1:
                    rows[c] = table[<Py_ssize_t>x]
    else:
        Wi = wanted.astype(np.int64, copy=False)
        with nogil:
            for c in range(Wi.shape[0]):
                k = Wi[c]
                if 0 <= k <= top:
                    rows[c] = table[k]
    return rows_


def scatter(const int64_t[::1] particle, const int64_t[::1] ring, const double[::1] w,
            const double[:, ::1] q, double[:, ::1] out):
    """out[k, c] += w q[p, c] over the (particle, cell, weight) triplets."""
    cdef Py_ssize_t t, c, p, k
    cdef double wt
    with nogil:
        for t in range(particle.shape[0]):
            p, k, wt = particle[t], ring[t], w[t]
            for c in range(q.shape[1]):
                out[k, c] += wt * q[p, c]


def scatter_sectors(const int64_t[::1] particle, const int64_t[::1] cell, const double[::1] w,
                    const int64_t[:, ::1] sector, const double[:, ::1] share, Py_ssize_t k,
                    const double[:, ::1] q, double[:, ::1] out):
    """out[cell * k + s, c] += w share q[p, c]: the cells' sums split over their sectors."""
    cdef Py_ssize_t t, p, j, c, row
    cdef double fr, wt
    with nogil:
        for t in range(particle.shape[0]):
            p = particle[t]
            for j in range(3):
                fr = share[p, j]
                if fr > 0.0:
                    row = cell[t] * k + sector[p, j]
                    wt = w[t] * fr
                    for c in range(q.shape[1]):
                        out[row, c] += wt * q[p, c]


cdef inline void _cross(const double *a, const double *b, int D, double *out) noexcept nogil:
    """a x b: the z component (out[0]) of two 2D vectors, the vector in 3D."""
    if D == 2:
        out[0] = a[0] * b[1] - a[1] * b[0]
    else:
        out[0] = a[1] * b[2] - a[2] * b[1]
        out[1] = a[2] * b[0] - a[0] * b[2]
        out[2] = a[0] * b[1] - a[1] * b[0]


def couple_channels(const int64_t[::1] i1, const int64_t[::1] i2, const double[:, ::1] n,
                    const double[:, ::1] f, const double[:, ::1] m,
                    const double[::1] overlap, const double[:, :, ::1] E,
                    const double[::1] a, const double[:, ::1] v, const double[:, ::1] w,
                    double shorten, double[:, ::1] q, Py_ssize_t lo,
                    const int64_t[::1] off):
    """The contacts' couple and power channels, each contact on both of its particles
    (side 2 sees -n, -f, -m; i2 < 0: a wall contact, on its particle alone). ``off``:
    the first channels of cst, lever, cnet, wcpl, ppow, wpow, lpow (-1: not kept).
    sum_c l (x) m (cst, l = (a - shorten overlap) n, in the basis E), the lever moment
    (overlap / 2) n x f (lever), sum_c m (cnet; wcpl: of wall contacts), the power
    f . (v + omega x l) + m . omega of the particles' contacts (ppow) and of the walls'
    (wpow), and the lever moment's power (lpow); vectors in the basis E (rows e_i) in 3D,
    2D moments scalars. Only the rows lo .. lo + len(q) of the frame's particles are
    this call's (q, E, a, v, w hold those rows; v and w in the lab frame)."""
    cdef int D = n.shape[1], S = m.shape[1], i, j, side
    cdef Py_ssize_t c, p, hi = lo + q.shape[0]
    cdef Py_ssize_t CST = off[0], LEVER = off[1], CNET = off[2], WCPL = off[3]
    cdef Py_ssize_t PPOW = off[4], WPOW = off[5], LPOW = off[6]
    cdef bint powers = PPOW >= 0 or WPOW >= 0 or LPOW >= 0
    cdef double nc[3]
    cdef double fc[3]
    cdef double arm[3]
    cdef double lv[3]
    cdef double wl[3]
    cdef double nb[3]
    cdef double mb[3]
    cdef double ab[3]
    cdef double s, length, power, lpower, acc
    cdef bint wall
    with nogil:
        for c in range(i1.shape[0]):
            for i in range(D):
                nc[i], fc[i] = n[c, i], f[c, i]
            _cross(nc, fc, D, arm)
            for i in range(S):
                arm[i] = 0.5 * overlap[c] * arm[i]
            wall = i2[c] < 0
            for side in range(2):
                p = _side_row(i1, i2, c, side, lo, hi)
                if p < 0:
                    continue
                s = 1.0 if side == 0 else -1.0
                length = a[p] - shorten * overlap[c]
                if powers:                   # in the lab frame: scalars need no basis
                    for i in range(D):
                        lv[i] = s * length * nc[i]
                    if D == 2:               # omega z x l
                        wl[0], wl[1] = -w[p, 0] * lv[1], w[p, 0] * lv[0]
                    else:
                        _cross(&w[p, 0], lv, 3, wl)
                    power = 0.0
                    for i in range(D):
                        power = power + s * fc[i] * (v[p, i] + wl[i])
                    lpower = 0.0
                    for i in range(S):
                        power = power + s * m[c, i] * w[p, i]
                        lpower = lpower + arm[i] * w[p, i]
                    if wall and WPOW >= 0:
                        q[p, WPOW] += power
                    elif not wall and PPOW >= 0:
                        q[p, PPOW] += power
                    if LPOW >= 0:
                        q[p, LPOW] += lpower
                if CST >= 0 or CNET >= 0 or WCPL >= 0:
                    if D == 2:
                        mb[0] = s * m[c, 0]
                    else:
                        _project(m, c, E, p, s, 3, mb)
                    if CST >= 0:
                        _project(n, c, E, p, s, D, nb)
                        for i in range(D):
                            for j in range(S):
                                q[p, CST + i * S + j] += length * nb[i] * mb[j]
                    if CNET >= 0:
                        for j in range(S):
                            q[p, CNET + j] += mb[j]
                    if WCPL >= 0 and wall:
                        for j in range(S):
                            q[p, WCPL + j] += mb[j]
                if LEVER >= 0:
                    if D == 2:
                        q[p, LEVER] += arm[0]
                    else:
                        for i in range(3):
                            acc = 0.0
                            for j in range(3):
                                acc = acc + arm[j] * E[p, i, j]
                            q[p, LEVER + i] += acc
