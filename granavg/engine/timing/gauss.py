"""The Gaussian in time (MercuryCG's TimeSmoothedCG: exp(-s^2 / 2 w^2), cut at 3 w),
shifted so that it ends with zero value and slope at the cutoff:
g = exp(-u^2/2) - exp(-9/2) (1 - (u^2 - 9)/2), u = 3 q. Inside it differs from the plain
Gaussian by at most 6% of its peak, at q = 0; its integral is normalised to 1."""

import numpy as np

from granavg.engine.timing.base import TimeKernel

_C = 3.0
_E = float(np.exp(-0.5 * _C * _C))


def _g(q):
    u = _C * np.asarray(q, float)
    return np.exp(-0.5 * u * u) - _E * (1.0 - 0.5 * (u * u - _C * _C))


def _dg(q):
    u = _C * np.asarray(q, float)
    return _C * u * (_E - np.exp(-0.5 * u * u))


TIME_KERNEL = TimeKernel("gauss", "a Gaussian of standard deviation w, cut at 3 w with "
                         "zero value and slope there", "the standard deviation", _C, _g,
                         _dg)
