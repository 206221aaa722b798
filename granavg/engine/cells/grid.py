"""A rectangular grid of disks in 2D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells.base import (GRID, THICKNESS, X_RANGE, Y_RANGE, Cells, Disks, Imaged,
                                       Space, cartesian_basis, cell_index, check_range,
                                       checked_edges, counts, disk_height, edge_coordinates,
                                       periods_of, spans_of, without_suffix)
from granavg.engine.weights import grid_weights


@dataclass(frozen=True)
class Grid(Disks, Imaged, Cells):
    """Rectangles [x_i, x_i+1) x [y_j, y_j+1); cell k = i n_y + j; volumes h dx dy.
    Exact weights (disk-rectangle areas in closed form); Cartesian basis."""

    xedges: np.ndarray
    yedges: np.ndarray
    h: float
    periods: tuple | None = None

    kind = "grid"
    title = "a 2D grid"
    axes = ("x", "y")
    selector = "grid"
    option_specs = (THICKNESS, GRID, X_RANGE, Y_RANGE)

    @classmethod
    def from_options(cls, space: Space, *, thickness=None, grid=None, x_range=None,
                     y_range=None) -> "Grid":
        """``grid`` = (nx, ny) rectangles over ``x_range`` and ``y_range`` (default the
        box; the particles' periodic images where the box is periodic,
        :meth:`Space.period`)."""
        h = disk_height(space, thickness)
        nx, ny = counts("grid", grid, 2, "NX NY for a 2D dump")
        check_range("x_range", x_range)
        check_range("y_range", y_range)
        xr, yr = space.span("x", x_range), space.span("y", y_range)
        periods = (space.period("x", x_range, "x_range"), space.period("y", y_range, "y_range"))
        return cls(np.linspace(*xr, nx + 1), np.linspace(*yr, ny + 1), h,
                   periods if any(periods) else None)

    @classmethod
    def restore(cls, d: dict) -> "Grid":
        d = without_suffix(d)
        return cls(np.asarray(d["xedges"], float), np.asarray(d["yedges"], float),
                   float(d["h"]), periods_of(d.get("periods")))

    def __post_init__(self):
        object.__setattr__(self, "xedges", checked_edges(self.xedges, "grid x edges"))
        object.__setattr__(self, "yedges", checked_edges(self.yedges, "grid y edges"))

    @property
    def shape(self) -> tuple:
        return (len(self.xedges) - 1, len(self.yedges) - 1)

    @property
    def n(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def volume(self) -> np.ndarray:
        return self.h * np.outer(np.diff(self.xedges), np.diff(self.yedges)).ravel()

    def weights(self, pos, a, images=None):
        return self._imaged(lambda p, r: grid_weights(p[0], p[1], r, self.xedges,
                                                      self.yedges), pos, a, images)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 2)

    def cell_of(self, pos, slack=0.0):
        """The cell k = i n_y + j of each point (edge cells take points up to ``slack``
        beyond)."""
        i, j = cell_index(pos[0], self.xedges, slack), cell_index(pos[1], self.yedges, slack)
        return np.where((i >= 0) & (j >= 0), i * (len(self.yedges) - 1) + j, -1)

    def coordinates(self) -> dict:
        nx, ny = self.shape
        i, j = np.divmod(np.arange(nx * ny), ny)
        return edge_coordinates({"x": (self.xedges, i), "y": (self.yedges, j)})

    def describe(self) -> dict:
        out = {"kind": self.kind, "xedges": list(self.xedges), "yedges": list(self.yedges),
               "h": self.h}
        return out if self.periods is None else {**out, "periods": spans_of(self.periods)}

    def grid(self) -> tuple:
        e = (self.xedges, self.yedges)
        return ("x", "y"), self.shape, e

    def mesh(self):
        """Quadrilaterals in the z = 0 plane."""
        from granavg.engine.cells.boxes import hexahedra
        points, hexes = hexahedra(self.xedges, self.yedges, np.array([0.0, 1.0]))
        points = points[points[:, 2] == 0.0]
        quads = hexes[:, :4] // 2                      # the z = 0 corners, renumbered
        return points, [("quad", quads)], np.arange(self.n), None

    def residuals(self, T, f, closed):
        """sum_j dT_ij/dx_j + f_i by central differences, interior cells only, times
        the mean cell width."""
        nx, ny = self.shape
        xc = 0.5 * (self.xedges[1:] + self.xedges[:-1])
        yc = 0.5 * (self.yedges[1:] + self.yedges[:-1])
        width = 0.5 * (np.mean(np.diff(self.xedges)) + np.mean(np.diff(self.yedges)))
        inner = np.zeros((nx, ny), bool)
        inner[1:-1, 1:-1] = True

        def div(c):
            tx, ty = T[c + "x"].reshape(nx, ny), T[c + "y"].reshape(nx, ny)
            d = np.full((nx, ny), np.nan)
            if nx > 2 and ny > 2:
                d = np.gradient(tx, xc, axis=0) + np.gradient(ty, yc, axis=1)
            return np.where(inner, d, np.nan).ravel()
        return (width * (div("x") + f["x"]), width * (div("y") + f["y"]))

    def nodes(self):
        """The rectangles' centres."""
        return "lattice", tuple(0.5 * (e[1:] + e[:-1]) for e in (self.xedges, self.yedges))

    def planes(self):
        nx, ny = self.shape
        return [("x-y", ("x", self.xedges), ("y", self.yedges), lambda a: a.reshape(nx, ny).T)]


CELLS = Grid
