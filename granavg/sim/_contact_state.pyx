# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The contact pass of :mod:`granavg.sim.couette_state`, compiled ahead of time."""

import numpy as np

from libc.stdint cimport int64_t


def contact_state(const int64_t[::1] i1, const int64_t[::1] i2, const double[::1] fn,
                  const double[::1] a, const double[::1] x, const double[::1] y,
                  Py_ssize_t n):
    """One pass over the contacts: each disk's contact count, its sum a f.n (the trace of
    its stress sum) and the sums cos 6 theta, sin 6 theta over its disk-disk bonds
    (theta the bond's angle; the reverse bond has the same); shape (n,) each."""
    out = np.zeros((5, n))
    cdef double[:, ::1] o = out
    cdef Py_ssize_t c, p, q
    cdef double dx, dy, r2, u, v, cs, c6, s6
    with nogil:
        for c in range(i1.shape[0]):
            p, q = i1[c], i2[c]
            o[0, p] += 1.0
            o[1, p] += a[p] * fn[c]
            if q < 0:
                continue
            o[0, q] += 1.0
            o[1, q] += a[q] * fn[c]
            dx, dy = x[q] - x[p], y[q] - y[p]
            r2 = dx * dx + dy * dy
            if r2 > 0.0:
                u, v = dx * dx / r2, dy * dy / r2            # cos^2, sin^2
                cs = dx * dy / r2                              # cos sin
                c6 = u * u * u - 15.0 * u * u * v + 15.0 * u * v * v - v * v * v
                s6 = cs * (6.0 * u * u - 20.0 * u * v + 6.0 * v * v)
                o[2, p] += 1.0
                o[2, q] += 1.0
                o[3, p] += c6
                o[4, p] += s6
                o[3, q] += c6
                o[4, q] += s6
    return tuple(out)
