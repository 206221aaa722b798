"""The ring weights' lens area against the textbook segment form, in one process.

    python benchmarks/lens.py

Both compiled with numba over the same 2 x 10^5 disks straddling a circle 33 radii
away: granavg's segments r^2 theta - chord x (granavg.engine.weights) against
r^2 (theta - sin theta cos theta) with theta from atan2, the form granavg used before.
Prints the largest difference (in units of the disk's area) and ns per lens, the ratio
paired pass by pass (15 pairs).
"""

import math
import time

import numpy as np
from numba import njit

from granavg.engine.weights import area as _area_scalar, segment as _segment


@njit
def textbook(d, a, R):
    """The lens only (every disk here straddles the circle: granavg's form also tests
    for the other cases, so the ratio is on the safe side)."""
    k = (-d + a + R) * (d + a - R) * (d - a + R) * (d + a + R)
    chord = 0.5 * math.sqrt(max(k, 0.0)) / d
    x = (d * d + R * R - a * a) / (2.0 * d)
    return (R * R * _segment(math.atan2(chord, x))
            + a * a * _segment(math.atan2(chord, d - x)))


@njit
def total(f, d, a, R):
    s = 0.0
    for i in range(d.shape[0]):
        s += f(d[i], a[i], R)
    return s


def main():
    rng = np.random.default_rng(1)
    n, R = 200_000, 0.15
    a = rng.uniform(0.003, 0.0045, n)
    d = R + rng.uniform(-1, 1, n) * a * 0.999
    diff = max(abs(textbook(*t, R) - _area_scalar(*t, R)) / (math.pi * t[1] ** 2)
               for t in zip(d[:20000], a[:20000]))
    total(textbook, d, a, R), total(_area_scalar, d, a, R)
    old, new = [], []
    for _ in range(15):
        for f, times in ((textbook, old), (_area_scalar, new)):
            t0 = time.perf_counter()
            total(f, d, a, R)
            times.append(time.perf_counter() - t0)
    ratio = np.array(new) / np.array(old)
    print(f"largest difference {diff:.1e} of a disk's area; ns per lens: textbook "
          f"{np.median(old) / n * 1e9:.0f}, granavg {np.median(new) / n * 1e9:.0f}; "
          f"granavg/textbook {np.median(ratio):.2f} ({ratio.min():.2f} - {ratio.max():.2f})")


if __name__ == "__main__":
    main()
