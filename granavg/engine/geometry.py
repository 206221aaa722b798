"""Averaging cells: rings (the Couette default), Cartesian slabs and a rectangular grid
of disks in 2D.

Each geometry object (freud's ``Box`` in spirit) knows its dimension, its cells'
volumes, the exact volume weights of particles in them (:mod:`granavg.engine.weights`),
the particles' own volumes, the basis in which vectors and tensors are expressed (polar
about the centre for rings, Cartesian for slabs and grids), the names of its axes (and
with them the channels, :mod:`granavg.engine.channels`) and the coordinate columns of a
profile table. In 2D volumes are h x area: disks of height ``h``. The 3D cells are in
:mod:`granavg.engine.cells3d`. Lengths are in the frames' units (m for granavg's own
runs).

Positions are handed over as a tuple of coordinate arrays, ``(x, y)`` in 2D.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.channels import Layout
from granavg.engine.weights import grid_weights, ring_weights, strip_weights
from granavg.errors import ParameterError, UserError


def with_images(pos, a, periods):
    """The spheres and, along each axis with a period (the cells spanning a periodic box),
    the images of those that reach across its ends, so that their volume beyond one end
    lands in the cells at the other.

    Parameters
    ----------
    pos : tuple of 3 ndarray, shape (P,)
    a : ndarray, shape (P,)
    periods : tuple of 3 (lo, hi) or None
        The periodic span along each axis.

    Returns
    -------
    pos, a, index : the extended arrays and, for each entry, the sphere it is of.
    """
    index = np.arange(len(a))
    pos = [np.asarray(u, float) for u in pos]
    for k, span in enumerate(periods):
        if span is None:
            continue
        lo, hi = span
        low, high = pos[k] - a < lo, pos[k] + a > hi
        if not (low.any() or high.any()):
            continue
        extra = np.concatenate([np.flatnonzero(low), np.flatnonzero(high)])
        shift = np.concatenate([np.full(low.sum(), hi - lo), np.full(high.sum(), lo - hi)])
        pos = [np.concatenate([u, u[extra] + (shift if j == k else 0.0)])
               for j, u in enumerate(pos)]
        a = np.concatenate([a, a[extra]])
        index = np.concatenate([index, index[extra]])
    return tuple(pos), a, index


class Imaged:
    """Cells that may span a periodic box: ``periods``, per axis, the span over which the
    packing is periodic (the cells then take the particles' images across its ends,
    :func:`with_images`), or None."""

    def _imaged(self, weigh, pos, a):
        periods = getattr(self, "periods", None)
        if not periods or all(p is None for p in periods):
            return weigh(pos, a)
        pos, a, index = with_images(pos, a, periods)
        particle, cell, w = weigh(pos, a)
        return index[particle], cell, w


def _spans(periods):
    """The periods for the sidecar (lists, None where not periodic)."""
    return None if periods is None else [None if p is None else list(p) for p in periods]


def _periods(periods):
    """Periods as tuples of floats (None where not periodic), or None."""
    return None if periods is None else tuple(None if p is None else
                                              tuple(float(v) for v in p) for p in periods)


class Disks(Imaged):
    """What the 2D cells share: disks of height ``h`` (volume pi h a^2, Eq. 7's factor
    V^p / a^2 = pi h), positions ``(x, y)``; ``periods`` as :class:`Imaged`."""

    dim = 2
    position_names = ("x", "y")

    @property
    def layout(self) -> Layout:
        return _layout(self.axes)

    def particle_volume(self, a):
        """V^p = pi h a^2 of each disk."""
        return np.pi * self.h * a * a

    def def_factor(self, a):
        """Eq. 7's pi h = V^p / a^2, one per disk."""
        return np.full(len(a), np.pi * self.h)


_LAYOUTS = {}


def _layout(axes) -> Layout:
    """One Layout per set of axes (they are immutable)."""
    if axes not in _LAYOUTS:
        _LAYOUTS[axes] = Layout(axes)
    return _LAYOUTS[axes]


def cartesian_basis(n, dim):
    """The Cartesian basis at n points, shape (n, dim, dim)."""
    return np.broadcast_to(np.eye(dim), (n, dim, dim))

def _edges(values, what) -> np.ndarray:
    e = np.asarray(values, dtype=float)
    if e.ndim != 1 or len(e) < 2 or not np.all(np.isfinite(e)) or not np.all(np.diff(e) > 0):
        shown = " ".join(f"{v:g}" for v in np.ravel(e))
        raise UserError(f"{what} must be finite and increasing, at least two (got {shown})")
    return e


