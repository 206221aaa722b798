"""Compiled kernel that turns the rows of a dump frame into a float array.

The kernel walks the bytes of a frame's row block once: it skips the columns nobody asked
for and converts the others with Clinger's fast path (an integer mantissa of at most 17
digits times an exact power of ten, |exponent| <= 22), which is correctly rounded, so the
values equal Python's ``float()`` of the same text. LAMMPS' ``%g``-style numbers always
take that path; longer numbers go through a slower loop that may differ in the last bit.

Every scan in the kernel stops at a newline, and a row may not start at or beyond the
block's end (``limit``), so a block of newline-terminated rows is never read beyond,
whether it holds ``nrows`` rows or fewer (then MALFORMED: the caller counts the rows for
its message); within a row no byte is bounds-checked.
"""

from __future__ import annotations

import numpy as np
from numba import njit

OK, MALFORMED, NOT_FINITE = 0, 1, 2
_POW10 = np.array([10.0**k for k in range(23)])
_U48, _U9 = np.uint64(48), np.uint64(9)
_SPACE, _TAB, _CR, _LF = 32, 9, 13, 10


@njit(cache=True, nogil=True, inline="always")
def _blank(c):
    return c == _SPACE or c == _TAB or c == _CR


@njit(cache=True, nogil=True, inline="always")
def _digits(buf, q, mant):
    """Append the decimal digits at ``buf[q:]`` to ``mant``; returns (end, mant)."""
    while True:
        d = np.uint64(buf[q]) - _U48
        if d > _U9:
            return q, mant
        mant = mant * np.uint64(10) + d
        q += 1


@njit(cache=True, nogil=True)
def _non_finite_word(buf, pos):
    """Whether ``buf[pos:]`` holds nan, inf or infinity (any case) up to a blank or
    newline: how C's printf writes a non-finite number. Other words (``none``) are not
    numbers at all."""
    n = 0
    while not (_blank(buf[pos + n]) or buf[pos + n] == _LF) and n < 9:
        n += 1
    if not (_blank(buf[pos + n]) or buf[pos + n] == _LF):
        return False
    lower = np.empty(n, np.uint8)
    for k in range(n):
        c = buf[pos + k]
        lower[k] = c + 32 if 65 <= c <= 90 else c
    if n == 3:
        return ((lower[0] == 110 and lower[1] == 97 and lower[2] == 110) or
                (lower[0] == 105 and lower[1] == 110 and lower[2] == 102))
    if n == 8:
        word = (105, 110, 102, 105, 110, 105, 116, 121)             # infinity
        for k in range(8):
            if lower[k] != word[k]:
                return False
        return True
    return False


@njit(cache=True, nogil=True)
def _long_number(buf, pos, pow10):
    """A number of more than 17 digits (or a huge exponent): (status, value, end)."""
    neg = buf[pos] == 45
    if neg or buf[pos] == 43:
        pos += 1
    mant, sig, exp10 = 0, 0, 0
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
    value = float(mant) * 10.0**exp10
    if value == np.inf:
        return NOT_FINITE, 0.0, pos
    return OK, -value if neg else value, pos


@njit(cache=True, nogil=True)
def parse_rows(buf, pos, nrows, ncol, target, out, pow10, limit):
    """Parse ``nrows`` rows of ``ncol`` numbers from ``buf[pos:]``.

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
    out : ndarray of float64, shape (nrows, n_out)
        Filled in place.
    pow10 : ndarray of float64
        10**0 ... 10**22.
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
    for row in range(nrows):
        if pos >= limit:
            return MALFORMED, row, 0
        for col in range(ncol):
            while _blank(buf[pos]):
                pos += 1
            c = buf[pos]
            if c == _LF:
                return MALFORMED, row, col
            dst = target[col]
            if dst < 0:
                while not (_blank(buf[pos]) or buf[pos] == _LF):
                    pos += 1
                continue
            start = pos
            neg = c == 45
            if neg or c == 43:
                pos += 1
            q, mant = _digits(buf, pos, np.uint64(0))
            ndig = q - pos
            exp10 = 0
            if buf[q] == 46:
                f = q + 1
                q, mant = _digits(buf, f, mant)
                exp10 = f - q
                ndig += q - f
            if ndig == 0:
                if _non_finite_word(buf, pos):
                    return NOT_FINITE, row, col
                return MALFORMED, row, col
            if buf[q] == 101 or buf[q] == 69:
                q += 1
                eneg = buf[q] == 45
                if eneg or buf[q] == 43:
                    q += 1
                f = q
                q, e = _digits(buf, f, np.uint64(0))
                edig = q - f
                if edig == 0:
                    return MALFORMED, row, col
                e = np.int64(e) if edig <= 5 else 100
                exp10 += -e if eneg else e
            if not (_blank(buf[q]) or buf[q] == _LF):
                return MALFORMED, row, col
            if ndig > 17 or exp10 > 22 or exp10 < -22:
                status, value, q = _long_number(buf, start, pow10)
                if status != OK:
                    return status, row, col
                out[row, dst] = value
            else:
                value = float(mant)
                value = value / pow10[-exp10] if exp10 < 0 else value * pow10[exp10]
                out[row, dst] = -value if neg else value
            pos = q
        while _blank(buf[pos]):
            pos += 1
        if buf[pos] != _LF:
            return MALFORMED, row, ncol
        pos += 1
    return OK, nrows, pos


def parse_block(buf: np.ndarray, start: int, nrows: int, ncol: int, target: np.ndarray,
                limit: int | None = None):
    """Parse a block of ``nrows`` newline-terminated rows ending before ``limit`` (default
    the buffer's end); returns (out, status, row, col).

    ``out`` has shape (nrows, max(target) + 1); see :func:`parse_rows`.
    """
    n_out = int(target.max()) + 1 if len(target) and target.max() >= 0 else 0
    out = np.empty((nrows, n_out))
    status, row, col = parse_rows(buf, start, nrows, ncol, target, out, _POW10,
                                  len(buf) if limit is None else limit)
    return out, int(status), int(row), int(col)


@njit(cache=True, nogil=True)
def count_newlines(buf, start, end):
    """Newlines in buf[start:end] (uint8), counted in place: a mapped file's block is
    not copied to be counted."""
    n = 0
    for i in range(start, end):
        n += buf[i] == 10
    return n
