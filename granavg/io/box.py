"""The simulation box a LAMMPS dump describes: orthogonal or triclinic (tilted).

A dump's ``ITEM: BOX BOUNDS`` gives, for a triclinic box, the *bounding* box of the
tilted cell and the tilt factors ``xy xz yz``; the cell itself is spanned by the edge
vectors a = (lx, 0, 0), b = (xy, ly, 0), c = (xz, yz, lz) from its corner (xlo, ylo,
zlo), with (LAMMPS' Howto_triclinic)

    xlo = xlo_bound - min(0, xy, xz, xy + xz),  xhi = xhi_bound - max(0, xy, xz, xy + xz)
    ylo = ylo_bound - min(0, yz),               yhi = yhi_bound - max(0, yz)

:class:`Box` gives the cell's own bounds (what cells that default to "the box" must
span: the slabs across z of a box tilted in xy have the cross-section lx ly, not that of
its bounding box), turns scaled coordinates into positions, and wraps positions along
its periodic axes: a tilted box into its brick (its own lengths from its lower corner),
which tiles space as the tilted cell does, the images of a row sliding by the tilt
(:class:`~granavg.engine.cells.base.Shear`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


#: A tilt factor within this fraction of the box's largest edge is round-off: none.
ROUND_OFF = 1e-12


@dataclass(frozen=True)
class Box:
    """The cell of a dump frame.

    Attributes
    ----------
    lo, hi : tuple of 3 float
        The cell's own bounds: ``hi - lo`` are its edge lengths lx, ly, lz.
    tilt : tuple of 3 float
        ``(xy, xz, yz)``; zeros for an orthogonal box.
    periodic : tuple of 3 bool
    """

    lo: tuple
    hi: tuple
    tilt: tuple = (0.0, 0.0, 0.0)
    periodic: tuple = (False, False, False)

    @classmethod
    def of(cls, frame) -> "Box":
        """The box of a :class:`~granavg.io.reader.DumpFrame` (bounds, tilt, flags)."""
        (xlo, xhi), (ylo, yhi), (zlo, zhi) = (tuple(map(float, b)) for b in frame.box)
        xy, xz, yz = (float(t) for t in getattr(frame, "tilt", (0.0, 0.0, 0.0)))
        # a tilt within round-off of the box's size is none (a box deformed from zero
        # tilt writes 1e-14 at its first frame): xy and xz shift x, yz shifts y
        size = max(abs(xhi - xlo), abs(yhi - ylo), abs(zhi - zlo), 1e-300)
        xy, xz, yz = (0.0 if abs(t) <= ROUND_OFF * size else t for t in (xy, xz, yz))
        if any((xy, xz, yz)):
            xlo -= min(0.0, xy, xz, xy + xz)
            xhi -= max(0.0, xy, xz, xy + xz)
            ylo -= min(0.0, yz)
            yhi -= max(0.0, yz)
        return cls((xlo, ylo, zlo), (xhi, yhi, zhi), (xy, xz, yz),
                   tuple(b == "pp" for b in frame.boundary))

    @property
    def tilted(self) -> bool:
        return any(t != 0.0 for t in self.tilt)

    @property
    def lengths(self) -> np.ndarray:
        return np.subtract(self.hi, self.lo)

    def bounds(self, dim: int) -> list:
        """(lo, hi) of the cell along each of the first ``dim`` axes."""
        return [(self.lo[k], self.hi[k]) for k in range(dim)]

    def matrix(self) -> np.ndarray:
        """The edge vectors a, b, c as columns, shape (3, 3): x = lo + H lamda."""
        (lx, ly, lz), (xy, xz, yz) = self.lengths, self.tilt
        return np.array([[lx, xy, xz], [0.0, ly, yz], [0.0, 0.0, lz]])

    def shifts(self, axis: int) -> tuple:
        """Which coordinates a step along each edge vector moves: the axes ``axis``'s
        coordinate changes with, through the tilt (x: b and c if xy, xz; y: c if yz)."""
        xy, xz, yz = self.tilt
        return {0: (xy, xz), 1: (yz,), 2: ()}[axis]

    def unscale(self, scaled: list, dim: int) -> list:
        """Positions from the scaled (fractional) coordinates of the first ``dim`` axes."""
        lam = np.zeros((3, len(scaled[0])))
        lam[:dim] = scaled
        x = np.asarray(self.lo)[:, None] + self.matrix() @ lam
        return [x[k] for k in range(dim)]

    def wrap(self, pos: list, dim: int) -> list:
        """Positions wrapped into the cell along its periodic axes (the first ``dim``);
        others are left where they are (an atom beyond a fixed boundary stays there). A
        tilted box wraps into its brick, its own lengths from its lower corner, which
        tiles space as its parallelepiped does: along the last axis first, a step along
        an edge vector moving the axes before it by the tilt."""
        axes = [k for k in range(dim) if self.periodic[k] and self.hi[k] > self.lo[k]]
        out = list(pos)
        H = self.matrix()
        for k in (reversed(axes) if self.tilted else axes):
            u, lo, hi = np.asarray(out[k], float), self.lo[k], self.hi[k]
            outside = (u < lo) | (u >= hi)
            if not outside.any():
                continue
            out[k] = np.where(outside, lo + np.mod(u - lo, hi - lo), u)
            steps = np.where(outside, np.floor((u - lo) / (hi - lo)), 0.0)
            for i in range(k):
                if H[i, k] != 0.0:
                    out[i] = np.asarray(out[i], float) - steps * H[i, k]
        return out