@dataclass(frozen=True)
class Rings(Disks):
    """Rings [r_lo, r_hi) about ``center`` (m) of height h: volumes pi h (r_hi^2 - r_lo^2).

    Vectors and tensors are in each particle's polar basis (e_r, e_phi) about the centre.
    """

    edges: np.ndarray
    h: float
    center: tuple = (0.0, 0.0)

    kind = "rings"
    axes = ("r", "phi")
    #: The symmetry direction along which cells split into sectors
    #: (:mod:`granavg.engine.replicas`), and whether its sectors close on themselves.
    symmetry, periodic, across = "phi", True, "r"

    @classmethod
    def count(cls, n: int, r_inner: float, r_outer: float, h: float,
              center=(0.0, 0.0)) -> "Rings":
        """``n`` equal-width rings between r_inner and r_outer (m)."""
        if n < 1:
            raise ParameterError("bins", f"{{param}} {n}: need at least one ring")
        return cls(np.linspace(r_inner, r_outer, n + 1), h, tuple(center))

    def __post_init__(self):
        e = _edges(self.edges, "ring edges")
        if e[0] < 0:
            raise UserError("ring edges must be >= 0 and increasing (got "
                            f"{' '.join(f'{v:g}' for v in e)})")
        object.__setattr__(self, "edges", e)
        object.__setattr__(self, "center", tuple(float(c) for c in self.center))

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    @property
    def volume(self) -> np.ndarray:
        return np.pi * self.h * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)

    @property
    def centre(self) -> np.ndarray:
        """Mid radius of each ring, m."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    def weights(self, pos, a):
        """(particle, ring, fraction of the disk's area in it); exact lens areas."""
        x, y = pos
        return ring_weights(np.hypot(x - self.center[0], y - self.center[1]), a, self.edges)

    def basis(self, pos):
        """e_r and e_phi (rows) at each point, shape (P, 2, 2)."""
        return polar_basis(pos[0] - self.center[0], pos[1] - self.center[1])

    def coordinates(self) -> dict:
        return {"r_lo": self.edges[:-1], "r_hi": self.edges[1:], "r": self.centre}

    def cell_of(self, pos, slack=0.0):
        """The ring of each point; points less than ``slack`` beyond the first or last
        edge (a wall's contact points, a disk radius from the disk's centre) go to the
        edge rings (:func:`_cell_of`)."""
        return _cell_of(np.hypot(pos[0] - self.center[0], pos[1] - self.center[1]),
                        self.edges, slack)

    def describe(self) -> dict:
        return {"kind": "rings", "edges": list(self.edges), "h": self.h,
                "center": list(self.center)}


@dataclass(frozen=True)
class Slabs(Disks):
    """Strips [u_k, u_k+1) across ``axis`` (``"x"`` or ``"y"``), each ``length`` m long
    in the other direction; volumes h (u_k+1 - u_k) length. A disk's weight is the
    fraction of its area between the strip's edges (the strips are taken to span the
    whole packing along the other direction). Cartesian basis.

    ``span`` = (lo, hi), the slabs' extent along the other direction (hi - lo is
    normally ``length``), lets them split into segments along it: the spatial replicas of
    :mod:`granavg.engine.replicas`. Without it the errors come from time alone."""

    edges: np.ndarray
    h: float
    axis: str = "x"
    length: float = 1.0
    span: tuple | None = None
    periods: tuple | None = None

    kind = "slabs"
    axes = ("x", "y")
    periodic = False

    @property
    def across(self):
        """The direction across the slabs."""
        return self.axis

    @property
    def symmetry(self):
        """The direction along the slabs (segments), or None without a ``span``."""
        return None if self.span is None else ("y" if self.axis == "x" else "x")

    def __post_init__(self):
        object.__setattr__(self, "edges", _edges(self.edges, "slab edges"))
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
            raise UserError(f"slab length {self.length}: must be a finite number > 0 (m)")

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    @property
    def volume(self) -> np.ndarray:
        return self.h * np.diff(self.edges) * self.length

    def weights(self, pos, a):
        k = "xy".index(self.axis)
        return self._imaged(lambda p, r: strip_weights(p[k], r, self.edges), pos, a)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 2)

    def cell_of(self, pos, slack=0.0):
        """The slab of each point (edge slabs take points up to ``slack`` beyond)."""
        return _cell_of(pos["xy".index(self.axis)], self.edges, slack)

    def coordinates(self) -> dict:
        return edge_coordinates({self.axis: (self.edges, np.arange(len(self.edges) - 1))})

    def describe(self) -> dict:
        out = {"kind": "slabs", "edges": list(self.edges), "h": self.h,
               "axis": self.axis, "length": self.length}
        out = out if self.span is None else {**out, "span": list(self.span)}
        return out if self.periods is None else {**out, "periods": _spans(self.periods)}


