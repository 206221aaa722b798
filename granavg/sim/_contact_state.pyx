# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The contact pass of :mod:`granavg.sim.couette_state`, compiled ahead of time."""

import numpy as np

from libc.math cimport M_PI, hypot
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


def disk_state(const double[::1] x, const double[::1] y, const double[::1] a,
               const double[::1] count, const double[::1] trace, const double[::1] bonds,
               const double[::1] re6, const double[::1] im6, double R_i, double R_o,
               const double[:, ::1] zones, Py_ssize_t bulk):
    """One pass over the disks: per zone (rows of ``zones``: the fractions lo, hi of the
    gap; hi = 1 closes the zone) its disks, their contacts, their area pi a^2 and trace
    sum; and over the bulk zone's disks with at least 3 bonds, their number, the sum of
    |psi_6| and how many exceed 0.8; then all disks' contacts and rattlers (fewer than 2).
    ``count`` ... ``im6``: :func:`contact_state`'s (empty without contacts). Returns an
    array: zones x (n, contacts, area, trace), then (kept, psi, ordered, contacts,
    rattlers)."""
    cdef Py_ssize_t Z = zones.shape[0], p, k, n = x.shape[0]
    cdef bint contacts = count.shape[0] == n
    out = np.zeros(4 * Z + 5)
    cdef double[::1] o = out
    cdef double frac, psi, gap = R_o - R_i
    with nogil:
        for p in range(n):
            frac = (hypot(x[p], y[p]) - R_i) / gap
            if contacts:
                o[4 * Z + 3] += count[p]
                o[4 * Z + 4] += count[p] < 2
            for k in range(Z):
                if frac >= zones[k, 0] and (frac < zones[k, 1] or zones[k, 1] == 1.0):
                    o[4 * k] += 1.0
                    o[4 * k + 2] += M_PI * a[p] * a[p]
                    if contacts:
                        o[4 * k + 1] += count[p]
                        o[4 * k + 3] += trace[p]
                        if k == bulk and bonds[p] >= 3:
                            psi = hypot(re6[p], im6[p]) / bonds[p]
                            o[4 * Z] += 1.0
                            o[4 * Z + 1] += psi
                            o[4 * Z + 2] += psi > 0.8
    return out
