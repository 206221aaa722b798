"""A polar grid: rings about a centre times equal angular sectors, disks in 2D - field
maps over an annulus such as the Couette cell's.

A disk's weight in the cell (ring i, sector j) is its exact weight in ring i (the lens
areas of :mod:`granavg.engine.weights`) times its exact share of sector j (the circular
segments beyond the sector's rays, :mod:`granavg.engine.cells.sectors`). The shares of a
disk sum to 1, so a ring's sectors add up to the ring: the polar grid's sums over phi
are the ring profile's sums to round-off. The product is exact for every disk cut by a
ring edge or by a ray, and approximate only for a disk cut by both at once (a corner of
a cell; docs/profiles.md gives the error measured against Monte Carlo). Vectors and
tensors are in each particle's polar basis, as for rings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from granavg.engine.cells import sectors
from granavg.engine.cells.base import (CENTER, MAX_CELLS, R_RANGE, THICKNESS, Cells, Disks, Option,
                                       Space, cell_index, check_range, cuts, disk_height, faces,
                                       polar_basis, radial_flux, radii_edges, without_suffix)
from granavg.engine.weights import ring_weights
from granavg.errors import ParameterError, UserError

#: Mesh quadrilaterals per full turn in the VTK file (each cell's arc in several).
MESH_SEGMENTS = 96


#: The option that chooses a polar grid.
POLAR_GRID = Option("polar_grid", "a polar grid: NR equal rings (from R_i to R_o of a run, "
                    "or over {r_range} about {center}) in NPHI equal sectors each: maps "
                    "over the annulus", "int", nargs=2, metavar=("NR", "NPHI"), runs=True)


@dataclass(frozen=True)
class PolarGrid(Disks, Cells):
    """Cells [r_i, r_i+1) x [phi_j, phi_j+1) about ``center``, ``nphi`` equal sectors
    from the +x direction counter-clockwise; cell k = i nphi + j; volumes
    h (r_i+1^2 - r_i^2) (phi_j+1 - phi_j) / 2."""

    edges: np.ndarray
    nphi: int
    h: float
    center: tuple = (0.0, 0.0)

    kind = "polar_grid"
    title = "a polar grid"
    axes = ("r", "phi")
    angles = ("phi",)
    selector = "polar_grid"
    option_specs = (THICKNESS, POLAR_GRID, R_RANGE, CENTER)

    @classmethod
    def from_options(cls, space: Space, *, thickness=None, polar_grid=None, r_range=None,
                     center=None) -> "PolarGrid":
        """``polar_grid`` = (nr, nphi): nr equal rings over ``r_range`` about ``center``
        (default 0, 0), each in nphi sectors."""
        h = disk_height(space, thickness)
        if len(polar_grid) != 2:
            raise ParameterError("polar_grid", f"{{param}} {' '.join(map(str, polar_grid))}"
                                 ": give NR NPHI")
        nr, nphi = (int(v) for v in polar_grid)
        if min(nr, nphi) < 1 or nr * nphi > MAX_CELLS:
            raise ParameterError("polar_grid", f"{{param}} {nr} {nphi}: give between 1 and "
                                 f"{MAX_CELLS} cells")
        if r_range is None:
            raise ParameterError("r_range", "a polar grid needs {param} R1 R2")
        check_range("r_range", r_range, nonnegative=True)
        return cls(cuts(nr, None, r_range, radial=True), nphi, h,
                   (0.0, 0.0) if center is None else tuple(center))

    @classmethod
    def restore(cls, d: dict) -> "PolarGrid":
        d = without_suffix(d)
        return cls(np.asarray(d["edges"], float), int(d["nphi"]), float(d["h"]),
                   tuple(d.get("center", (0.0, 0.0))))

    def __post_init__(self):
        object.__setattr__(self, "edges", radii_edges(self.edges, "polar grid radii"))
        if not 1 <= int(self.nphi) <= MAX_CELLS:
            raise UserError(f"polar grid sectors {self.nphi}: give between 1 and {MAX_CELLS}")
        object.__setattr__(self, "nphi", int(self.nphi))
        object.__setattr__(self, "center", tuple(float(c) for c in self.center))

    @property
    def shape(self) -> tuple:
        return (len(self.edges) - 1, self.nphi)

    @property
    def n(self) -> int:
        return self.shape[0] * self.nphi

    @property
    def phi_edges(self) -> np.ndarray:
        """The sectors' bounding angles, 0 to 2 pi, shape (nphi + 1,)."""
        return np.arange(self.nphi + 1) * (2.0 * math.pi / self.nphi)

    @property
    def volume(self) -> np.ndarray:
        ring = np.pi * self.h * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)
        return np.repeat(ring / self.nphi, self.nphi)

    def _radius(self, pos):
        return np.hypot(pos[0] - self.center[0], pos[1] - self.center[1])

    def weights(self, pos, a):
        """(particle, cell, weight): each ring weight split over the disk's sectors."""
        particle, ring, w = ring_weights(self._radius(pos), a, self.edges)
        sector, share = sectors.about_axis(pos, a, self.center, self.nphi, self.dim)
        if self.nphi == 1:                  # one sector: the ring itself
            return particle, ring, w
        s, f = sector[particle], share[particle]                      # (T, 3)
        keep = f > 0.0
        cell = ring[:, None] * self.nphi + s
        return (np.broadcast_to(particle[:, None], s.shape)[keep], cell[keep],
                (w[:, None] * f)[keep])

    def basis(self, pos):
        """e_r and e_phi (rows) at each point, shape (P, 2, 2)."""
        return polar_basis(pos[0] - self.center[0], pos[1] - self.center[1])

    def cell_of(self, pos, slack=0.0):
        i = cell_index(self._radius(pos), self.edges, slack)
        phi = np.mod(np.arctan2(pos[1] - self.center[1], pos[0] - self.center[0]),
                     2.0 * math.pi)
        j = np.minimum((phi / (2.0 * math.pi / self.nphi)).astype(np.int64), self.nphi - 1)
        return np.where(i >= 0, i * self.nphi + j, -1)

    def coordinates(self) -> dict:
        i, j = np.divmod(np.arange(self.n), self.nphi)
        p = self.phi_edges
        return {"r_lo": self.edges[i], "r_hi": self.edges[i + 1], "phi_lo": p[j],
                "phi_hi": p[j + 1], "r": 0.5 * (self.edges[i] + self.edges[i + 1]),
                "phi": 0.5 * (p[j] + p[j + 1])}

    def describe(self) -> dict:
        return {"kind": self.kind, "edges": list(self.edges), "nphi": self.nphi,
                "h": self.h, "center": list(self.center)}

    def grid(self) -> tuple:
        return ("r", "phi"), self.shape, (self.edges, self.phi_edges)

    def mesh(self):
        """Quadrilaterals in the z = 0 plane, each cell's arc in
        ``MESH_SEGMENTS / nphi`` pieces; each piece's angle for the Cartesian
        components."""
        nr, nphi = self.shape
        per = max(1, math.ceil(MESH_SEGMENTS / nphi))
        phi = np.linspace(0.0, 2.0 * math.pi, nphi * per + 1)
        R, P = np.meshgrid(self.edges, phi, indexing="ij")              # (nr+1, m+1)
        points = np.column_stack([self.center[0] + (R * np.cos(P)).ravel(),
                                  self.center[1] + (R * np.sin(P)).ravel(),
                                  np.zeros(R.size)])
        m = len(phi)
        i, s = (a.ravel() for a in np.meshgrid(np.arange(nr), np.arange(m - 1),
                                               indexing="ij"))
        quads = np.column_stack([i * m + s, (i + 1) * m + s, (i + 1) * m + s + 1,
                                 i * m + s + 1])
        return points, [("quad", quads)], i * nphi + s // per, 0.5 * (phi[s] + phi[s + 1])

    def residuals(self, T, f, closed):
        """(div T)_r = (1/r) d(r T_rr)/dr + (1/r) dT_rphi/dphi - T_phiphi / r and
        (div T)_phi = (1/r^2) d(r^2 T_phir)/dr + (1/r) dT_phiphi/dphi + (T_rphi -
        T_phir) / r, plus f, in finite volumes (the sectors close on themselves; the
        radial outer faces closed or, else, NaN), times dr as for rings: the net force
        on the cell over its face. An axisymmetric field gives the rings' residuals."""
        nr, nphi = self.shape
        e = self.edges
        r = (0.5 * (e[1:] + e[:-1]))[:, None]
        dr = np.diff(e)[:, None]
        dphi = 2.0 * math.pi / nphi

        def grid(name):
            return T[name].reshape(nr, nphi)

        def radial(name, power):
            return radial_flux(grid(name), e, closed, power)

        def angular(name):
            values = np.apply_along_axis(faces, 1, grid(name), closed, True)
            return np.diff(values, axis=1) / dphi / r

        res_r = radial("rr", 1) + angular("rphi") - grid("phiphi") / r
        res_phi = radial("phir", 2) + angular("phiphi") + (grid("rphi") - grid("phir")) / r
        return tuple((dr * (res + f[c].reshape(nr, nphi))).ravel()
                     for res, c in ((res_r, "r"), (res_phi, "phi")))

    def nodes(self):
        """The cells' centres (mid radius, mid angle)."""
        return "polar", self.center, 0.5 * (self.edges[1:] + self.edges[:-1]), \
            0.5 * (self.phi_edges[1:] + self.phi_edges[:-1])

    def planes(self):
        """The annulus in x-y, each cell's arc drawn in several pieces."""
        nr, nphi = self.shape
        per = max(1, math.ceil(MESH_SEGMENTS / nphi))
        phi = np.linspace(0.0, 2.0 * math.pi, nphi * per + 1)
        R, P = np.meshgrid(self.edges, phi, indexing="ij")
        X, Y = self.center[0] + R * np.cos(P), self.center[1] + R * np.sin(P)
        return [("x-y", ("x", X), ("y", Y),
                 lambda a: np.repeat(a.reshape(nr, nphi), per, axis=1))]


CELLS = PolarGrid
