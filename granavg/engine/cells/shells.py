"""Cylindrical shells of spheres in 3D: rings about an axis parallel to z, times layers
in z."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells import sectors
from granavg.engine.cells.base import (BINS, CENTER, EDGES, MAX_CELLS, R_RANGE, Z_RANGE, Cells,
                                       Imaged, Option, Space, Spheres, cell_index, check_range,
                                       checked_edges, cuts, divergence, edge_coordinates,
                                       periods_of, polar_basis, radial_flux, radii_edges, spans_of)
from granavg.engine.sphere_weights import shell_weights
from granavg.errors import ParameterError

#: Sectors of a revolved cylindrical shell in the VTK mesh.
MESH_SECTORS = 48


#: Cylindrical shells' layers along z.
LAYERS = Option("layers", "3D cylindrical shells: NZ layers over {z_range} (default 1)",
                "int", metavar="NZ")


@dataclass(frozen=True)
class Shells(Spheres, Imaged, Cells):
    """Cylindrical shells about the axis through ``center`` (x, y) parallel to z: rings
    [r_i, r_i+1) times layers [z_l, z_l+1); cell k = i n_z + l; volumes
    pi (r_i+1^2 - r_i^2) dz. Exact weights (quadrature of the slices' lens areas,
    converged to 1e-10). Basis e_r, e_phi, e_z at each sphere; sectors along phi."""

    edges: np.ndarray
    zedges: np.ndarray
    center: tuple = (0.0, 0.0)
    periods: tuple | None = None

    kind = "shells"
    title = "cylindrical shells"
    axes = ("r", "phi", "z")
    option_specs = (BINS, EDGES, R_RANGE, CENTER, LAYERS, Z_RANGE)
    symmetry, sectors_close, across = "phi", True, "r"

    @classmethod
    def from_options(cls, space: Space, *, bins=None, edges=None, r_range=None,
                     center=None, layers=None, z_range=None) -> "Shells":
        """``bins`` shells over ``r_range`` (or ``edges``) about the axis through
        ``center`` (default 0, 0), times ``layers`` layers (default 1) over ``z_range``
        (default the box; periodic images along z where the box is periodic there)."""
        check_range("r_range", r_range, nonnegative=True)
        check_range("z_range", z_range)
        if edges is None and r_range is None:
            raise ParameterError("r_range", "cylindrical shells need {param} R1 R2 (with "
                                 "{bins}) or {edges}; or choose {slabs} or {grid}")
        radii = cuts(bins, edges, r_range, radial=True)
        if layers is not None and not 1 <= layers <= MAX_CELLS:
            raise ParameterError("layers", f"{{param}} {layers}: give between 1 and "
                                 f"{MAX_CELLS}")
        zedges = np.linspace(*space.span("z", z_range), (layers or 1) + 1)
        period = space.period("z", z_range, "z_range")
        return cls(radii, zedges, (0.0, 0.0) if center is None else tuple(center),
                   (None, None, period) if period else None)

    @classmethod
    def restore(cls, d: dict) -> "Shells":
        return cls(np.asarray(d["edges"], float), np.asarray(d["zedges"], float),
                   tuple(d.get("center", (0.0, 0.0))), periods_of(d.get("periods")))

    def __post_init__(self):
        object.__setattr__(self, "edges", radii_edges(self.edges, "shell radii"))
        object.__setattr__(self, "zedges", checked_edges(self.zedges, "shell layer edges"))
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

    def weights(self, pos, a, images=None):
        return self._imaged(lambda p, r: shell_weights(self._radius(p), p[2], r, self.edges,
                                                       self.zedges), pos, a, images)

    def basis(self, pos):
        """e_r, e_phi, e_z (rows) at each point, shape (P, 3, 3)."""
        E2 = polar_basis(pos[0] - self.center[0], pos[1] - self.center[1])
        E = np.zeros((len(E2), 3, 3))
        E[:, :2, :2] = E2
        E[:, 2, 2] = 1.0
        return E

    def cell_of(self, pos, slack=0.0):
        i, k = cell_index(self._radius(pos), self.edges, slack), cell_index(pos[2],
                                                                           self.zedges, slack)
        return np.where((i >= 0) & (k >= 0), i * self.shape[1] + k, -1)

    def sector_shares(self, pos, a, k):
        return sectors.about_axis(pos, a, self.center, k, self.dim)

    def coordinates(self) -> dict:
        i, k = np.unravel_index(np.arange(self.n), self.shape)
        return edge_coordinates({"r": (self.edges, i), "z": (self.zedges, k)})

    def describe(self) -> dict:
        return {"kind": self.kind, "edges": list(self.edges), "zedges": list(self.zedges),
                "center": list(self.center), "periods": spans_of(self.periods)}

    def grid(self) -> tuple:
        return ("r", "z"), self.shape, (self.edges, self.zedges)

    def mesh(self):
        """The shells revolved into :data:`MESH_SECTORS` sectors (hexahedra), so that they
        show as the cylinder they are; each sector's angle for the Cartesian
        components."""
        from granavg.engine.cells.boxes import hexahedra
        nr, nz = self.shape
        phi = np.linspace(0.0, 2 * np.pi, MESH_SECTORS + 1)
        R, P, Z = np.meshgrid(self.edges, phi, self.zedges, indexing="ij")
        points = np.column_stack([self.center[0] + (R * np.cos(P)).ravel(),
                                  self.center[1] + (R * np.sin(P)).ravel(), Z.ravel()])
        _, hexes = hexahedra(self.edges, phi, self.zedges)   # (ring, sector, layer), C order
        i, j, k = np.unravel_index(np.arange(len(hexes)), (nr, MESH_SECTORS, nz))
        return points, [("hexahedron", hexes)], i * nz + k, 0.5 * (phi[j] + phi[j + 1])

    def residuals(self, T, f, closed):
        """Axisymmetric: (1/r) d(r T_rr)/dr + dT_rz/dz - T_phiphi / r, (1/r^2) d(r^2
        T_phir)/dr + dT_phiz/dz + (T_rphi - T_phir) / r and (1/r) d(r T_zr)/dr +
        dT_zz/dz, plus f, times the mean cell width (the z derivatives between layers;
        none with a single layer, where the flow is taken uniform in z)."""
        nr, nz = self.shape
        e, ze = self.edges, self.zedges
        r = self.centre_r[:, None]
        wrap = self.wraps("z")
        width = 0.5 * (np.mean(np.diff(e)) + np.mean(np.diff(ze)))

        def grid(name):
            return T[name].reshape(nr, nz)

        def radial(name, power):
            return radial_flux(grid(name), e, closed, power)

        def axial(name):
            if nz == 1 and not wrap:
                return np.zeros((nr, nz))                     # one layer: uniform in z
            return divergence(grid(name).T, np.diff(ze), closed, wrap).T

        res_r = radial("rr", 1) + axial("rz") - grid("phiphi") / r
        res_phi = radial("phir", 2) + axial("phiz") + (grid("rphi") - grid("phir")) / r
        res_z = radial("zr", 1) + axial("zz")
        return tuple(width * (res.ravel() + f[c]) for res, c in
                     ((res_r, "r"), (res_phi, "phi"), (res_z, "z")))

    def nodes(self):
        """Circles at the shells' mid radii and the layers' mid heights."""
        return "circles", self.center, self.centre_r, 0.5 * (self.zedges[1:] +
                                                              self.zedges[:-1])

    def position(self):
        return ("r", self.coordinates()["r"]) if self.shape[1] == 1 else None

    def planes(self):
        nr, nz = self.shape
        return [("r-z", ("r", self.edges), ("z", self.zedges), lambda a: a.reshape(nr, nz).T)]


CELLS = Shells
