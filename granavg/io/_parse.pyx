# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True, initializedcheck=False
"""The row parser of :mod:`granavg.io.parse`, compiled ahead of time (C, at install).

Every scan stops at a newline and a row may not start at or beyond ``limit``, so a block
of newline-terminated rows is never read beyond; within a row no byte is bounds-checked.
"""

from libc.math cimport INFINITY, isinf
from libc.stdlib cimport strtod
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize
from libc.string cimport memchr, memcpy

OK, MALFORMED, NOT_FINITE = 0, 1, 2
cdef int _OK = 0, _MALFORMED = 1, _NOT_FINITE = 2
cdef double _POW10[23]
#: The largest mantissa a double holds exactly (Clinger's fast path needs it exact).
cdef unsigned long long _EXACT = 1ULL << 53
for _k in range(23):
    _POW10[_k] = 10.0 ** _k
import sys
#: Digits eight at a time (:func:`_eight_value` reads the bytes as a little-endian word).
cdef bint _SWAR = sys.byteorder == "little"


cdef inline bint _blank(unsigned char c) noexcept nogil:
    return c == 32 or c == 9 or c == 13


cdef inline bint _end(unsigned char c) noexcept nogil:
    return c == 32 or c == 9 or c == 13 or c == 10


cdef inline bint _eight_digits(unsigned long long v) noexcept nogil:
    """Whether the 8 bytes in ``v`` (little-endian, as loaded) are all ASCII digits."""
    return ((v & 0xF0F0F0F0F0F0F0F0ULL) |
            (((v + 0x0606060606060606ULL) & 0xF0F0F0F0F0F0F0F0ULL) >> 4)) == \
        0x3333333333333333ULL


cdef inline unsigned long long _eight_value(unsigned long long v) noexcept nogil:
    """The number that 8 ASCII digits (the first byte the leading digit) spell: three
    multiplications for the eight, pairs then quadruples (SWAR)."""
    v -= 0x3030303030303030ULL
    v = (v * 10) + (v >> 8)
    return (((v & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32))) +
            (((v >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32)))) >> 32


cdef inline Py_ssize_t _digits(const unsigned char[::1] buf, Py_ssize_t q,
                               unsigned long long *mant) noexcept nogil:
    """Append the decimal digits at ``buf[q:]`` to ``mant``; returns their end."""
    cdef unsigned long long d
    while True:
        d = <unsigned long long>buf[q] - 48
        if d > 9:
            return q
        mant[0] = mant[0] * 10 + d
        q += 1


cdef inline Py_ssize_t _fraction_digits(const unsigned char[::1] buf, Py_ssize_t q,
                                        unsigned long long *mant) noexcept nogil:
    """:func:`_digits` for a fraction, whose runs are long (``%g`` prints six or more
    significant digits): eight at a time while eight bytes lie within the buffer (never
    read beyond it), then one by one."""
    cdef unsigned long long v
    cdef Py_ssize_t size = buf.shape[0]
    while _SWAR and q + 8 <= size:
        memcpy(&v, &buf[q], 8)
        if not _eight_digits(v):
            break
        mant[0] = mant[0] * 100000000ULL + _eight_value(v)
        q += 8
    return _digits(buf, q, mant)


cdef bint _non_finite_word(const unsigned char[::1] buf, Py_ssize_t pos) noexcept nogil:
    """Whether ``buf[pos:]`` holds nan, inf or infinity (any case) up to a blank or
    newline: how C's printf writes a non-finite number. Other words (``none``) are not
    numbers at all."""
    cdef int n = 0, k
    cdef unsigned char lower[9]
    cdef unsigned char c
    cdef const char *word = b"infinity"
    while not _end(buf[pos + n]) and n < 9:
        n += 1
    if not _end(buf[pos + n]):
        return False
    for k in range(n):
        c = buf[pos + k]
        lower[k] = c + 32 if 65 <= c <= 90 else c
    if n == 3:
        return ((lower[0] == 110 and lower[1] == 97 and lower[2] == 110) or
                (lower[0] == 105 and lower[1] == 110 and lower[2] == 102))
    if n == 8:
        for k in range(8):
            if lower[k] != <unsigned char>word[k]:
                return False
        return True
    return False


