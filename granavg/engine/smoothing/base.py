"""What a smoothing kernel of coarse graining declares (:class:`Kernel`), and its
normalised value and derivative at a distance.

A kernel is a radial profile g(q) on the support q = r / c in [0, 1], c = ``support``
times the width w, zero beyond. In D dimensions its normalised form is

    phi_D(r) = N_D / c^D g(r / c),   integral of phi_D over R^D = 1,

with N_D the kernel's ``norms[D]`` (exact, in closed form). The 1D profile is what slabs
smooth with across their planes; 2D and 3D the distance in space, at points or averaged
around the circles of rings and shells. The width w is in the frames' length unit.

The profile is declared as data - polynomial pieces in q plus, optionally, a Gaussian
exp(-b q^2) - so that one set of compiled kernels (:func:`profile`, taking the packed
array :attr:`Kernel.packed`) serves every kernel, and compiles once into numba's cache.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Kernel:
    """A smoothing kernel.

    Attributes
    ----------
    name : str
        What ``kernel`` calls it.
    support : float
        Its support radius over the width: c = support w.
    pieces : tuple of (float, tuple of float)
        The profile's polynomial pieces: (q where the piece starts, coefficients of
        1, q, q^2, ...), the first starting at 0.
    gauss : tuple of (float, float)
        (a, b): a exp(-b q^2) added to the pieces ((0, 0): none).
    norms : dict of int -> float
        N_D for D = 1, 2, 3.
    smooth_edge : bool
        Whether it is continuous at its support's edge, so that its derivative is the
        derivative of the coarse-grained fields (gradients, divergences): a kernel with a
        step there would need a delta term on the edge.
    edge_order : int
        The order of its zero at the support's edge (g ~ (1 - q)^n): a circle node's
        weight then goes like a power n + 1/2 of the distance to where the support
        begins, which decides how near a segment's end such a kink may lie
        (:data:`granavg.engine.smoothing.circles.MARGINS`).
    help : str
        What it is, in words.
    """

    name: str
    support: float
    pieces: tuple
    norms: dict
    smooth_edge: bool
    edge_order: int
    gauss: tuple = (0.0, 0.0)
    help: str = ""
    packed: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        degree = max(len(c) for _, c in self.pieces)
        rows = [[start, *coef, *[0.0] * (degree - len(coef))] for start, coef in self.pieces]
        packed = np.array([len(rows), degree + 1, *self.gauss,
                           *np.ravel(rows)], float)
        object.__setattr__(self, "packed", packed)

    def cutoff(self, width: float) -> float:
        """The support radius c of width w."""
        return self.support * width

    def g(self, q: float) -> float:
        """The profile at q (numpy-free, for tests and checks)."""
        from granavg.engine.smoothing.points import profile    # numba's: on demand
        return profile(self.packed, min(q, 1.0))[0] if q < 1.0 else 0.0

    def value(self, r, width: float, dim: int):
        """phi_D(r) (numpy, for tests and checks)."""
        c = self.cutoff(width)
        q = np.asarray(r, float) / c
        g = np.array([self.g(x) for x in np.ravel(q)]).reshape(q.shape)
        return self.norms[dim] / c ** dim * g
