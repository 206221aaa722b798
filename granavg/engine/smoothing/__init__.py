"""Smoothing kernels of coarse graining, one per module: each module of this package
that defines ``KERNEL`` (a :class:`~granavg.engine.smoothing.base.Kernel`) is one, found
here without being listed anywhere else, or one given to :func:`register` (a plug-in of
your own; docs/extending.md). Each is checked against the kernels' contract when it
registers (:func:`~granavg.engine.smoothing.base.contract`). ``exact``, the cells' own
volume-fraction weights, is no kernel: it is what cells average with when none is
given.

:class:`~granavg.engine.smoothing.smoothed.Smoothed` turns any cells into the nodes of a
smooth field (fields at the cells' centres, with their gradients).
"""

from __future__ import annotations

from granavg.engine.plugins import Registry
from granavg.engine.smoothing.base import Kernel, contract
from granavg.errors import ParameterError

#: The kernels, by name.
KERNELS = Registry(__name__, "KERNEL", lambda k: isinstance(k, Kernel), lambda k: k.name,
                   contract, group="granavg.kernels")
#: The kernel of a scale study when none is named.
DEFAULT = "lucy"
#: What the cells' own weights are called where a kernel could be named.
EXACT = "exact"


def registry() -> dict:
    """Every kernel, by name."""
    return KERNELS.all()


def register(kernel: Kernel) -> Kernel:
    """Add a kernel of your own (checked against the contract); returns it."""
    return KERNELS.register(kernel)


def names(smooth_only: bool = False) -> str:
    """The kernels' names as a message lists them: ``gauss, heaviside or lucy``;
    ``smooth_only``: those continuous at their edge (the gradients' kernels)."""
    found = sorted(n for n, k in registry().items() if k.smooth_edge or not smooth_only)
    return found[0] if len(found) == 1 else f"{', '.join(found[:-1])} or {found[-1]}"


def widths() -> str:
    """What each kernel's width is, for help texts: ``lucy: the support radius, ...``."""
    return ", ".join(f"{k.name}: {k.width_is}" for k in registry().values())


def catalogue() -> str:
    """The kernels in words, for help texts."""
    return ", ".join([f"{EXACT} (each cell's exact average: the particles' volume "
                      "fractions in it)"] + [f"{k.name} ({k.help})" for k in
                                            registry().values()])


def smooth(cells, kernel: str | None, width: float | None):
    """``cells`` as the nodes of ``kernel`` of width ``width`` (the cells themselves for
    no kernel or ``exact``); one-line refusals of a width without a kernel, a kernel
    without a width, or a width that is not a finite number > 0."""
    if kernel in (None, EXACT):
        if width is not None:
            raise ParameterError("width", "{param} is the width of a smoothing kernel: "
                                 f"give {{kernel}} {names()} with it")
        return cells
    if width is None:
        raise ParameterError("width", f"{{kernel}} {kernel} needs {{param}} W, the kernel's "
                             "width in the dumps' length unit (e.g. a particle diameter)")
    from granavg.engine.smoothing.smoothed import Smoothed    # (on demand)
    return Smoothed(cells, get(kernel), float(width))


def get(name: str) -> Kernel:
    """The kernel called ``name`` (one-line refusal of an unknown one)."""
    known = registry()
    if name not in known:
        raise ParameterError("kernel", f"{{param}} {name!r}: choose {EXACT} or "
                             f"{names()}")
    return known[name]
