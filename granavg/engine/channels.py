"""The channels of the per-frame cell sums, for cells of any dimension and basis.

A frame adds to every cell k and channel c the sum ``S[k, c] = sum_p w_pk Q_pc``
(:mod:`granavg.engine.kernels`). The channels come in blocks; vectors have one channel
per axis of the cells' basis, tensors one per ordered pair of axes (first index the
force or the deformation, second the branch vector), in the order of :class:`Layout`:

=========  ==========================  ==========================================
block      channels                    Q_p
=========  ==========================  ==========================================
vol        vol                         V^p (pi h a^2 for a disk, 4/3 pi a^3 a sphere)
mass       mass                        m^p
mom        mom_<i>                     V^p v_i
spin       spin (2D) or spin_<i> (3D)  V^p omega (omega_z in 2D, the vector in 3D)
ncontact   ncontact                    V^p C^p
fab        fab_<ij>                    V^p sum_c n_i n_j
sig        sig_<ij>                    sum_c f_i l_j
kin        kin_<ij>                    m^p v_i v_j
def        def_<ij>                    (V^p / a_p^2) sum_c Delta_i l_j
wall       wall_<i>                    the walls' forces (at the contact points)
body       body_<i>                    b^p (gravity, base-plate friction, ...)
=========  ==========================  ==========================================

For disks V^p / a_p^2 = pi h, the factor of Eq. 7; a sphere's is 4/3 pi a_p. The 2D
rings' layout, axes ``(r, phi)``, is the one granavg always had (``vol, mass, mom_r,
mom_phi, spin, ncontact, fab_rr, ...``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: The blocks in channel order.
BLOCKS = ("vol", "mass", "mom", "spin", "ncontact", "fab", "sig", "kin", "def", "wall",
          "body")
#: Blocks that are vectors and tensors (the rest are scalars, but ``spin`` in 3D).
VECTORS = ("mom", "wall", "body")
TENSORS = ("fab", "sig", "kin", "def")
#: Blocks the contacts fill.
CONTACT_BLOCKS = ("ncontact", "fab", "sig", "def")


def pairs(axes) -> tuple:
    """Tensor component names ``ij`` in channel order: rr, rphi, phir, phiphi for
    ``(r, phi)``; xx, xy, xz, yx, ... for ``(x, y, z)``."""
    return tuple(i + j for i in axes for j in axes)


@dataclass(frozen=True)
class Layout:
    """Channel names and positions for cells whose basis has these axes.

    Attributes
    ----------
    axes : tuple of str
        The basis' axes: ``("r", "phi")`` (rings), ``("x", "y")``, ``("x", "y", "z")``
        or ``("r", "phi", "z")`` (cylindrical shells).
    """

    axes: tuple
    names: tuple = field(init=False)
    index: dict = field(init=False)
    offsets: np.ndarray = field(init=False)

    def __post_init__(self):
        names, first = [], {}
        for b in BLOCKS:
            first[b] = len(names)
            if b in VECTORS or (b == "spin" and self.dim == 3):
                names += [f"{b}_{i}" for i in self.axes]
            elif b in TENSORS:
                names += [f"{b}_{c}" for c in pairs(self.axes)]
            else:
                names.append(b)
        object.__setattr__(self, "names", tuple(names))
        object.__setattr__(self, "index", {n: k for k, n in enumerate(names)})
        object.__setattr__(self, "offsets", np.array([first[b] for b in BLOCKS], np.int64))

    @property
    def dim(self) -> int:
        return len(self.axes)

    @property
    def n(self) -> int:
        """Number of channels."""
        return len(self.names)

    def first(self, block: str) -> int:
        """Column of the block's first channel."""
        return int(self.offsets[BLOCKS.index(block)])

    def block(self, S, block: str):
        """The block's columns of sums ``S`` (last axis the channels)."""
        k = self.first(block)
        size = {**{b: self.dim for b in VECTORS}, **{b: self.dim**2 for b in TENSORS},
                "spin": self.dim if self.dim == 3 else 1}.get(block, 1)
        return S[..., k:k + size]

    def spin_names(self) -> tuple:
        """Profile names of the spin: ``omega`` (2D, about z), ``omega_<i>`` (3D)."""
        return ("omega",) if self.dim == 2 else tuple(f"omega_{i}" for i in self.axes)
