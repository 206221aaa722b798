"""Averaging cells, one geometry per module: each module of this package that defines
``CELLS`` (a :class:`~granavg.engine.cells.base.Cells` subclass) is one, found here
without being listed anywhere else (docs/extending.md).

:func:`registry` lists them by kind; :func:`restore` rebuilds cells from a sidecar's
description; :func:`from_options` chooses and builds the cells that options describe.
"""

from __future__ import annotations

from granavg.engine.cells.base import Cells, Space
from granavg.engine.plugins import Registry
from granavg.errors import ParameterError, UserError

#: The kinds of cells, by kind.
CELLS = Registry(__name__, "CELLS", lambda c: isinstance(c, type) and issubclass(c, Cells),
                 lambda c: c.kind, group="granavg.cells")


def registry() -> dict:
    """Every kind of cells, by kind (modules of this package that define ``CELLS``, and
    those given to :func:`register`)."""
    return CELLS.all()


def register(cells: type) -> type:
    """Add a kind of cells of your own (a :class:`Cells` subclass); returns it."""
    return CELLS.register(cells)


def option_specs() -> dict:
    """Every option that builds cells (:class:`~granavg.engine.cells.base.Option`), by
    name, as the kinds of cells declare them; one name, one declaration."""
    out = {}
    for cls in registry().values():
        for spec in cls.option_specs:
            if out.setdefault(spec.name, spec) != spec:
                raise ValueError(f"cells option {spec.name!r} is declared twice, "
                                 f"differently ({cls.kind})")
    return out


def restore(description: dict) -> Cells:
    """The cells a sidecar describes (``describe()``'s dict; older sidecars: rings); with
    a ``kernel``, the smoothed nodes of them
    (:class:`~granavg.engine.smoothing.smoothed.Smoothed`)."""
    if "kernel" in description:
        from granavg.engine.smoothing import get
        from granavg.engine.smoothing.smoothed import Smoothed

        inner = {k: v for k, v in description.items() if k not in ("kernel", "width")}
        return Smoothed(restore(inner), get(description["kernel"]),
                        float(description["width"]))
    kind = description.get("kind", "rings")
    known = registry()
    if kind not in known:
        raise UserError(f"unknown kind of cells {kind!r} (granavg knows "
                        f"{', '.join(sorted(known))})")
    return known[kind].restore(description)


#: The sidecar key older granavg wrote a run's cells under (their edges and disk height),
#: still written beside ``geometry`` for readers of that time.
LEGACY_KEY = "rings"


def legacy_description(cells) -> dict:
    """A run's cells as older sidecars described them: ``{LEGACY_KEY: {"edges_m",
    "h_m"}}``."""
    return {LEGACY_KEY: {"edges_m": list(cells.edges), "h_m": cells.h}}


def restore_sidecar(meta: dict) -> Cells:
    """The cells a sidecar describes: its ``geometry``, or an older one's rings."""
    return restore(meta.get("geometry") or meta[LEGACY_KEY])


def from_options(space: Space, **options) -> Cells:
    """The cells of ``space.dim`` that the options choose and describe: the kind whose
    ``selector`` option is given, else the dimension's default; an option the chosen
    cells do not take is refused in one line naming it."""
    given = {k: v for k, v in options.items() if v is not None}
    kinds = [c for c in registry().values() if c.dim == space.dim]
    chosen = [c for c in kinds if c.selector and c.selector in given]
    if len(chosen) > 1:
        first, second = (c.selector for c in chosen[:2])
        raise ParameterError(first, "{param} and {" + second + "} choose different "
                             "cells; give one")
    cls = chosen[0] if chosen else next(c for c in kinds if c.selector is None)
    foreign = sorted(set(given) - cls.options)
    if foreign:
        raise ParameterError(foreign[0], _does_not_apply(foreign[0], cls, space.dim))
    return cls.from_options(space, **given)


def _does_not_apply(name, cls, dim) -> str:
    """The refusal of an option the cells ``cls`` do not take: for which cells it is."""
    takers = [c for c in registry().values() if name in c.options]
    if takers and all(c.dim != dim for c in takers):
        other = takers[0].dim
        return ("{param} is for " + ("3D dumps (spheres); these are 2D (give {dim} 3 if the "
                                     "dump is 3D)" if other == 3 else
                                     "2D disks; the dump is 3D (spheres: volume 4/3 pi a^3)"))
    same = [c.title for c in takers if c.dim == dim]
    return ("{param} does not apply to " + cls.title
            + (f" (it is for {' and '.join(same)})" if same else "") + "; leave it out")
