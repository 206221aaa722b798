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
array :attr:`Kernel.packed`) serves every kernel, compiled ahead of time.
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
    width_is : str
        What its width w is, in words ("the support radius").
    """

    name: str
    support: float
    pieces: tuple
    norms: dict
    smooth_edge: bool
    edge_order: int
    gauss: tuple = (0.0, 0.0)
    help: str = ""
    width_is: str = ""
    packed: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        degree = max(len(c) for _, c in self.pieces)
        rows = [[start, *coef, *[0.0] * (degree - len(coef))] for start, coef in self.pieces]
        packed = np.array([len(rows), degree + 1, *self.gauss,
                           *np.ravel(rows)], float)
        object.__setattr__(self, "packed", packed)

    def profile(self, q):
        """g at q in [0, 1] from the declared pieces (numpy; the compiled kernels use
        :attr:`packed`)."""
        q = np.asarray(q, float)
        starts = np.array([s for s, _ in self.pieces])
        piece = np.clip(np.searchsorted(starts, q, side="right") - 1, 0, len(starts) - 1)
        g = np.zeros_like(q)
        for k, (_, coef) in enumerate(self.pieces):
            g = np.where(piece == k, np.polynomial.polynomial.polyval(q, coef), g)
        a, b = self.gauss
        return g + a * np.exp(-b * q * q)

    def cutoff(self, width: float) -> float:
        """The support radius c of width w."""
        return self.support * width

    def g(self, q: float) -> float:
        """The profile at q (numpy-free, for tests and checks)."""
        from granavg.engine.smoothing._kernels import profile
        return profile(self.packed, min(q, 1.0))[0] if q < 1.0 else 0.0

    def value(self, r, width: float, dim: int):
        """phi_D(r) (numpy, for tests and checks)."""
        c = self.cutoff(width)
        q = np.asarray(r, float) / c
        g = np.array([self.g(x) for x in np.ravel(q)]).reshape(q.shape)
        return self.norms[dim] / c ** dim * g


#: Quadrature points per piece of the contract's norm check (Gauss-Legendre: exact for
#: the pieces' polynomials, 1e-15 for a Gaussian on the support).
_NODES = np.polynomial.legendre.leggauss(64)


def contract(k: Kernel) -> None:
    """What a kernel must be for granavg's sums to hold (checked when it registers;
    ``ValueError`` with the reason): pieces that start at q = 0 and increase; a profile
    flat at q = 0 (g'(0) = 0: the rings' tabulated circle moments are accurate only
    then); zero at its edge where it declares a smooth edge; norms that make it
    integrate to one in 1, 2 and 3 dimensions (to 1e-9); what it and its width are, in
    words."""
    starts = [s for s, _ in k.pieces]
    if starts[0] != 0.0 or any(b <= a for a, b in zip(starts, starts[1:])) or starts[-1] >= 1:
        raise ValueError(f"its pieces must start at q = 0 and increase within [0, 1) "
                         f"(starts {starts})")
    coef = k.pieces[0][1]
    if len(coef) > 1 and coef[1] != 0.0:
        raise ValueError(f"g'(0) = {coef[1]:g}: its profile must be flat at q = 0 (the "
                         "rings' circle moments need it)")
    edge = float(k.profile(1.0 - 1e-15))
    if k.smooth_edge and abs(edge) > 1e-12 * abs(float(k.profile(0.0))):
        raise ValueError(f"g(1) = {edge:g}: a kernel with a smooth edge is zero there")
    x, w = _NODES
    bounds = [*starts, 1.0]
    for dim, surface in ((1, lambda q: 2.0 + 0 * q), (2, lambda q: 2 * np.pi * q),
                         (3, lambda q: 4 * np.pi * q * q)):
        total = 0.0
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            q = lo + 0.5 * (hi - lo) * (x + 1)
            total += 0.5 * (hi - lo) * np.sum(w * k.profile(q) * surface(q))
        if abs(k.norms[dim] * total - 1.0) > 1e-9:
            raise ValueError(f"norms[{dim}] = {k.norms[dim]!r} makes it integrate to "
                             f"{k.norms[dim] * total!r}, not 1")
    if not k.help or not k.width_is:
        raise ValueError("it needs a help text and a width_is (what it and its width are, "
                         "in words)")
