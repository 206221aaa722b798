"""Lucy's polynomial in time, g = (1 + 3q)(1 - q)^3 on the support |s| < w: smooth to
its second derivative at the cutoff."""

import numpy as np

from granavg.engine.timing.base import TimeKernel


def _g(q):
    q = np.asarray(q, float)
    return (1.0 + 3.0 * q) * (1.0 - q) ** 3


def _dg(q):
    q = np.asarray(q, float)
    return -12.0 * q * (1.0 - q) ** 2


TIME_KERNEL = TimeKernel("lucy", "Lucy's polynomial (1 + 3q)(1 - q)^3, q = |t - t_f| / w",
                         "the support's half-length", 1.0, _g, _dg)
