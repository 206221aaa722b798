# cython: language_level=3
# The closed-form areas and volumes of the exact weights (Eq. 1), inline C shared by the
# compiled weight and sector kernels (granavg/engine/_weights.pyx, _sphere_weights.pyx,
# cells/_sectors.pyx); their derivations are in granavg/engine/weights.py.

from libc.math cimport M_PI, acos, asin, atan2, cos, fabs, sin, sqrt


cdef inline double _segment(double theta) noexcept nogil:
    """Area of a circular segment of half-angle theta over r^2: theta - sin cos; a series
    for thin segments, where the difference would cancel catastrophically."""
    cdef double t2
    if theta < 1e-2:
        t2 = theta * theta
        return theta * t2 * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (4.0 / 315.0)))
    return theta - sin(theta) * cos(theta)


cdef inline double _cut(double r2, double chord, double x) noexcept nogil:
    """Area of the segment of a circle (radius^2 r2 = chord^2 + x^2) cut off by a chord
    of half-length ``chord`` at distance ``x`` from its centre (x < 0: the larger part);
    a thin segment (chord / x < 0.1) by its series."""
    cdef double t2
    if x > 10.0 * chord:
        t2 = (chord / x) * (chord / x)
        return chord * chord * chord / x * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (
            2.0 / 35.0 - t2 * (2.0 / 63.0 - t2 * (2.0 / 99.0 - t2 * (2.0 / 143.0))))))
    return r2 * atan2(chord, x) - chord * x


cdef inline double area_in_circle(double d, double a, double R) noexcept nogil:
    """Area of a disk of radius a centred at distance d from the origin inside the
    circle of radius R about the origin (the lens; granavg.engine.weights._area)."""
    cdef double k, chord, x
    if d + a <= R:
        return M_PI * a * a
    if R <= a - d:
        return M_PI * R * R
    if d >= R + a or d <= fabs(R - a):
        return 0.0
    k = (-d + a + R) * (d + a - R) * (d - a + R) * (d + a + R)
    chord = 0.5 * sqrt(k if k > 0.0 else 0.0) / d
    x = (d * d + R * R - a * a) / (2.0 * d)
    return _cut(R * R, chord, x) + _cut(a * a, chord, d - x)


cdef inline double below_disk(double u, double a) noexcept nogil:
    """Area of a disk of radius a (centre 0) with x < u; the smaller side is always the
    segment formula, so thin parts keep precision."""
    if u <= -a:
        return 0.0
    if u >= a:
        return M_PI * a * a
    if u < 0.0:
        return a * a * _segment(acos(-u / a))
    return M_PI * a * a - a * a * _segment(acos(u / a))


cdef inline double below_sphere(double u, double a) noexcept nogil:
    """Volume of a sphere of radius a (centre 0) with x < u; the smaller side is always
    the cap pi h^2 (3a - h) / 3, so thin parts keep precision."""
    cdef double h
    if u <= -a:
        return 0.0
    if u >= a:
        return 4.0 / 3.0 * M_PI * a * a * a
    if u < 0.0:
        h = a + u
        return M_PI * h * h * (3.0 * a - h) / 3.0
    h = a - u
    return 4.0 / 3.0 * M_PI * a * a * a - M_PI * h * h * (3.0 * a - h) / 3.0


cdef inline double below_fraction(double u, double a, int dim) noexcept nogil:
    """Fraction of a disk (dim 2) or sphere (dim 3) of radius a, centre 0, with x < u."""
    if dim == 2:
        return below_disk(u, a) / (M_PI * a * a)
    return below_sphere(u, a) / (4.0 / 3.0 * M_PI * a * a * a)


cdef inline Py_ssize_t search(const double[::1] edges, double v, bint right) noexcept nogil:
    """numpy's searchsorted of one value (side "right" or "left"; NaN after all)."""
    cdef Py_ssize_t lo = 0, hi = edges.shape[0], mid
    if v != v:
        return hi
    while lo < hi:
        mid = (lo + hi) >> 1
        if (edges[mid] <= v) if right else (edges[mid] < v):
            lo = mid + 1
        else:
            hi = mid
    return lo


cdef inline void span(const double[::1] edges, double u, double a, Py_ssize_t *lo,
                      Py_ssize_t *hi) noexcept nogil:
    """The first and last cell of ``edges`` that [u - a, u + a] reaches (clamped)."""
    cdef Py_ssize_t n = edges.shape[0] - 1
    lo[0] = min(max(search(edges, u - a, True) - 1, 0), n - 1)
    hi[0] = min(max(search(edges, u + a, False) - 1, 0), n - 1)
