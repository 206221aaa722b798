"""Slabs across x, y or z: Cartesian slabs of spheres in 3D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells import sectors
from granavg.engine.cells.base import (BINS, EDGES, RANGE, SLABS, Cells, Imaged, Option, Space,
                                       Spheres, cartesian_basis, check_range, checked_edges, cuts,
                                       periods_of, positive, spans_of)
from granavg.engine.cells.slabs import AcrossAxis
from granavg.engine.sphere_weights import layer_weights
from granavg.errors import ParameterError, UserError


#: 3D slabs' cross-section.
AREA = Option("area", "3D slabs: their cross-section (default the box's)")


@dataclass(frozen=True)
class Slabs3D(Spheres, Imaged, AcrossAxis, Cells):
    """Slabs [u_k, u_k+1) across ``axis`` (x, y or z) with cross-section ``area`` (the
    slabs are taken to span the packing in the other two directions); volumes area x
    (u_k+1 - u_k). Exact weights (spherical caps). Cartesian basis.

    ``span`` = (lo, hi), the slabs' extent along their first other axis (x for slabs
    across y or z, y across x), lets them split into strips along it: the spatial
    replicas of the errors (a packing's frozen structure). Without it the errors come
    from time alone."""

    edges: np.ndarray
    axis: str = "z"
    area: float = 1.0
    periods: tuple | None = None
    span: tuple | None = None

    kind = "slabs3d"
    title = "3D slabs"
    axes = ("x", "y", "z")
    selector = "slabs"
    option_specs = (SLABS, BINS, EDGES, RANGE, AREA)

    @classmethod
    def from_options(cls, space: Space, *, slabs=None, bins=None, edges=None, range=None,
                     area=None) -> "Slabs3D":
        """Slabs across ``slabs``: ``bins`` over ``range`` (default the box) or
        ``edges``, of cross-section ``area`` (default the box's: of a tilted box its
        brick's, :class:`~granavg.engine.cells.base.Shear`)."""
        if slabs not in ("x", "y", "z"):
            raise ParameterError("slabs", f"{{param}} {slabs}: give x, y or z")
        check_range("range", range)
        lo_hi = tuple(range) if range else space.span(slabs)
        cells = cuts(bins, edges, lo_hi)
        if area is None:
            others = [space.span(a) for a in "xyz" if a != slabs]
            area = (others[0][1] - others[0][0]) * (others[1][1] - others[1][0])
        positive("area", area)
        given = None if range is None and edges is None else (cells[0], cells[-1])
        periods = tuple(space.period(a, given, "range" if edges is None else "edges")
                        if a == slabs else None for a in "xyz")
        span = tuple(space.span(_along(slabs)))
        return cls(cells, slabs, float(area), periods if any(periods) else None, span)

    @classmethod
    def restore(cls, d: dict) -> "Slabs3D":
        return cls(np.asarray(d["edges"], float), d["axis"], float(d["area"]),
                   periods_of(d.get("periods")), tuple(d["span"]) if d.get("span") else None)

    @property
    def symmetry(self):
        """The direction of the strips (:attr:`span`), or None without one."""
        return None if self.span is None else _along(self.axis)

    def __post_init__(self):
        object.__setattr__(self, "edges", checked_edges(self.edges, "slab edges"))
        if self.axis not in ("x", "y", "z"):
            raise UserError(f"slabs across {self.axis!r}: give x, y or z")
        if not (np.isfinite(self.area) and self.area > 0):
            raise UserError(f"slab cross-section {self.area}: must be a finite number > 0 "
                            "(length^2)")

    @property
    def volume(self) -> np.ndarray:
        return self.area * np.diff(self.edges)

    def weights(self, pos, a, images=None):
        k = "xyz".index(self.axis)
        return self._imaged(lambda p, r: layer_weights(p[k], r, self.edges), pos, a, images)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 3)

    def sector_shares(self, pos, a, k):
        return sectors.along_line(pos["xyz".index(_along(self.axis))], a, self.span, k, 3)

    def describe(self) -> dict:
        out = {"kind": self.kind, "edges": list(self.edges), "axis": self.axis,
               "area": self.area, "periods": spans_of(self.periods)}
        return out if self.span is None else {**out, "span": [float(v) for v in self.span]}


def _along(axis: str) -> str:
    """The axis of the strips of slabs across ``axis``."""
    return "y" if axis == "x" else "x"



CELLS = Slabs3D
