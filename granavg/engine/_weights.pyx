# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The exact weights of disks (and of spheres in slabs) in 1D cells and 2D grids (Eq. 1),
compiled ahead of time; the wrappers and the derivations are in
:mod:`granavg.engine.weights`. The loops run with the GIL released."""

import numpy as np

from libc.math cimport M_PI, asin, sqrt
from libc.stdint cimport int64_t

from granavg.engine._geometry cimport area_in_circle, below_disk, below_sphere, span


def areas(const double[::1] d, const double[::1] a, const double[::1] R, double[::1] out):
    """out[i] = the area of disk (d[i], a[i]) inside the circle of radius R[i]."""
    cdef Py_ssize_t i
    with nogil:
        for i in range(d.shape[0]):
            out[i] = area_in_circle(d[i], a[i], R[i])


cdef inline double _cumulative(int mode, double pos, double a, double edge) noexcept nogil:
    """Area of a disk (centre coordinate pos, radius a) on the inner side of a cell edge:
    inside the circle of radius ``edge`` (mode 0, rings) or below x = edge (mode 1,
    strips); mode 2: the volume of a sphere below x = edge (3D slabs)."""
    if mode == 0:
        return area_in_circle(pos, a, edge)
    if mode == 1:
        return below_disk(edge - pos, a)
    return below_sphere(edge - pos, a)


def spans(const double[::1] edges, const double[::1] u, const double[::1] a):
    """The first and last cell of ``edges`` that each particle's [u - a, u + a] reaches
    (clamped), shape (P,) each."""
    lo, hi = np.empty(u.shape[0], np.intp), np.empty(u.shape[0], np.intp)
    cdef Py_ssize_t[::1] L = lo, H = hi
    cdef Py_ssize_t p
    with nogil:
        for p in range(u.shape[0]):
            span(edges, u[p], a[p], &L[p], &H[p])
    return lo, hi


def triplets(const double[::1] pos, const double[::1] a, const double[::1] edges, int mode):
    """(particle, cell, weight) of disks (or spheres, mode 2) in 1D cells, from
    differences of cumulative areas (volumes) at consecutive edges."""
    cdef Py_ssize_t n = pos.shape[0], p, k, t = 0
    lo_, hi_ = spans(edges, pos, a)
    cdef Py_ssize_t[::1] lo = lo_, hi = hi_
    size = int(np.sum(hi_ - lo_)) + n
    particle_, cell_, w_ = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    cdef int64_t[::1] particle = particle_, cell = cell_
    cdef double[::1] w = w_
    cdef double u, ap, full, inner, outer, wk
    with nogil:
        for p in range(n):
            u, ap = pos[p], a[p]
            full = M_PI * ap * ap if mode < 2 else 4.0 / 3.0 * M_PI * ap * ap * ap
            inner = _cumulative(mode, u, ap, edges[lo[p]])
            for k in range(lo[p], hi[p] + 1):
                outer = _cumulative(mode, u, ap, edges[k + 1])
                wk = (outer - inner) / full
                inner = outer
                if wk > 0:
                    particle[t], cell[t], w[t] = p, k, wk
                    t += 1
    return particle_[:t], cell_[:t], w_[:t]


cdef inline double _antideriv(double x, double a) noexcept nogil:
    """Integral of sqrt(a^2 - x^2) dx from 0 to x (|x| <= a)."""
    cdef double m = a * a - x * x
    return 0.5 * (x * sqrt(m if m > 0.0 else 0.0) + a * a * asin(x / a))


cdef inline double _corner(double X, double Y, double a) noexcept nogil:
    """Area of a disk of radius a (centre 0) with x < X and y < Y, in closed form: the
    integral over x of the chord's part below Y."""
    cdef double x1, c, area, lo, hi
    if X <= -a or Y <= -a:
        return 0.0
    if Y >= a:
        return below_disk(X, a)
    if X >= a:
        return below_disk(Y, a)
    x1 = min(X, a)
    c = sqrt(a * a - Y * Y)
    area = 0.0
    if Y >= 0.0:                                  # full chords where |x| > c
        lo = min(x1, -c)
        area += 2.0 * (_antideriv(lo, a) - _antideriv(-a, a))
        if x1 > c:
            area += 2.0 * (_antideriv(x1, a) - _antideriv(c, a))
    if x1 > -c:                                   # chords cut at Y where |x| < c
        hi = min(x1, c)
        area += Y * (hi + c) + _antideriv(hi, a) - _antideriv(-c, a)
    return area


def grid_triplets(const double[::1] x, const double[::1] y, const double[::1] a,
                  const double[::1] xe, const double[::1] ye):
    """(particle, cell, weight) of disks in the rectangles of a grid, cell i ny + j."""
    cdef Py_ssize_t ny = ye.shape[0] - 1, p, i, j, t = 0
    I0_, I1_ = spans(xe, x, a)
    J0_, J1_ = spans(ye, y, a)
    cdef Py_ssize_t[::1] I0 = I0_, I1 = I1_, J0 = J0_, J1 = J1_
    size = int(np.sum((I1_ - I0_ + 1) * (J1_ - J0_ + 1)))
    particle_, cell_, w_ = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    cdef int64_t[::1] particle = particle_, cell = cell_
    cdef double[::1] w = w_
    cdef double full, xl, xh, yl, yh, area, wk, ap
    with nogil:
        for p in range(x.shape[0]):
            ap = a[p]
            full = M_PI * ap * ap
            for i in range(I0[p], I1[p] + 1):
                xl, xh = xe[i] - x[p], xe[i + 1] - x[p]
                for j in range(J0[p], J1[p] + 1):
                    yl, yh = ye[j] - y[p], ye[j + 1] - y[p]
                    area = (_corner(xh, yh, ap) - _corner(xl, yh, ap)
                            - _corner(xh, yl, ap) + _corner(xl, yl, ap))
                    wk = area / full
                    if wk > 0:
                        particle[t], cell[t], w[t] = p, i * ny + j, wk
                        t += 1
    return particle_[:t], cell_[:t], w_[:t]


from granavg.engine._geometry cimport _cut, _segment


def cut(double r2, double chord, double x):
    """The segment area of :func:`granavg.engine.weights.area_inside_circle`'s lens, one
    value (for tests)."""
    return _cut(r2, chord, x)


def segment(double theta):
    """theta - sin theta cos theta, with its thin-segment series (for tests)."""
    return _segment(theta)


def area(double d, double a, double R):
    """One value of :func:`granavg.engine.weights.area_inside_circle`."""
    return area_in_circle(d, a, R)
