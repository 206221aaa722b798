"""Turning the rows of a dump frame into a float array: a kernel compiled ahead of time
(C, at install: :mod:`granavg.io._parse`) and its wrapper.

The kernel walks the bytes of a frame's row block once: it skips the columns nobody asked
for and converts the others with Clinger's fast path (an integer mantissa of at most 2^53,
its fraction's digits taken eight at a time, times an exact power of ten, |exponent| <=
22), which is correctly rounded; other numbers (17 significant digits, magnitudes beyond
1e+-22) go through the C library's ``strtod``, also correctly rounded. So the values equal
Python's ``float()`` of the same text (tests/test_parse_kernel.py). LAMMPS' ``%g``-style
numbers nearly always take the fast path.

Every scan in the kernel stops at a newline, and a row may not start at or beyond the
block's end (``limit``), so a block of newline-terminated rows is never read beyond,
whether it holds ``nrows`` rows or fewer (then MALFORMED: the caller counts the rows for
its message); within a row no byte is bounds-checked.
"""

from __future__ import annotations

import numpy as np

from granavg.io._parse import MALFORMED, NOT_FINITE, OK, count_newlines, joined, parse_rows, \
    skip_rows

__all__ = ["MALFORMED", "NOT_FINITE", "OK", "count_newlines", "joined", "parse_block",
           "parse_rows", "skip_rows"]


def parse_block(buf: np.ndarray, start: int, nrows: int, ncol: int, target: np.ndarray,
                limit: int | None = None):
    """Parse a block of ``nrows`` newline-terminated rows ending before ``limit`` (default
    the buffer's end); returns (out, status, row, col).

    ``out`` has shape (nrows, max(target) + 1), in Fortran order: each column is
    contiguous (the engine's kernels take them without a copy); see :func:`parse_rows`.
    """
    n_out = int(target.max()) + 1 if len(target) and target.max() >= 0 else 0
    out = np.empty((n_out, nrows))
    status, row, col = parse_rows(buf, start, nrows, ncol, np.asarray(target, np.int64), out,
                                  len(buf) if limit is None else limit)
    return out.T, int(status), int(row), int(col)