@dataclass(frozen=True)
class Grid(Disks):
    """Rectangles [x_i, x_i+1) x [y_j, y_j+1); cell k = i n_y + j; volumes h dx dy.
    Exact weights (disk-rectangle areas in closed form); Cartesian basis."""

    xedges: np.ndarray
    yedges: np.ndarray
    h: float
    periods: tuple | None = None

    kind = "grid"
    axes = ("x", "y")
    symmetry, periodic = None, False

    def __post_init__(self):
        object.__setattr__(self, "xedges", _edges(self.xedges, "grid x edges"))
        object.__setattr__(self, "yedges", _edges(self.yedges, "grid y edges"))

    @property
    def n(self) -> int:
        return (len(self.xedges) - 1) * (len(self.yedges) - 1)

    @property
    def volume(self) -> np.ndarray:
        return self.h * np.outer(np.diff(self.xedges), np.diff(self.yedges)).ravel()

    def weights(self, pos, a):
        return self._imaged(lambda p, r: grid_weights(p[0], p[1], r, self.xedges,
                                                      self.yedges), pos, a)

    basis = Slabs.basis

    def cell_of(self, pos, slack=0.0):
        """The cell k = i n_y + j of each point (edge cells take points up to ``slack``
        beyond)."""
        i, j = _cell_of(pos[0], self.xedges, slack), _cell_of(pos[1], self.yedges, slack)
        return np.where((i >= 0) & (j >= 0), i * (len(self.yedges) - 1) + j, -1)

    def coordinates(self) -> dict:
        nx, ny = len(self.xedges) - 1, len(self.yedges) - 1
        i, j = np.divmod(np.arange(nx * ny), ny)
        return edge_coordinates({"x": (self.xedges, i), "y": (self.yedges, j)})

    def describe(self) -> dict:
        out = {"kind": "grid", "xedges": list(self.xedges), "yedges": list(self.yedges),
               "h": self.h}
        return out if self.periods is None else {**out, "periods": _spans(self.periods)}


def edge_coordinates(cuts: dict) -> dict:
    """Each cell's lower and upper edge along each axis, then its centres: ``cuts`` maps
    an axis name to (its edges, the cells' index along it, shape (n_cells,)); returns
    ``{name_lo, name_hi, ..., name, ...}``, arrays of shape (n_cells,)."""
    out = {}
    for name, (e, m) in cuts.items():
        out[f"{name}_lo"], out[f"{name}_hi"] = e[m], e[m + 1]
    for name, (e, m) in cuts.items():
        out[name] = 0.5 * (e[m] + e[m + 1])
    return out


def _cell_of(u, edges, slack=0.0):
    """Index of the cell [e_k, e_k+1) holding each u; -1 outside. A point at most
    ``slack`` beyond the first or last edge is clamped to that cell: a wall's contact
    points lie on the wall, just beyond the cells of the packing."""
    u = np.asarray(u, float)
    k = np.searchsorted(edges, u, side="right") - 1
    n = len(edges) - 1
    k = np.where((u < edges[0]) & (u >= edges[0] - slack), 0, k)
    k = np.where((u >= edges[-1]) & (u <= edges[-1] + slack), n - 1, k)
    return np.where((k >= 0) & (k < n), k, -1)


def polar_basis(dx, dy):
    """e_r and e_phi (rows) of the points at (dx, dy) from the axis, shape (P, 2, 2)."""
    r = np.hypot(dx, dy)
    E = np.empty((len(r), 2, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        E[:, 0, 0], E[:, 0, 1] = dx / r, dy / r
    E[:, 1, 0], E[:, 1, 1] = -E[:, 0, 1], E[:, 0, 0]
    return E


def from_description(d: dict):
    """The geometry a sidecar describes (``describe()``'s dict, lengths in the sidecar's
    units; older sidecars: rings, and keys with an ``_m`` suffix)."""
    d = {k[:-2] if k.endswith("_m") else k: v for k, v in d.items()}
    kind = d.get("kind", "rings")
    if kind == "rings":
        return Rings(np.asarray(d["edges"], float), float(d["h"]),
                     tuple(d.get("center", (0.0, 0.0))))
    periods = _periods(d.get("periods"))
    if kind == "slabs":
        return Slabs(np.asarray(d["edges"], float), float(d["h"]), d["axis"],
                     float(d["length"]), tuple(d["span"]) if d.get("span") else None,
                     periods)
    if kind == "grid":
        return Grid(np.asarray(d["xedges"], float), np.asarray(d["yedges"], float),
                    float(d["h"]), periods)
    from granavg.engine.cells3d import Boxes, Shells, Slabs3D
    if kind == "slabs3d":
        return Slabs3D(np.asarray(d["edges"], float), d["axis"], float(d["area"]), periods)
    if kind == "boxes":
        return Boxes(*(np.asarray(d[k], float) for k in ("xedges", "yedges", "zedges")),
                     periods)
    if kind == "shells":
        return Shells(np.asarray(d["edges"], float), np.asarray(d["zedges"], float),
                      tuple(d.get("center", (0.0, 0.0))), periods)
    raise UserError(f"unknown geometry kind {kind!r}")
