"""The quadrature rules of the smoothing kernels: Gauss-Legendre on [0, 1], and the maps
that make a piece's singular ends harmless.

A piece of a line integral ends where the integrand stops being smooth: where a node's
support begins or ends along the segment (there the weight goes like a half-integer
power of the distance), or where the segment crosses a ring's circle (a term
e^4 log e). The compiled loops (:mod:`granavg.engine.smoothing._kernels`,
``_quadrature``) map x in [0, 1] to the piece so that the step shrinks
quadratically towards each singular end: a half-integer power becomes a polynomial in
x, e^4 log e becomes x^8 log x, and Gauss-Legendre converges again
(tests/test_smoothing.py holds the results to adaptive quadrature at 1e-10).
"""

from __future__ import annotations

import numpy as np


def gauss_legendre(n: int):
    """Nodes and weights of n-point Gauss-Legendre on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


#: Along the u pieces of the sinh map (points.py, circles.py).
SX, SW = gauss_legendre(12)
#: Along a branch segment's pieces between a circle node's kinks.
LX, LW = gauss_legendre(16)
#: Around a circle, away from the particle.
AX, AW = gauss_legendre(16)