cdef int _slow_number(const unsigned char[::1] buf, Py_ssize_t start, Py_ssize_t end,
                      double *value) noexcept nogil:
    """A number off the fast path (a mantissa beyond 2^53, a power of ten beyond 10^22):
    the C library's strtod, correctly rounded, over ``buf[start:end]``, which the caller
    has checked is a decimal number; NOT_FINITE where it overflows. Where strtod stops
    elsewhere (a locale whose decimal point is not '.'), :func:`_long_number`."""
    cdef char *stop
    value[0] = strtod(<const char *>&buf[start], &stop)
    if stop != <const char *>&buf[end]:
        return _long_number(buf, start, value, &end)
    if isinf(value[0]):
        value[0] = 0.0
        return _NOT_FINITE
    return _OK


cdef int _long_number(const unsigned char[::1] buf, Py_ssize_t pos, double *value,
                      Py_ssize_t *end) noexcept nogil:
    """A number of more than 17 digits (or a huge exponent), to within a few units in the
    last place: its status, value and end."""
    cdef bint neg = buf[pos] == 45, eneg
    cdef long long mant = 0, sig = 0, exp10 = 0, e
    if neg or buf[pos] == 43:
        pos += 1
    while 48 <= buf[pos] <= 57:
        if sig < 18:
            mant = mant * 10 + (buf[pos] - 48)
            sig += mant > 0
        else:
            exp10 += 1
        pos += 1
    if buf[pos] == 46:
        pos += 1
        while 48 <= buf[pos] <= 57:
            if sig < 18:
                mant = mant * 10 + (buf[pos] - 48)
                sig += mant > 0
                exp10 -= 1
            pos += 1
    if buf[pos] == 101 or buf[pos] == 69:
        pos += 1
        eneg = buf[pos] == 45
        if eneg or buf[pos] == 43:
            pos += 1
        e = 0
        while 48 <= buf[pos] <= 57:
            e = min(e * 10 + (buf[pos] - 48), 100000)
            pos += 1
        exp10 += -e if eneg else e
    cdef double v = <double>mant * 10.0 ** <double>exp10
    end[0] = pos
    if v == INFINITY:
        value[0] = 0.0
        return _NOT_FINITE
    value[0] = -v if neg else v
    return _OK


def parse_rows(const unsigned char[::1] buf, Py_ssize_t pos, Py_ssize_t nrows,
               Py_ssize_t ncol, const long long[::1] target, double[:, ::1] out,
               Py_ssize_t limit):
    """Parse ``nrows`` rows of ``ncol`` numbers from ``buf[pos:]`` (the GIL released).

    Parameters
    ----------
    buf : ndarray of uint8
        Bytes holding the rows, each ending with ``\\n``.
    pos : int
        Offset of the first row.
    nrows, ncol : int
        Rows to read; numbers per row.
    target : ndarray of int64, shape (ncol,)
        Output column of each input column, or -1 to skip it.
    out : ndarray of float64, shape (n_out, nrows)
        Filled in place, a column per row of ``out`` (so that each column is contiguous).
    limit : int
        Where the block ends: a row starting there is not one of its rows (MALFORMED),
        so a block holding fewer rows than ``nrows`` is never read beyond.

    Returns
    -------
    status, row, col : int
        ``OK`` (row = nrows, col = offset after the block); otherwise ``MALFORMED`` or
        ``NOT_FINITE`` with the 0-based row and column of the first bad value
        (col = ncol: too many values in the row).
    """
    cdef Py_ssize_t row = 0, col = 0
    cdef int status
    with nogil:
        status = _parse(buf, &pos, nrows, ncol, target, out, limit, &row, &col)
    if status == _OK:
        return OK, nrows, pos
    return status, row, col


