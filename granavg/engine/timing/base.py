"""Time kernels: the weight a frame at time t_f gets in a field at time t,
psi(t - t_f), and its derivative, which gives the fields' time derivatives
(:mod:`granavg.engine.timing.axes`).

A kernel is a profile g(q) on 0 <= q = |s| / c <= 1, c the cutoff (a multiple of the
width), normalised here so that the integral of psi over s is 1:
psi(s) = g(|s| / c) / (c N), N = the integral of g(|q|) over -1 <= q <= 1.
Its contract: g flat at q = 0 and zero with a zero slope at q = 1, so that psi and its
derivative are continuous everywhere. Then d/dt of a field smoothed in time is the
field smoothed with psi' (no term from the cutoff), and the balance laws that hold at
every instant hold for the smoothed fields, up to the time quadrature of the frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class TimeKernel:
    """One time kernel.

    Attributes
    ----------
    name : str
        Its name (``--time-kernel``).
    help : str
        What it is, in words.
    width_is : str
        What its width is (``the standard deviation``), for help texts.
    reach : float
        The cutoff over the width: c = reach * width.
    g, dg : callable
        The profile g(q) and its derivative dg/dq on 0 <= q <= 1 (arrays in, arrays out).
    """

    name: str
    help: str
    width_is: str
    reach: float
    g: Callable
    dg: Callable
    norm: float = field(init=False)

    def __post_init__(self):
        q, w = np.polynomial.legendre.leggauss(96)       # on [0, 1]: g is smooth there
        half = 0.5 * float(np.dot(w, self.g(0.5 * (q + 1.0))))
        object.__setattr__(self, "norm", 2.0 * half)

    def cutoff(self, width: float) -> float:
        """The support's half-length for a width."""
        return self.reach * float(width)

    def weights(self, s, width: float):
        """psi(s) and dpsi/ds for lags ``s`` (t - t_f), zero beyond the cutoff.

        Returns
        -------
        psi, dpsi : ndarray, shape of ``s``
        """
        s = np.asarray(s, float)
        c = self.cutoff(width)
        q = np.abs(s) / c
        inside = q < 1.0
        qi = np.where(inside, q, 0.0)
        psi = np.where(inside, self.g(qi), 0.0) / (c * self.norm)
        dpsi = np.where(inside, self.dg(qi), 0.0) * np.sign(s) / (c * c * self.norm)
        return psi, dpsi


def contract(k: TimeKernel) -> None:
    """What a time kernel must keep (``ValueError`` with the reason): a name that is an
    identifier, a help text and what its width is, a reach > 0, g > 0 inside, g'(0) = 0,
    g(1) = g'(1) = 0 (continuous psi and psi'), and dg the derivative of g."""
    if not k.name.isidentifier():
        raise ValueError(f"its name {k.name!r} must be an identifier")
    if not (k.help and k.width_is):
        raise ValueError("it needs a help text and what its width is")
    if not k.reach > 0:
        raise ValueError("its reach (cutoff over width) must be > 0")
    q = np.linspace(0.0, 1.0, 2001)
    g, dg = k.g(q), k.dg(q)
    if not np.all(g[:-1] > 0):
        raise ValueError("g must be > 0 inside its support")
    scale = float(np.max(np.abs(dg))) or 1.0
    if abs(dg[0]) > 1e-9 * scale:
        raise ValueError(f"g'(0) = {dg[0]:.3g}: it must be flat at q = 0")
    if abs(g[-1]) > 1e-9 * g[0] or abs(dg[-1]) > 1e-9 * scale:
        raise ValueError(f"g(1) = {g[-1]:.3g}, g'(1) = {dg[-1]:.3g}: both must be 0, so "
                         "that psi and its derivative are continuous at the cutoff")
    numeric = np.gradient(g, q)
    if np.max(np.abs(numeric[1:-1] - dg[1:-1])) > 1e-3 * scale:
        raise ValueError("dg is not the derivative of g")
