"""Rings about a centre: the paper's cells (the Couette default), disks in 2D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.cells import sectors
from granavg.engine.cells.base import (BINS, CENTER, EDGES, R_RANGE, THICKNESS, Cells, Disks, Space,
                                       cell_index, check_range, cuts, disk_height, faces,
                                       polar_basis, radii_edges, without_suffix)
from granavg.engine.weights import ring_weights
from granavg.errors import ParameterError


@dataclass(frozen=True)
class Rings(Disks, Cells):
    """Rings [r_lo, r_hi) about ``center`` of height h: volumes pi h (r_hi^2 - r_lo^2).

    Vectors and tensors are in each particle's polar basis (e_r, e_phi) about the centre.
    Each ring splits into sectors along phi for the errors' spatial replicas.
    """

    edges: np.ndarray
    h: float
    center: tuple = (0.0, 0.0)

    kind = "rings"
    title = "rings"
    axes = ("r", "phi")
    option_specs = (THICKNESS, BINS, EDGES, R_RANGE, CENTER)
    symmetry, sectors_close, across = "phi", True, "r"

    @classmethod
    def count(cls, n: int, r_inner: float, r_outer: float, h: float,
              center=(0.0, 0.0)) -> "Rings":
        """``n`` equal-width rings between r_inner and r_outer."""
        if n < 1:
            raise ParameterError("bins", f"{{param}} {n}: need at least one ring")
        return cls(np.linspace(r_inner, r_outer, n + 1), h, tuple(center))

    @classmethod
    def from_options(cls, space: Space, *, thickness=None, bins=None, edges=None,
                     r_range=None, center=None) -> "Rings":
        """``bins`` equal rings over ``r_range`` (or ``edges``) about ``center`` (default
        0, 0), disks of height ``thickness``."""
        h = disk_height(space, thickness)
        check_range("r_range", r_range, nonnegative=True)
        if edges is None and r_range is None:
            raise ParameterError("r_range", "rings need {param} R1 R2 (with {bins}) or "
                                 "{edges}; or choose {slabs} or {grid}")
        return cls(cuts(bins, edges, r_range, radial=True), h,
                   (0.0, 0.0) if center is None else tuple(center))

    @classmethod
    def restore(cls, d: dict) -> "Rings":
        d = without_suffix(d)
        return cls(np.asarray(d["edges"], float), float(d["h"]),
                   tuple(d.get("center", (0.0, 0.0))))

    def __post_init__(self):
        object.__setattr__(self, "edges", radii_edges(self.edges, "ring edges"))
        object.__setattr__(self, "center", tuple(float(c) for c in self.center))

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    @property
    def volume(self) -> np.ndarray:
        return np.pi * self.h * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)

    @property
    def centre(self) -> np.ndarray:
        """Mid radius of each ring."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    def _radius(self, pos):
        return np.hypot(pos[0] - self.center[0], pos[1] - self.center[1])

    def weights(self, pos, a):
        """(particle, ring, fraction of the disk's area in it); exact lens areas."""
        return ring_weights(self._radius(pos), a, self.edges)

    def basis(self, pos):
        """e_r and e_phi (rows) at each point, shape (P, 2, 2)."""
        return polar_basis(pos[0] - self.center[0], pos[1] - self.center[1])

    def coordinates(self) -> dict:
        return {"r_lo": self.edges[:-1], "r_hi": self.edges[1:], "r": self.centre}

    def cell_of(self, pos, slack=0.0):
        return cell_index(self._radius(pos), self.edges, slack)

    def sector_shares(self, pos, a, k):
        return sectors.about_axis(pos, a, self.center, k, self.dim)

    def describe(self) -> dict:
        return {"kind": self.kind, "edges": list(self.edges), "h": self.h,
                "center": list(self.center)}

    def grid(self) -> tuple:
        return ("r",), (self.n,), (self.edges,)

    def residuals(self, T, f, closed):
        """Steady and axisymmetric (Eqs. 11-12 with the force densities), in r-form:
        radial d(r T_rr)/dr - T_phiphi + r f_r, tangential d(r^2 T_phir)/dr / r + T_rphi
        - T_phir + r f_phi; times dr / r, the net force on the ring over its face."""
        e, r = self.edges, self.centre
        dr = np.diff(e)
        flux_rr = np.diff(e * faces(T["rr"], closed)) / dr            # d(r T_rr)/dr
        flux_pr = np.diff(e * e * faces(T["phir"], closed)) / dr / r  # d(r^2 T_phir)/dr / r
        per_cell = dr / r                                # r (div T + f) -> per cell
        return (per_cell * (flux_rr - T["phiphi"] + r * f["r"]),
                per_cell * (flux_pr + T["rphi"] - T["phir"] + r * f["phi"]))

    def position(self):
        return "r", self.coordinates()["r"]

    def nodes(self):
        """The rings' mid circles."""
        return "circles", self.center, self.centre, np.zeros(1)


CELLS = Rings
