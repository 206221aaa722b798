"""The row parser's kernel (granavg.io._parse) against Python's float() of the same text,
bit for bit: every number a printf format writes (mantissas beyond 2^53 and exponents
beyond 22 among them), digit runs of every length around the eight-digit steps, and rows
that end exactly at the buffer's end (where an eight-byte load would read beyond it)."""

import numpy as np
import pytest

from granavg.io.parse import MALFORMED, OK, parse_block

FORMATS = ("%g", "%.6g", "%.10g", "%.12g", "%.15g", "%.17g", "%.8e", "%.16e", "%f",
           "%.10f", "%.3f", "%d")


def _numbers(rng, n):
    """Values over many magnitudes and signs, zeros and integers among them."""
    mag = 10.0 ** rng.uniform(-22, 22, n)
    v = rng.choice([-1.0, 1.0], n) * mag * rng.uniform(1, 10, n)
    v[::17] = 0.0
    v[::23] = rng.integers(-10 ** 6, 10 ** 6, len(v[::23]))
    return v


def _parse(text: bytes, nrows, ncol):
    buf = np.frombuffer(text, dtype=np.uint8)
    out, status, row, col = parse_block(buf, 0, nrows, ncol, np.arange(ncol))
    assert status == OK, (row, col)
    return out


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_printf_format_reads_as_python_float_reads_it(fmt):
    rng = np.random.default_rng(7)
    v = _numbers(rng, 6000)
    if fmt == "%d":
        v = np.round(v[np.abs(v) < 1e15])
    words = [fmt % x for x in v]
    nrows = len(words) // 6
    words = words[:nrows * 6]
    text = "\n".join(" ".join(words[i:i + 6]) for i in range(0, len(words), 6)) + "\n"
    got = _parse(text.encode(), nrows, 6)
    want = np.array([float(w) for w in words]).reshape(nrows, 6)
    assert np.array_equal(got, want)            # correctly rounded, on either path


@pytest.mark.parametrize("ndig", range(1, 19))
def test_digit_runs_of_every_length_read_exactly(ndig):
    rng = np.random.default_rng(ndig)
    words = []
    for _ in range(400):
        digits = "".join(rng.choice(list("0123456789"), ndig))
        words += [f"0.{digits}", f"-{digits[:1]}.{digits[1:]}e-07", f"{digits}",
                  f"+.{digits}", f"{digits}.{digits[::-1]}"[:20]]
    text = "\n".join(" ".join(words[i:i + 5]) for i in range(0, len(words), 5)) + "\n"
    got = _parse(text.encode(), len(words) // 5, 5).ravel()
    assert np.array_equal(got, np.array([float(w) for w in words]))


@pytest.mark.parametrize("tail", ["1.2345678", "0.123456789012", "7.25e-05", "12345678"])
def test_a_row_ending_at_the_buffers_end_is_read_and_not_beyond(tail):
    """The buffer holds exactly the row: an eight-byte step near its end would read past
    it (a mapped file ends at a page); the kernel steps one byte at a time there."""
    for lead in range(12):                     # every alignment of the last number
        text = (" " * lead + "1 " + tail + "\n").encode()
        buf = np.frombuffer(bytearray(text), dtype=np.uint8)   # exactly this long
        out, status, _, _ = parse_block(buf, 0, 1, 2, np.arange(2))
        assert status == OK and out[0, 1] == float(tail)
