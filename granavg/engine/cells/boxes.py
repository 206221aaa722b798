"""A box grid of spheres in 3D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells.base import (GRID, X_RANGE, Y_RANGE, Z_RANGE, Cells, Imaged, Space,
                                       Spheres, cartesian_basis, cell_index, check_range,
                                       checked_edges, counts, divergence, edge_coordinates,
                                       periods_of, spans_of)
from granavg.engine.sphere_weights import box_weights


@dataclass(frozen=True)
class Boxes(Spheres, Imaged, Cells):
    """Boxes [x_i, x_i+1) x [y_j, y_j+1) x [z_l, z_l+1); cell k = (i n_y + j) n_z + l;
    volumes dx dy dz. Exact weights (closed form). Cartesian basis."""

    xedges: np.ndarray
    yedges: np.ndarray
    zedges: np.ndarray
    periods: tuple | None = None

    kind = "boxes"
    title = "a box grid"
    axes = ("x", "y", "z")
    selector = "grid"
    option_specs = (GRID, X_RANGE, Y_RANGE, Z_RANGE)

    @classmethod
    def from_options(cls, space: Space, *, grid=None, x_range=None, y_range=None,
                     z_range=None) -> "Boxes":
        """``grid`` = (nx, ny, nz) boxes over the ranges (default the box; the particles'
        periodic images where the box is periodic, :meth:`Space.period`)."""
        shape = counts("grid", grid, 3, "NX NY NZ for a 3D dump")
        ranges = {"x": check_range("x_range", x_range), "y": check_range("y_range", y_range),
                  "z": check_range("z_range", z_range)}
        e = [np.linspace(*space.span(a, ranges[a]), n + 1) for a, n in zip("xyz", shape)]
        periods = tuple(space.period(a, ranges[a], f"{a}_range") for a in "xyz")
        return cls(*e, periods if any(periods) else None)

    @classmethod
    def restore(cls, d: dict) -> "Boxes":
        return cls(*(np.asarray(d[k], float) for k in ("xedges", "yedges", "zedges")),
                   periods_of(d.get("periods")))

    def __post_init__(self):
        for name in ("xedges", "yedges", "zedges"):
            object.__setattr__(self, name, checked_edges(getattr(self, name),
                                                         f"box {name[0]} edges"))

    @property
    def edges3(self) -> tuple:
        return (self.xedges, self.yedges, self.zedges)

    @property
    def shape(self) -> tuple:
        return (len(self.xedges) - 1, len(self.yedges) - 1, len(self.zedges) - 1)

    @property
    def n(self) -> int:
        return int(np.prod(self.shape))

    @property
    def volume(self) -> np.ndarray:
        dx, dy, dz = (np.diff(e) for e in self.edges3)
        return (dx[:, None, None] * dy[None, :, None] * dz[None, None, :]).ravel()

    def weights(self, pos, a, images=None):
        return self._imaged(lambda p, r: box_weights(*p, r, self.xedges, self.yedges,
                                                     self.zedges), pos, a, images)

    def basis(self, pos):
        return cartesian_basis(len(pos[0]), 3)

    def cell_of(self, pos, slack=0.0):
        """The box (i n_y + j) n_z + l of each point (edge boxes take points up to
        ``slack`` beyond)."""
        nx, ny, nz = self.shape
        i, j, k = (cell_index(u, e, slack) for u, e in zip(pos, self.edges3))
        return np.where((i >= 0) & (j >= 0) & (k >= 0), (i * ny + j) * nz + k, -1)

    def coordinates(self) -> dict:
        i, j, k = np.unravel_index(np.arange(self.n), self.shape)
        return edge_coordinates({"x": (self.xedges, i), "y": (self.yedges, j),
                                 "z": (self.zedges, k)})

    def describe(self) -> dict:
        return {"kind": self.kind, "xedges": list(self.xedges), "yedges": list(self.yedges),
                "zedges": list(self.zedges), "periods": spans_of(self.periods)}

    def grid(self) -> tuple:
        return ("x", "y", "z"), self.shape, self.edges3

    def mesh(self):
        points, hexes = hexahedra(*self.edges3)
        return points, [("hexahedron", hexes)], np.arange(self.n), None

    def residuals(self, T, f, closed):
        """sum_j dT_ij/dx_j + f_i in finite volumes (interior cells; every cell along a
        periodic axis; the outer faces closed or, else, the edge cells NaN), times the
        mean cell width."""
        shape = self.shape
        width = np.mean([np.mean(np.diff(e)) for e in self.edges3])
        out = []
        for c in "xyz":
            div = np.zeros(shape)
            for k, (j, e) in enumerate(zip("xyz", self.edges3)):
                d = divergence(np.moveaxis(T[c + j].reshape(shape), k, 0), np.diff(e),
                               closed, self.wraps(j))
                div += np.moveaxis(d, 0, k)
            out.append(width * (div.ravel() + f[c]))
        return tuple(out)

    def nodes(self):
        """The boxes' centres."""
        return "lattice", tuple(0.5 * (e[1:] + e[:-1]) for e in self.edges3)

    def planes(self):
        nx, ny, nz = self.shape
        return [(f"x-y, layer {nz // 2 + 1} of {nz} in z", ("x", self.xedges),
                 ("y", self.yedges), lambda a: a.reshape(nx, ny, nz)[:, :, nz // 2].T),
                (f"x-z, row {ny // 2 + 1} of {ny} in y", ("x", self.xedges),
                 ("z", self.zedges), lambda a: a.reshape(nx, ny, nz)[:, ny // 2, :].T)]


def hexahedra(xe, ye, ze):
    """Corner points and hexahedra (VTK order) of the boxes of a rectilinear grid, the
    cells in C order of (x, y, z)."""
    X, Y, Z = np.meshgrid(xe, ye, ze, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    ny, nz = len(ye), len(ze)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(len(xe) - 1), np.arange(ny - 1),
                                              np.arange(nz - 1), indexing="ij"))

    def at(di, dj, dk):
        return ((i + di) * ny + (j + dj)) * nz + (k + dk)
    cells = np.column_stack([at(0, 0, 0), at(1, 0, 0), at(1, 1, 0), at(0, 1, 0),
                             at(0, 0, 1), at(1, 0, 1), at(1, 1, 1), at(0, 1, 1)])
    return points, cells


CELLS = Boxes
