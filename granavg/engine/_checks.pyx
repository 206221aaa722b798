# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The per-frame checks of :mod:`granavg.io.frames`, compiled ahead of time: one pass over
a frame's columns each. A frame's columns are short (thousands of rows), and a pass of a
few microseconds that released the GIL would wait longer to get it back from a thread
running Python than it runs: the GIL is released only for long columns."""

import numpy as np

from libc.math cimport fabs, floor, hypot, sqrt

#: Rows above which a pass releases the GIL.
cdef Py_ssize_t LONG = 100000


cdef void _not_integers(const double[:] v, bint ids, double exact, Py_ssize_t *bad,
                        Py_ssize_t *huge) noexcept nogil:
    cdef Py_ssize_t i
    cdef double x
    for i in range(v.shape[0]):
        x = v[i]
        if bad[0] < 0 and x != floor(x):
            bad[0] = i
        if ids and huge[0] < 0 and fabs(x) >= exact:
            huge[0] = i
        if bad[0] >= 0 and (huge[0] >= 0 or not ids):
            break


def not_integers(const double[:] v, bint ids, double exact):
    """The first row whose value is not an integer (NaN included), and, for ids, the first
    whose magnitude is ``exact`` or more; -1 where there is none."""
    cdef Py_ssize_t bad = -1, huge = -1
    if v.shape[0] > LONG:
        with nogil:
            _not_integers(v, ids, exact, &bad, &huge)
    else:
        _not_integers(v, ids, exact, &bad, &huge)
    return bad, huge


cdef void _contacts(Py_ssize_t n, const double[:] id1, const double[:] id2, bint pairs,
                    const double[:] wall, bint walls, const double[:] nx,
                    const double[:] ny, const double[:] nz, int axes, double[::1] norm,
                    Py_ssize_t *code, Py_ssize_t *itself, Py_ssize_t *worst,
                    double *off) noexcept nogil:
    cdef Py_ssize_t c
    cdef double w, d
    for c in range(n):
        if walls:
            w = wall[c]
            if code[0] < 0 and not (w == 0.0 or w == 1.0 or w == 2.0):
                code[0] = c
        if pairs and itself[0] < 0 and id1[c] == id2[c] and (not walls or wall[c] == 0.0):
            itself[0] = c
        if axes:
            norm[c] = hypot(nx[c], ny[c]) if axes == 2 else \
                sqrt(nx[c] * nx[c] + ny[c] * ny[c] + nz[c] * nz[c])
            d = fabs(norm[c] - 1.0)
            if d > off[0]:
                off[0], worst[0] = d, c


def contact_rows_checked(Py_ssize_t n, id1, id2, wall, nx, ny, nz):
    """One pass over a frame's n contact rows: the first row whose wall code is not 0, 1
    or 2, the first particle-particle row of an atom with itself, and, with normals, their
    lengths |n| and the row whose |n| - 1 is largest, with that value (rows -1: none).
    Each column may be None (absent: its check left out; ``nz`` None in 2D). Returns
    (code, itself, norm, worst, off)."""
    cdef Py_ssize_t code = -1, itself = -1, worst = -1
    cdef double off = 0.0
    cdef int axes = 0 if nx is None or ny is None else (2 if nz is None else 3)
    cdef bint pairs = id1 is not None and id2 is not None
    norm_ = np.empty(n if axes else 0)
    empty = np.zeros(n)
    cdef const double[:] i1 = id1 if pairs else empty
    cdef const double[:] i2 = id2 if pairs else empty
    cdef const double[:] w = empty if wall is None else wall
    cdef const double[:] x = nx if axes else empty
    cdef const double[:] y = ny if axes else empty
    cdef const double[:] z = nz if axes == 3 else empty
    cdef double[::1] norm = norm_
    if n > LONG:
        with nogil:
            _contacts(n, i1, i2, pairs, w, wall is not None, x, y, z, axes, norm, &code,
                      &itself, &worst, &off)
    else:
        _contacts(n, i1, i2, pairs, w, wall is not None, x, y, z, axes, norm, &code,
                  &itself, &worst, &off)
    return code, itself, norm_, worst, off
