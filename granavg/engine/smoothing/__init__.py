"""Smoothing kernels of coarse graining, one per module: each module of this package
that defines ``KERNEL`` (a :class:`~granavg.engine.smoothing.base.Kernel`) is one, found
here without being listed anywhere else. ``exact``, the cells' own volume-fraction
weights, is no kernel: it is what cells average with when none is given.

:class:`~granavg.engine.smoothing.smoothed.Smoothed` turns any cells into the nodes of a
smooth field (fields at the cells' centres, with their gradients).
"""

from __future__ import annotations

import importlib
import pkgutil

from granavg.engine.smoothing.base import Kernel
from granavg.errors import ParameterError

_FOUND: dict = {}


def registry() -> dict:
    """Every kernel, by name."""
    if not _FOUND:
        for info in pkgutil.iter_modules(__path__):
            module = importlib.import_module(f"{__name__}.{info.name}")
            kernel = getattr(module, "KERNEL", None)
            if isinstance(kernel, Kernel):
                _FOUND[kernel.name] = kernel
    return dict(_FOUND)


def smooth(cells, kernel: str | None, width: float | None):
    """``cells`` as the nodes of ``kernel`` of width ``width`` (the cells themselves for
    no kernel or ``exact``); one-line refusals of a width without a kernel, a kernel
    without a width, or a width that is not a finite number > 0."""
    if kernel in (None, "exact"):
        if width is not None:
            raise ParameterError("width", "{param} is the width of a smoothing kernel: "
                                 "give {kernel} lucy, gauss or heaviside with it")
        return cells
    if width is None:
        raise ParameterError("width", f"{{kernel}} {kernel} needs {{param}} W, the kernel's "
                             "width in the dumps' length unit (e.g. a particle diameter)")
    from granavg.engine.smoothing.smoothed import Smoothed    # numba's kernels: on demand
    return Smoothed(cells, get(kernel), float(width))


def get(name: str) -> Kernel:
    """The kernel called ``name`` (one-line refusal of an unknown one)."""
    known = registry()
    if name not in known:
        raise ParameterError("kernel", f"{{param}} {name!r}: choose exact or one of "
                             f"{', '.join(sorted(known))}")
    return known[name]
