"""Strips across x or y: Cartesian slabs of disks in 2D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells import sectors
from granavg.engine.cells.base import (BINS, EDGES, RANGE, SLABS, THICKNESS, Cells, Disks, Imaged,
                                       Option, Space, cartesian_basis, cell_index, check_range,
                                       checked_edges, cuts, disk_height, edge_coordinates, faces,
                                       periods_of, positive, spans_of, without_suffix)
from granavg.engine.weights import strip_weights
from granavg.errors import ParameterError, UserError


class AcrossAxis:
    """What slabs across an ``axis`` share, of disks (2D) or spheres (3D): the cells
    along the axis by their ``edges``, the balance of forces across them (periodic
    where they wrap)."""

    @property
    def across(self):
        """The direction across the slabs."""
        return self.axis

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    def cell_of(self, pos, slack=0.0):
        """The slab of each point (edge slabs take points up to ``slack`` beyond)."""
        return cell_index(pos["xyz".index(self.axis)], self.edges, slack)

    def coordinates(self) -> dict:
        return edge_coordinates({self.axis: (self.edges, np.arange(len(self.edges) - 1))})

    def grid(self) -> tuple:
        return (self.axis,), (self.n,), (self.edges,)

    def residuals(self, T, f, closed):
        """dT_iu/du + f_i for every component i, times the slab's width."""
        k = self.axis
        wrap = self.wraps(k)
        return tuple(np.diff(faces(T[c + k], closed, wrap)) + np.diff(self.edges) * f[c]
                     for c in self.axes)

    def position(self):
        return self.axis, self.coordinates()[self.axis]

    def nodes(self):
        """The slabs' mid planes, and the slabs' extent along them (length in 2D, area
        in 3D)."""
        return "planes", "xyz".index(self.axis), 0.5 * (self.edges[1:] + self.edges[:-1]), \
            self.volume / (np.diff(self.edges) * (self.h if self.dim == 2 else 1.0))


#: 2D slabs' length along them.
LENGTH = Option("length", "2D slabs: their length along the other axis (default the box's)")


@dataclass(frozen=True)
class Slabs(Disks, Imaged, AcrossAxis, Cells):
    """Strips [u_k, u_k+1) across ``axis`` (``"x"`` or ``"y"``), each ``length`` long
    in the other direction; volumes h (u_k+1 - u_k) length. A disk's weight is the
    fraction of its area between the strip's edges (the strips are taken to span the
    whole packing along the other direction). Cartesian basis.

    ``span`` = (lo, hi), the slabs' extent along the other direction (hi - lo is
    normally ``length``), lets them split into segments along it: the spatial replicas
    of the errors. Without it the errors come from time alone. ``periods``: the strips
    span a periodic box across them (:class:`~granavg.engine.cells.base.Imaged`)."""

    edges: np.ndarray
    h: float
    axis: str = "x"
    length: float = 1.0
    span: tuple | None = None
    periods: tuple | None = None

    kind = "slabs"
    title = "slabs"
    axes = ("x", "y")
    selector = "slabs"
    option_specs = (THICKNESS, SLABS, BINS, EDGES, RANGE, LENGTH)
    sectors_close = False

    @classmethod
    def from_options(cls, space: Space, *, thickness=None, slabs=None, bins=None,
                     edges=None, range=None, length=None) -> "Slabs":
        """Slabs across ``slabs`` (x or y): ``bins`` over ``range`` (default the box) or
        ``edges``, ``length`` long (default the box's other side, from its lower bound;
        their segments the errors' spatial replicas)."""
        h = disk_height(space, thickness)
        if slabs not in ("x", "y"):
            raise ParameterError("slabs", f"{{param}} {slabs}: a 2D dump has slabs across "
                                 "x or y")
        check_range("range", range)
        k = "xy".index(slabs)
        bx = space.box()
        lo_hi = range or bx[k]
        other = bx[1 - k]
        if length is not None:
            positive("length", length)
        length = length or (other[1] - other[0])
        span = (other[0], other[0] + length)
        cells = cuts(bins, edges, lo_hi)
        given = None if range is None and edges is None else (cells[0], cells[-1])
        period = space.period(slabs, given, "range" if edges is None else "edges")
        periods = None if period is None else tuple(period if j == k else None
                                                     for j in (0, 1))
        return cls(cells, h, slabs, length, span, periods)

    @classmethod
    def restore(cls, d: dict) -> "Slabs":
        d = without_suffix(d)
        return cls(np.asarray(d["edges"], float), float(d["h"]), d["axis"],
                   float(d["length"]), tuple(d["span"]) if d.get("span") else None,
                   periods_of(d.get("periods")))

    @property
    def symmetry(self):
        """The direction along the slabs (segments), or None without a ``span``."""
        return None if self.span is None else ("y" if self.axis == "x" else "x")

    def __post_init__(self):
        object.__setattr__(self, "edges", checked_edges(self.edges, "slab edges"))
        if self.span is not None:
            if len(self.span) != 2:
                raise UserError(f"slab span {self.span}: give two numbers, lo and hi")
            lo, hi = (float(v) for v in self.span)
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise UserError(f"slab span {self.span}: give finite lo < hi")
            object.__setattr__(self, "span", (lo, hi))
        if self.axis not in ("x", "y"):
            raise UserError(f"slabs across {self.axis!r}: give x or y")
        if not (np.isfinite(self.length) and self.length > 0):
            raise UserError(f"slab length {self.length}: must be a finite number > 0")

    @property
    def volume(self) -> np.ndarray:
        return self.h * np.diff(self.edges) * self.length

    def weights(self, pos, a, images=None):
        k = "xy".index(self.axis)
        return self._imaged(lambda p, r: strip_weights(p[k], r, self.edges), pos, a, images)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 2)

    def sector_shares(self, pos, a, k):
        along = pos[1] if self.axis == "x" else pos[0]
        return sectors.along_line(along, a, self.span, k, self.dim)

    def describe(self) -> dict:
        out = {"kind": self.kind, "edges": list(self.edges), "h": self.h,
               "axis": self.axis, "length": self.length}
        out = out if self.span is None else {**out, "span": list(self.span)}
        return out if self.periods is None else {**out, "periods": spans_of(self.periods)}



CELLS = Slabs
