"""A Gaussian of standard deviation w, cut at 3 w and shifted to zero there, so that it
is continuous at the edge of its support: g(q) = exp(-(3q)^2 / 2) - exp(-9/2) on
c = 3 w. Its norms are exact (erf)."""

import math

from granavg.engine.smoothing.base import Kernel

_CUT = math.exp(-4.5)


def _norms():
    """N_D = c^D / integral of g over the ball of radius c = 3 (w = 1)."""
    erf = math.erf(3.0 / math.sqrt(2.0))
    one = math.sqrt(2.0 * math.pi) * erf - 2.0 * 3.0 * _CUT
    two = 2.0 * math.pi * (1.0 - _CUT) - math.pi * 9.0 * _CUT
    three = 4.0 * math.pi * (math.sqrt(math.pi / 2.0) * erf - 3.0 * _CUT) \
        - 4.0 / 3.0 * math.pi * 27.0 * _CUT
    return {1: 3.0 / one, 2: 9.0 / two, 3: 27.0 / three}


KERNEL = Kernel("gauss", 3.0, ((0.0, (-_CUT,)),), _norms(), True, 1, gauss=(1.0, 4.5),
                help="Gaussian of standard deviation w, cut and shifted to zero at 3 w",
                width_is="the standard deviation")
