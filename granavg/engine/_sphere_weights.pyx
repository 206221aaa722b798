# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The exact weights of spheres in 3D boxes and cylindrical shells (Eq. 1), compiled ahead
of time; the wrappers and the derivations are in :mod:`granavg.engine.sphere_weights`.
The loops run with the GIL released."""

import numpy as np

from libc.math cimport M_PI, atan2, fabs, sqrt
from libc.stdint cimport int64_t
from libc.stdlib cimport free, malloc, qsort
from libc.string cimport memset

from granavg.engine._geometry cimport area_in_circle, below_sphere, search

from granavg.engine._weights import spans


cdef inline double _beyond1(double p, double a) noexcept nogil:
    """Volume of the sphere (radius a, centre 0) with x >= p."""
    return 4.0 / 3.0 * M_PI * a * a * a - below_sphere(p, a)


cdef double _antiderivative(double z, double m, double p, double q, double a) noexcept nogil:
    """F(z): the integral from 0 to z of the area of the disk of radius sqrt(a^2 - t^2)
    with x >= p and y >= q (p, q >= 0, |z| <= sqrt(a^2 - p^2 - q^2)); odd in z. ``m`` is
    a^2 - z^2, given by the caller without cancellation (p^2 + q^2 at the top)."""
    cdef double a2 = a * a, c, b2, w, asn, g, k
    cdef double poly = a2 * z - z * z * z / 3.0
    cdef double rho = sqrt(m if m > 0.0 else 0.0)
    cdef double out = -0.25 * M_PI * poly + p * q * z
    cdef int side
    for side in range(2):
        c = p if side == 0 else q
        b2 = a2 - c * c
        w = sqrt(m - c * c if m - c * c > 0.0 else 0.0)      # sqrt(b^2 - z^2)
        asn = atan2(z, w)                                     # asin(z / b), also b -> 0
        # G_c = int (a^2 - t^2) acos(c / rho) dt, by parts (the module's docstring)
        g = poly * (atan2(w, c) if rho > 0.0 else 0.5 * M_PI)
        g += c / 3.0 * (0.5 * b2 * asn - 0.5 * z * w - 2.0 * a2 * asn)
        g += 2.0 * a2 * a / 3.0 * atan2(c * z, a * w)
        # K_c = int sqrt(a^2 - c^2 - t^2) dt
        k = 0.5 * (z * w + b2 * asn)
        out += 0.5 * g - 0.5 * c * k
    return out


cdef double _core(double p, double q, double r, double a) noexcept nogil:
    """Volume with x >= p, y >= q, z >= r for p, q >= 0 (r of any sign)."""
    cdef double m_top = p * p + q * q                        # a^2 - top^2
    cdef double z2 = a * a - m_top, top
    if z2 <= 0.0:
        return 0.0
    top = sqrt(z2)
    if r >= top:
        return 0.0
    if r <= -top:
        return 2.0 * _antiderivative(top, m_top, p, q, a)
    return (_antiderivative(top, m_top, p, q, a)
            - _antiderivative(r, (a - r) * (a + r), p, q, a))


cdef double _beyond2(double p, double q, double a) noexcept nogil:
    """Volume of the sphere with x >= p and y >= q (any signs)."""
    if p >= 0.0 and q >= 0.0:
        return _core(p, q, -a, a)
    if p < 0.0 <= q:
        return _beyond1(q, a) - _core(-p, q, -a, a)
    if q < 0.0 <= p:
        return _beyond1(p, a) - _core(p, -q, -a, a)
    return (4.0 / 3.0 * M_PI * a * a * a - _beyond1(-p, a) - _beyond1(-q, a)
            + _core(-p, -q, -a, a))


cdef double _beyond3(double p, double q, double r, double a) noexcept nogil:
    """Volume of the sphere with x >= p, y >= q and z >= r (any signs)."""
    if p >= 0.0 and q >= 0.0:
        return _core(p, q, r, a)
    if p < 0.0 <= q:
        return _beyond2(q, r, a) - _core(-p, q, r, a)
    if q < 0.0 <= p:
        return _beyond2(p, r, a) - _core(p, -q, r, a)
    return _beyond1(r, a) - _beyond2(-p, r, a) - _beyond2(-q, r, a) + _core(-p, -q, r, a)


cdef double _below3(double X, double Y, double Z, double a) noexcept nogil:
    """Volume of the sphere (radius a, centre 0) with x < X, y < Y and z < Z, by
    inclusion-exclusion of the volumes beyond the planes that cut it."""
    if X <= -a or Y <= -a or Z <= -a:
        return 0.0
    cdef double out = 4.0 / 3.0 * M_PI * a * a * a
    cdef bint cx = X < a, cy = Y < a, cz = Z < a
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


def below3(double X, double Y, double Z, double a):
    """Volume of the sphere (radius a, centre 0) with x < X, y < Y and z < Z."""
    return _below3(X, Y, Z, a)


def box_triplets(const double[::1] x, const double[::1] y, const double[::1] z,
                 const double[::1] a, const double[::1] xe, const double[::1] ye,
                 const double[::1] ze):
    """(particle, cell, weight) of spheres in the boxes of a 3D grid, cell (i ny + j) nz + l."""
    cdef Py_ssize_t ny = ye.shape[0] - 1, nz = ze.shape[0] - 1
    I0_, I1_ = spans(xe, x, a)
    J0_, J1_ = spans(ye, y, a)
    K0_, K1_ = spans(ze, z, a)
    cdef Py_ssize_t[::1] I0 = I0_, I1 = I1_, J0 = J0_, J1 = J1_, K0 = K0_, K1 = K1_
    mi_, mj_, mk_ = I1_ - I0_ + 2, J1_ - J0_ + 2, K1_ - K0_ + 2
    size = int(np.sum((mi_ - 1) * (mj_ - 1) * (mk_ - 1)))
    ncorner = int(np.max(mi_ * mj_ * mk_, initial=8))
    particle_, cell_, w_ = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    corners_ = np.empty(ncorner)
    cdef int64_t[::1] particle = particle_, cell = cell_
    cdef double[::1] w = w_, corners = corners_
    cdef Py_ssize_t p, i, j, k, m, m0, m1, i0, i1, j0, j1, k0, k1, mi, mj, mk, t = 0
    cdef Py_ssize_t c000, di, dj, ci, cj, ck
    cdef double ap, full, inner, outer, wk, vol, u
    cdef const double[::1] e
    cdef bint xin, yin, zin
    with nogil:
        for p in range(x.shape[0]):
            ap = a[p]
            i0, i1, j0, j1, k0, k1 = I0[p], I1[p], J0[p], J1[p], K0[p], K1[p]
            mi, mj, mk = i1 - i0 + 2, j1 - j0 + 2, k1 - k0 + 2
            xin = mi == 2 and xe[i0] <= x[p] - ap and x[p] + ap <= xe[i0 + 1]
            yin = mj == 2 and ye[j0] <= y[p] - ap and y[p] + ap <= ye[j0 + 1]
            zin = mk == 2 and ze[k0] <= z[p] - ap and z[p] + ap <= ze[k0 + 1]
            if xin and yin and zin:                          # inside one box (most)
                particle[t], cell[t], w[t] = p, (i0 * ny + j0) * nz + k0, 1.0
                t += 1
                continue
            full = 4.0 / 3.0 * M_PI * ap * ap * ap
            if xin + yin + zin == 2:
                # cut by the planes of one axis only: differences of spherical caps
                if not zin:
                    u, e, m0, m1 = z[p], ze, k0, k1
                elif not yin:
                    u, e, m0, m1 = y[p], ye, j0, j1
                else:
                    u, e, m0, m1 = x[p], xe, i0, i1
                inner = below_sphere(e[m0] - u, ap)
                for m in range(m0, m1 + 1):
                    outer = below_sphere(e[m + 1] - u, ap)
                    wk = (outer - inner) / full
                    inner = outer
                    if wk > 0:
                        ci = m if not xin else i0
                        cj = m if not yin else j0
                        ck = m if not zin else k0
                        particle[t], cell[t], w[t] = p, (ci * ny + cj) * nz + ck, wk
                        t += 1
                continue
            # the cumulative volume at every corner of the boxes the sphere touches, once
            for i in range(mi):
                for j in range(mj):
                    for k in range(mk):
                        corners[(i * mj + j) * mk + k] = _below3(
                            xe[i0 + i] - x[p], ye[j0 + j] - y[p], ze[k0 + k] - z[p], ap)
            di, dj = mj * mk, mk
            for i in range(mi - 1):
                for j in range(mj - 1):
                    for k in range(mk - 1):
                        c000 = (i * mj + j) * mk + k
                        vol = (corners[c000 + di + dj + 1] - corners[c000 + dj + 1]
                               - corners[c000 + di + 1] + corners[c000 + 1]
                               - corners[c000 + di + dj] + corners[c000 + dj]
                               + corners[c000 + di] - corners[c000])
                        wk = vol / full
                        if wk > 0:
                            particle[t], cell[t], w[t] = \
                                p, ((i0 + i) * ny + j0 + j) * nz + k0 + k, wk
                            t += 1
    return particle_[:t], cell_[:t], w_[:t]


cdef int _compare(const void *a, const void *b) noexcept nogil:
    cdef double x = (<const double *>a)[0], y = (<const double *>b)[0]
    return (x > y) - (x < y)


def shell_triplets(const double[::1] d, const double[::1] z, const double[::1] a,
                   const double[::1] re, const double[::1] ze, const double[::1] mt,
                   const double[::1] mw):
    """(particle, cell, weight) of spheres in cylindrical shells, cell i nz + l: the
    integral over z of the slices' lens areas by the mapped Gauss-Legendre rule
    (nodes ``mt``, weights ``mw`` on [0, 1])."""
    cdef Py_ssize_t nz = ze.shape[0] - 1
    I0_, I1_ = spans(re, d, a)
    K0_, K1_ = spans(ze, z, a)
    cdef Py_ssize_t[::1] I0 = I0_, I1 = I1_, K0 = K0_, K1 = K1_
    ni_, nk_ = I1_ - I0_ + 1, K1_ - K0_ + 1
    size = int(np.sum(ni_ * nk_))
    particle_, cell_, w_ = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    acc_ = np.empty(int(np.max(ni_ * nk_, initial=1)))
    cdef int64_t[::1] particle = particle_, cell = cell_
    cdef double[::1] w = w_, acc = acc_
    cdef Py_ssize_t p, i, k, m, n, i0, i1, k0, k1, ni, nk, ncut, t = 0
    cdef double ap, full, inner, outer, tk, c, h, t0, t1, mid, tn, rho, wn, wk
    cdef Py_ssize_t most = 2 + int(np.max(nk_ + 1, initial=0)) + 4 * int(np.max(ni_ + 1, initial=0))
    cdef double *cuts = <double *>malloc(most * sizeof(double))
    if cuts == NULL:
        raise MemoryError()
    try:
        with nogil:
            for p in range(d.shape[0]):
                ap = a[p]
                full = 4.0 / 3.0 * M_PI * ap * ap * ap
                i0, i1, k0, k1 = I0[p], I1[p], K0[p], K1[p]
                ni, nk = i1 - i0 + 1, k1 - k0 + 1
                memset(&acc[0], 0, ni * nk * sizeof(double))
                if i0 == i1 and re[i0] <= d[p] - ap and d[p] + ap <= re[i0 + 1]:
                    # radially inside one ring: caps between the layers' edges
                    inner = below_sphere(ze[k0] - z[p], ap)
                    for k in range(k0, k1 + 1):
                        outer = below_sphere(ze[k + 1] - z[p], ap)
                        acc[k - k0] = outer - inner
                        inner = outer
                else:
                    # the pieces of [-a, a] in t = z - z_p: layer edges and tangent heights
                    cuts[0], cuts[1] = -ap, ap
                    ncut = 2
                    for k in range(k0, k1 + 2):
                        tk = ze[k] - z[p]
                        if -ap < tk < ap:
                            cuts[ncut] = tk
                            ncut += 1
                    for i in range(i0, i1 + 2):
                        for m in range(2):
                            c = fabs(re[i] - d[p]) if m == 0 else re[i] + d[p]
                            if c < ap:
                                h = sqrt(ap * ap - c * c)
                                cuts[ncut], cuts[ncut + 1] = h, -h
                                ncut += 2
                    qsort(cuts, ncut, sizeof(double), _compare)
                    for m in range(ncut - 1):
                        t0, t1 = cuts[m], cuts[m + 1]
                        if t1 - t0 <= 0.0:
                            continue
                        mid = z[p] + 0.5 * (t0 + t1)
                        k = min(max(search(ze, mid, True) - 1, 0), nz - 1)
                        if not (ze[0] <= mid < ze[nz]):
                            continue
                        for n in range(mt.shape[0]):
                            tn = t0 + (t1 - t0) * mt[n]
                            rho = sqrt(ap * ap - tn * tn if ap * ap - tn * tn > 0.0 else 0.0)
                            wn = (t1 - t0) * mw[n]
                            inner = area_in_circle(d[p], rho, re[i0])
                            for i in range(i0, i1 + 1):
                                outer = area_in_circle(d[p], rho, re[i + 1])
                                acc[(i - i0) * nk + k - k0] += wn * (outer - inner)
                                inner = outer
                for i in range(i0, i1 + 1):
                    for k in range(k0, k1 + 1):
                        wk = acc[(i - i0) * nk + k - k0] / full
                        if wk > 0:
                            particle[t], cell[t], w[t] = p, i * nz + k, wk
                            t += 1
    finally:
        free(cuts)
    return particle_[:t], cell_[:t], w_[:t]