cdef int _parse(const unsigned char[::1] buf, Py_ssize_t *at, Py_ssize_t nrows,
                Py_ssize_t ncol, const long long[::1] target, double[:, ::1] out,
                Py_ssize_t limit, Py_ssize_t *bad_row, Py_ssize_t *bad_col) noexcept nogil:
    cdef Py_ssize_t pos = at[0], row, col, start, q, f, ndig, edig
    cdef long long dst, exp10
    cdef unsigned long long mant, e
    cdef unsigned char c
    cdef bint neg, eneg
    cdef int status
    cdef double value
    for row in range(nrows):
        bad_row[0] = row
        if pos >= limit:
            bad_col[0] = 0
            return _MALFORMED
        for col in range(ncol):
            bad_col[0] = col
            while _blank(buf[pos]):
                pos += 1
            c = buf[pos]
            if c == 10:
                return _MALFORMED
            dst = target[col]
            if dst < 0:
                while not _end(buf[pos]):
                    pos += 1
                continue
            start = pos
            neg = c == 45
            if neg or c == 43:
                pos += 1
            mant = 0
            q = _digits(buf, pos, &mant)
            ndig = q - pos
            exp10 = 0
            if buf[q] == 46:
                f = q + 1
                q = _fraction_digits(buf, f, &mant)
                exp10 = f - q
                ndig += q - f
            if ndig == 0:
                if _non_finite_word(buf, pos):
                    return _NOT_FINITE
                return _MALFORMED
            if buf[q] == 101 or buf[q] == 69:
                q += 1
                eneg = buf[q] == 45
                if eneg or buf[q] == 43:
                    q += 1
                f = q
                e = 0
                q = _digits(buf, f, &e)
                edig = q - f
                if edig == 0:
                    return _MALFORMED
                exp10 += (-1 if eneg else 1) * (<long long>e if edig <= 5 else 100)
            if not _end(buf[q]):
                return _MALFORMED
            if ndig > 19 or mant > _EXACT or exp10 > 22 or exp10 < -22:
                status = _slow_number(buf, start, q, &value)
                if status != _OK:
                    return status
                out[dst, row] = value
            else:
                value = <double>mant
                value = value / _POW10[-exp10] if exp10 < 0 else value * _POW10[exp10]
                out[dst, row] = -value if neg else value
            pos = q
        bad_col[0] = ncol
        while _blank(buf[pos]):
            pos += 1
        if buf[pos] != 10:
            return _MALFORMED
        pos += 1
    at[0] = pos
    return _OK


def skip_rows(const unsigned char[::1] buf, Py_ssize_t start, Py_ssize_t n,
              Py_ssize_t limit):
    """The offset just past the n-th newline from ``start`` within buf[start:limit]
    (``start`` itself for n = 0), or -1 if fewer newlines lie there: n rows passed over
    in one memchr walk, the GIL released, nothing parsed."""
    cdef const unsigned char *base = &buf[0] if buf.shape[0] else NULL
    cdef const unsigned char *at
    cdef Py_ssize_t pos = start, k = 0
    if n == 0:
        return start
    if base == NULL or start >= limit:
        return -1
    with nogil:
        while k < n:
            at = <const unsigned char *>memchr(base + pos, 10, limit - pos)
            if at == NULL:
                break
            pos = at - base + 1
            k += 1
    return pos if k == n else -1


def count_newlines(const unsigned char[::1] buf, Py_ssize_t start, Py_ssize_t end):
    """Newlines in buf[start:end] (uint8), counted in place (the GIL released): a mapped
    file's block is not copied to be counted."""
    cdef Py_ssize_t i, n = 0
    with nogil:
        for i in range(start, end):
            n += buf[i] == 10
    return n


def joined(const unsigned char[::1] head, Py_ssize_t start, const unsigned char[::1] tail):
    """``head[start:] + tail`` as a new bytes object, copied with the GIL released: a
    decompressed chunk appended to a buffer's unread rest while other threads run Python
    (a plain ``+`` holds the GIL for the whole copy, page faults included)."""
    cdef Py_ssize_t n_head = head.shape[0] - start if head.shape[0] > start else 0
    cdef Py_ssize_t n_tail = tail.shape[0]
    out = PyBytes_FromStringAndSize(NULL, n_head + n_tail)
    cdef char *dst = PyBytes_AS_STRING(out)
    with nogil:
        if n_head:
            memcpy(dst, &head[start], n_head)
        if n_tail:
            memcpy(dst + n_head, &tail[0], n_tail)
    return out
