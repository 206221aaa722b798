"""Averaging cells for spheres in 3D: slabs across x, y or z, a box grid, and
cylindrical shells (rings about an axis parallel to z, times layers in z).

The same interface as the 2D cells of :mod:`granavg.engine.geometry`: dimension, axes
(and with them the channels), cell volumes, exact volume weights
(:mod:`granavg.engine.sphere_weights`), the particles' volumes 4/3 pi a^3 and Eq. 7's
factor V^p / a^2 = 4/3 pi a, the basis (Cartesian, or e_r, e_phi, e_z about the axis),
the cell of a point, the profile's coordinate columns and a description for the
sidecar. Positions are ``(x, y, z)``. Lengths are in the frames' units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.geometry import (Imaged, _cell_of, _edges, _layout, _spans,
                                     cartesian_basis, edge_coordinates, polar_basis)
from granavg.engine.sphere_weights import box_weights, layer_weights, shell_weights
from granavg.errors import UserError


class Spheres(Imaged):
    """What the 3D cells share: spheres (volume 4/3 pi a^3), positions ``(x, y, z)``;
    ``periods``: per axis, the span over which the packing is periodic (the cells then
    take the spheres' images across its ends, :func:`~granavg.engine.geometry.with_images`),
    or None."""

    dim = 3
    position_names = ("x", "y", "z")
    periodic = False

    @property
    def layout(self):
        return _layout(self.axes)

    def particle_volume(self, a):
        """V^p = 4/3 pi a^3 of each sphere."""
        return 4.0 / 3.0 * np.pi * a * a * a

    def def_factor(self, a):
        """Eq. 7's V^p / a^2 = 4/3 pi a of each sphere."""
        return 4.0 / 3.0 * np.pi * a


@dataclass(frozen=True)
class Slabs3D(Spheres):
    """Slabs [u_k, u_k+1) across ``axis`` (x, y or z) with cross-section ``area`` (the
    slabs are taken to span the packing in the other two directions); volumes area x
    (u_k+1 - u_k). Exact weights (spherical caps). Cartesian basis."""

    edges: np.ndarray
    axis: str = "z"
    area: float = 1.0
    periods: tuple | None = None

    kind = "slabs3d"
    axes = ("x", "y", "z")
    symmetry = None

    def __post_init__(self):
        object.__setattr__(self, "edges", _edges(self.edges, "slab edges"))
        if self.axis not in ("x", "y", "z"):
            raise UserError(f"slabs across {self.axis!r}: give x, y or z")
        if not (np.isfinite(self.area) and self.area > 0):
            raise UserError(f"slab cross-section {self.area}: must be a finite number > 0 "
                            "(length^2)")

    @property
    def across(self):
        return self.axis

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    @property
    def volume(self) -> np.ndarray:
        return self.area * np.diff(self.edges)

    def weights(self, pos, a):
        k = "xyz".index(self.axis)
        return self._imaged(lambda p, r: layer_weights(p[k], r, self.edges), pos, a)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 3)

    def cell_of(self, pos, slack=0.0):
        return _cell_of(pos["xyz".index(self.axis)], self.edges, slack)

    def coordinates(self) -> dict:
        return edge_coordinates({self.axis: (self.edges, np.arange(len(self.edges) - 1))})

    def describe(self) -> dict:
        return {"kind": self.kind, "edges": list(self.edges), "axis": self.axis,
                "area": self.area, "periods": _spans(self.periods)}


