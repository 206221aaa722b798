"""Any cells as the nodes of smooth coarse-grained fields: :class:`Smoothed`, the
smoothing kernel as a weight plug-in of the one engine.

The exact weights give each cell the particles' volume inside it. A smoothing kernel
phi of width w gives each node k (a cell's centre: a point, the plane of a slab, the
circle of a ring) the fields at it: a particle's weight in node k is

    w_pk = (V_k / depth) phi_k(x_p),

phi_k the kernel at the node (:meth:`~granavg.engine.cells.base.Cells.nodes`), depth the disks'
height in 2D (1 in 3D), so that the engine's sum over the particles, divided by V_k as
for cells, is the field: nu(x_k) = sum_p V^p phi_k(x_p) / depth, rho = sum_p m_p phi_k,
v = <m^p v> / <m^p>, and every other quantity alike. The static stress spreads each
contact's force along its branch vectors, centre -> contact point for each particle of
the contact (the contact point the middle of the overlap, as the exact weights' branch;
Weinhart, Thornton, Luding and Bokhove 2012): sigma(x) = sum_contacts f (x) l
int_0^1 phi(x - x_p - s l) ds / depth, so that its divergence is the contact forces
spread at the particles less the same at the contact points. The walls' forces are
spread at their contact points (the boundary force density), body forces at the
particles. The kernel's derivative gives the derivative blocks of
:mod:`granavg.engine.channels` (velocity gradient, the stresses' divergences).

Everything else - volumes, basis, coordinates, the errors' sectors, field files, maps -
is the wrapped cells'.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from granavg.engine.cells.base import Cells, with_images
from granavg.engine.smoothing import circles, lookup
from granavg.engine.smoothing._kernels import (point_pairs, point_segment_pairs, ring_pairs,
                                              ring_segment_pairs, shell_pairs,
                                              shell_segment_pairs)
from granavg.engine.smoothing.base import Kernel
from granavg.engine.smoothing.rotation import MOMENTS
from granavg.errors import ParameterError


@dataclass(frozen=True)
class Smoothed(Cells):
    """The nodes of ``cells`` with ``kernel`` of width ``width`` (the frames' length
    unit)."""

    cells: Cells
    kernel: Kernel
    width: float

    spreads_branches = True

    def __post_init__(self):
        if not (np.isfinite(self.width) and self.width > 0):
            raise ParameterError("width", f"{{param}} {self.width!r}: must be a finite "
                                 "number > 0")
        self.cells.nodes()                        # every kind of cells has nodes

    # -- what the wrapped cells are ------------------------------------------------------
    def __getattr__(self, name):
        """Every other attribute (edges, h, centre, shape, ...) is the cells'."""
        if name == "cells":                     # not set yet (unpickling)
            raise AttributeError(name)
        return getattr(self.cells, name)

    kind = property(lambda self: self.cells.kind)
    title = property(lambda self: self.cells.title)
    dim = property(lambda self: self.cells.dim)
    axes = property(lambda self: self.cells.axes)
    position_names = property(lambda self: self.cells.position_names)
    symmetry = property(lambda self: self.cells.symmetry)
    sectors_close = property(lambda self: self.cells.sectors_close)
    across = property(lambda self: self.cells.across)
    angles = property(lambda self: self.cells.angles)

    @classmethod
    def from_options(cls, space, **options):
        raise NotImplementedError("smooth cells are made from cells: Smoothed(cells, ...)")

    @classmethod
    def restore(cls, d: dict):
        raise NotImplementedError("granavg.engine.cells.restore restores smooth cells")

    def describe(self) -> dict:
        return {**self.cells.describe(), "kernel": self.kernel.name, "width": self.width}

    @property
    def n(self) -> int:
        return self.cells.n

    @property
    def volume(self) -> np.ndarray:
        return self.cells.volume

    def particle_volume(self, a):
        return self.cells.particle_volume(a)

    def def_factor(self, a):
        return self.cells.def_factor(a)

    def cell_of(self, pos, slack=0.0):
        return self.cells.cell_of(pos, slack)

    def basis(self, pos):
        return self.cells.basis(pos)

    def coordinates(self) -> dict:
        return self.cells.coordinates()

    def sector_shares(self, pos, a, k):
        return self.cells.sector_shares(pos, a, k)

    def grid(self):
        return self.cells.grid()

    def mesh(self):
        return self.cells.mesh()

    def residuals(self, T, f, closed):
        return self.cells.residuals(T, f, closed)

    def position(self):
        return self.cells.position()

    def nodes(self):
        return self.cells.nodes()

    def planes(self):
        return self.cells.planes()

    # -- the kernel's weights -------------------------------------------------------------
    @property
    def cutoff(self) -> float:
        return self.kernel.cutoff(self.width)

    @property
    def _per_node(self) -> np.ndarray:
        """V_k / depth (V_k / (depth section) for planes: the field is the plane's
        average): the factor of each node's weights."""
        depth = self.cells.h if self.dim == 2 else 1.0
        kind, *spec = self.cells.nodes()
        section = spec[2] if kind == "planes" else 1.0
        return self.volume / depth / section

    @property
    def moments(self) -> int:
        """Weights per pair: 1, or 5 where the nodes' basis turns about the axis
        (:mod:`granavg.engine.smoothing.rotation`)."""
        return MOMENTS if self.cells.nodes()[0] in ("circles", "polar") else 1

    def weights(self, pos, a):
        """(particle, node, w_pk) of particles at ``pos`` (their centres; the radii do
        not enter): the scalar weights."""
        particle, node, W, _ = self.kernel_weights(pos, deriv=False)
        return particle, node, W[:, 0]

    def images(self, pos, shear=None):
        """The particles' images within the kernel's reach of the nodes
        (:func:`~granavg.engine.cells.base.with_images`; in a sheared box ``shear``, with
        rows of their own where they move), or None without periods."""
        periods = getattr(self.cells, "periods", None)
        if not periods or all(p is None for p in periods):
            return None
        return with_images(pos, np.full(len(pos[0]), self.cutoff), periods, shear)

    def kernel_weights(self, pos, deriv=True, images=None, shear=None):
        """(particle, node, W, dW): the weights, shape (T, :attr:`moments`), and with
        ``deriv`` their derivatives along the cells' basis, shape (T, moments, D)
        (zeros along directions the nodes do not vary in). Where the basis turns, the
        moments take the quantities from the polar basis at each item's own position.
        ``images`` (:meth:`images`): the particles' rows as theirs; else the images of
        the box (sheared by ``shear``) map to the particles' own rows."""
        return self._pairs(tuple(np.asarray(u, float) for u in pos), None, deriv, shear,
                           images)

    def segment_weights(self, start, l, shear=None):
        """(segment, node, W) of the line integrals along the segments from ``start``
        (tuple of D arrays) by ``l`` (array (S, D)), the moments taking the
        quantities from the polar basis at the start; images in the box sheared by
        ``shear``."""
        item, node, W, _ = self._pairs(tuple(np.asarray(u, float) for u in start),
                                       np.asarray(l, float), False, shear)
        return item, node, W

    def _pairs(self, pos, l, deriv, shear=None, images=None):
        c = self.cutoff
        length = np.zeros(len(pos[0])) if l is None else \
            np.sqrt(np.sum(l ** 2, axis=1))
        periods = getattr(self.cells, "periods", None)
        rows = None
        if images is not None:
            rows = images.row
        elif periods and any(p is not None for p in periods):
            images = with_images(pos, c + length, periods, shear)   # images within reach
            rows = images.index
        if images is not None:
            pos = images.pos
            length = length[images.index]
            l = None if l is None else l[images.index]
        # the pairs: a segment's middle within c + half its length of the node
        mid = pos if l is None else tuple(u + 0.5 * l[:, k]
                                               for k, u in enumerate(pos))
        kind, *spec = self.cells.nodes()
        item, node, W, dW = getattr(self, f"_{kind}")(spec, pos, mid, c + 0.5 * length,
                                                      l, deriv)
        keep = np.any(W != 0.0, axis=1) | np.any(dW != 0.0, axis=(1, 2))
        item, node, W, dW = item[keep], node[keep], W[keep], dW[keep]
        if rows is not None:
            item = rows[item]
        f = self._per_node[node]
        return item, node, W * f[:, None], dW * f[:, None, None]

    def _points(self, x, l, grid, basis, item, node, deriv):
        """Point nodes at ``grid`` (basis rows per node): w (T,) and dw (T, D)."""
        k, c, D = self.kernel, self.cutoff, grid.shape[1]
        scale = k.norms[D] / c ** D
        w, dw = np.zeros(len(item)), np.zeros((len(item), D))
        x = np.ascontiguousarray(x, float)
        grid = np.ascontiguousarray(grid, float)
        if l is None:
            point_pairs(x, grid, np.ascontiguousarray(basis, float), item, node, k.packed,
                        scale, c, deriv, w, dw)
        else:
            point_segment_pairs(x, np.ascontiguousarray(l, float), grid, item, node,
                                k.packed, scale, c, w)
        return w, dw

    def _lattice(self, spec, pos, mid, reach, l, deriv):
        (axes,) = spec
        D = self.dim
        item, node = lookup.lattice_pairs(mid, axes, reach)
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, D)
        basis = np.broadcast_to(np.eye(D), (len(grid), D, D))
        w, dw = self._points(np.column_stack(pos), l, grid, basis, item, node, deriv)
        return item, node, w[:, None], dw[:, None, :]

    def _planes(self, spec, pos, mid, reach, l, deriv):
        axis, centres, _ = spec
        item, node = lookup.lattice_pairs((mid[axis],), (centres,), reach)
        w, dw1 = self._points(pos[axis][:, None], None if l is None else
                              l[:, axis:axis + 1], centres[:, None],
                              np.ones((len(centres), 1, 1)), item, node, deriv)
        dw = np.zeros((len(w), 1, self.dim))
        dw[:, 0, axis] = dw1[:, 0]
        return item, node, w[:, None], dw

    def _polar(self, spec, pos, mid, reach, l, deriv):
        """Points of a polar lattice: the kernel weight times the turn (cos, sin of k
        delta) from the particle's azimuth to the node's, and the turn's own derivative
        along e_phi (delta grows by 1/R per unit length)."""
        center, radii, phis = spec
        x, y = pos[0] - center[0], pos[1] - center[1]
        rings_item, ring = lookup.lattice_pairs((np.hypot(mid[0] - center[0],
                                                          mid[1] - center[1]),),
                                                (radii,), reach)
        nphi = len(phis)
        item = np.repeat(rings_item, nphi)
        node = (np.repeat(ring, nphi) * nphi + np.tile(np.arange(nphi), len(ring)))
        R, P = np.meshgrid(radii, phis, indexing="ij")
        grid = np.column_stack([center[0] + (R * np.cos(P)).ravel(),
                                center[1] + (R * np.sin(P)).ravel()])
        c_, s_ = np.cos(P).ravel(), np.sin(P).ravel()
        basis = np.stack([np.column_stack([c_, s_]), np.column_stack([-s_, c_])], axis=1)
        w, dw = self._points(np.column_stack(pos), l, grid, basis, item, node, deriv)
        delta = P.ravel()[node] - np.arctan2(y, x)[item]
        turn = np.column_stack([np.ones_like(delta), np.cos(delta), np.sin(delta),
                                np.cos(2 * delta), np.sin(2 * delta)])
        dturn = np.column_stack([np.zeros_like(delta), -np.sin(delta), np.cos(delta),
                                 -2 * np.sin(2 * delta), 2 * np.cos(2 * delta)])
        W = w[:, None] * turn
        dW = dw[:, None, :] * turn[:, :, None]
        dW[:, :, 1] += (w / R.ravel()[node])[:, None] * dturn
        return item, node, W, dW

    @property
    def _margin(self) -> float:
        """How near a segment's end a circle node's kink may lie (circles.MARGINS; an
        order not listed takes the next lower one's, the safer)."""
        return circles.MARGINS[max(n for n in circles.MARGINS if n <= self.kernel.edge_order)]

    @cached_property
    def _ring_tables(self):
        """The 2D rings' tabulated moments (:class:`circles.RingTables`)."""
        center, radii, heights = self.cells.nodes()[1:]
        return circles.RingTables(self.kernel, self.cutoff, radii).arrays()

    def _circles(self, spec, pos, mid, reach, l, deriv):
        center, radii, heights = spec
        k, c, D = self.kernel, self.cutoff, self.dim
        rho = np.hypot(mid[0] - center[0], mid[1] - center[1])
        item, node = lookup.lattice_pairs((rho,) if D == 2 else (rho, mid[2]),
                                          (radii,) if D == 2 else (radii, heights), reach)
        W, dW = np.zeros((len(item), MOMENTS)), np.zeros((len(item), MOMENTS, D))
        cx, cy = float(center[0]), float(center[1])
        x, y = pos[0], pos[1]
        if D == 2:
            tables = self._ring_tables
            if l is None:
                ring_pairs(x, y, cx, cy, *tables, item, node, deriv, W, dW)
            else:
                ring_segment_pairs(x, y, np.ascontiguousarray(l[:, 0]),
                                   np.ascontiguousarray(l[:, 1]), cx, cy, *tables,
                                   self._margin, item, node, W)
            return item, node, W, dW
        args = (cx, cy, np.asarray(radii, float), np.asarray(heights, float), len(heights),
                item, node, k.packed, k.norms[3] / c ** 3, c)
        if l is None:
            shell_pairs(x, y, pos[2], *args, deriv, W, dW)
        else:
            shell_segment_pairs(x, y, pos[2], *(np.ascontiguousarray(l[:, j])
                                                for j in range(3)), *args, self._margin, W)
        return item, node, W, dW

    def inverse_radius(self):
        """1/r of each node for a polar basis (None for Cartesian cells)."""
        kind, *spec = self.cells.nodes()
        if kind == "circles":
            center, radii, heights = spec
            return np.repeat(1.0 / radii, len(heights))
        if kind == "polar":
            center, radii, phis = spec
            return np.repeat(1.0 / radii, len(phis))
        return None
