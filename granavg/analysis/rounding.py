"""Numbers as a reader should see them: a value rounded to its error (the error to two
significant digits, the value to the same decimal place), with a common power of ten
where fixed notation would need many zeros."""

from __future__ import annotations

import math

#: Magnitudes shown in fixed notation; beyond, a common power of ten.
FIXED = (1e-2, 1e5)


def _places(err: float, digits: int) -> int:
    """Decimal places that keep ``digits`` significant digits of ``err`` (negative:
    rounding to tens, hundreds, ...)."""
    return digits - 1 - math.floor(math.log10(err))


def pm(value, err, unit: str = "", digits: int = 2, sep: str = " +- ") -> str:
    """``value +- err`` rounded to the error, e.g. ``0.81 +- 0.11``, ``-0.213 +- 0.012``,
    ``(3.860 +- 0.084) x 10^-3``; a value without a finite, positive error keeps four
    significant digits and says so; ``unit`` follows, after a space."""
    tail = f" {unit}" if unit else ""
    value = float(value)
    if not math.isfinite(value):
        return f"{value}{tail}"
    err = float(err) if err is not None else float("nan")
    if not (math.isfinite(err) and err > 0):
        return f"{value:.4g}{tail} (no error)"
    big = max(abs(value), err)
    power = 0
    if not FIXED[0] <= big < FIXED[1]:
        power = math.floor(math.log10(big))
        value, err = value / 10 ** power, err / 10 ** power
    places = _places(err, digits)
    err_r = round(err, places)
    if err_r >= 10 ** (digits - places):             # 0.0996 -> 0.10: one digit less
        places -= 1
        err_r = round(err, places)
    shown = max(places, 0)
    text = f"{round(value, places):.{shown}f}{sep}{err_r:.{shown}f}"
    if power:
        return f"({text}) x 10^{power}{tail}"
    return f"{text}{tail}"


def plain(value, digits: int = 3) -> str:
    """A number without an error, to ``digits`` significant digits."""
    return f"{float(value):.{digits}g}"