@dataclass(frozen=True)
class Boxes(Spheres):
    """Boxes [x_i, x_i+1) x [y_j, y_j+1) x [z_l, z_l+1); cell k = (i n_y + j) n_z + l;
    volumes dx dy dz. Exact weights (closed form). Cartesian basis."""

    xedges: np.ndarray
    yedges: np.ndarray
    zedges: np.ndarray
    periods: tuple | None = None

    kind = "boxes"
    axes = ("x", "y", "z")
    symmetry = None
    across = None

    def __post_init__(self):
        for name in ("xedges", "yedges", "zedges"):
            object.__setattr__(self, name, _edges(getattr(self, name), f"box {name[0]} edges"))

    @property
    def shape(self) -> tuple:
        return (len(self.xedges) - 1, len(self.yedges) - 1, len(self.zedges) - 1)

    @property
    def n(self) -> int:
        return int(np.prod(self.shape))

    @property
    def volume(self) -> np.ndarray:
        dx, dy, dz = (np.diff(e) for e in (self.xedges, self.yedges, self.zedges))
        return (dx[:, None, None] * dy[None, :, None] * dz[None, None, :]).ravel()

    def weights(self, pos, a):
        return self._imaged(lambda p, r: box_weights(*p, r, self.xedges, self.yedges,
                                                     self.zedges), pos, a)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 3)

    def cell_of(self, pos, slack=0.0):
        """The box (i n_y + j) n_z + l of each point (edge boxes take points up to
        ``slack`` beyond)."""
        nx, ny, nz = self.shape
        i, j, k = (_cell_of(u, e, slack) for u, e in zip(pos, (self.xedges, self.yedges,
                                                               self.zedges)))
        return np.where((i >= 0) & (j >= 0) & (k >= 0), (i * ny + j) * nz + k, -1)

    def coordinates(self) -> dict:
        i, j, k = np.unravel_index(np.arange(self.n), self.shape)
        return edge_coordinates({"x": (self.xedges, i), "y": (self.yedges, j),
                                 "z": (self.zedges, k)})

    def describe(self) -> dict:
        return {"kind": self.kind, "xedges": list(self.xedges), "yedges": list(self.yedges),
                "zedges": list(self.zedges), "periods": _spans(self.periods)}


@dataclass(frozen=True)
class Shells(Spheres):
    """Cylindrical shells about the axis through ``center`` (x, y) parallel to z: rings
    [r_i, r_i+1) times layers [z_l, z_l+1); cell k = i n_z + l; volumes
    pi (r_i+1^2 - r_i^2) dz. Exact weights (quadrature of the slices' lens areas,
    converged to 1e-10). Basis e_r, e_phi, e_z at each sphere; sectors along phi."""

    edges: np.ndarray
    zedges: np.ndarray
    center: tuple = (0.0, 0.0)
    periods: tuple | None = None

    kind = "shells"
    axes = ("r", "phi", "z")
    symmetry, periodic, across = "phi", True, "r"

    def __post_init__(self):
        e = _edges(self.edges, "shell radii")
        if e[0] < 0:
            raise UserError("shell radii must be >= 0 and increasing (got "
                            f"{' '.join(f'{v:g}' for v in e)})")
        object.__setattr__(self, "edges", e)
        object.__setattr__(self, "zedges", _edges(self.zedges, "shell layer edges"))
        object.__setattr__(self, "center", tuple(float(c) for c in self.center))

    @property
    def shape(self) -> tuple:
        return (len(self.edges) - 1, len(self.zedges) - 1)

    @property
    def n(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def volume(self) -> np.ndarray:
        ring = np.pi * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)
        return (ring[:, None] * np.diff(self.zedges)[None, :]).ravel()

    @property
    def centre_r(self) -> np.ndarray:
        """Mid radius of each ring, shape (n_r,)."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    def _radius(self, pos):
        return np.hypot(pos[0] - self.center[0], pos[1] - self.center[1])

    def weights(self, pos, a):
        return self._imaged(lambda p, r: shell_weights(self._radius(p), p[2], r, self.edges,
                                                       self.zedges), pos, a)

    def basis(self, pos):
        """e_r, e_phi, e_z (rows) at each point, shape (P, 3, 3)."""
        E2 = polar_basis(pos[0] - self.center[0], pos[1] - self.center[1])
        E = np.zeros((len(E2), 3, 3))
        E[:, :2, :2] = E2
        E[:, 2, 2] = 1.0
        return E

    def cell_of(self, pos, slack=0.0):
        i, k = _cell_of(self._radius(pos), self.edges, slack), _cell_of(pos[2], self.zedges,
                                                                       slack)
        return np.where((i >= 0) & (k >= 0), i * self.shape[1] + k, -1)

    def coordinates(self) -> dict:
        i, k = np.unravel_index(np.arange(self.n), self.shape)
        return edge_coordinates({"r": (self.edges, i), "z": (self.zedges, k)})

    def describe(self) -> dict:
        return {"kind": self.kind, "edges": list(self.edges), "zedges": list(self.zedges),
                "center": list(self.center), "periods": _spans(self.periods)}
