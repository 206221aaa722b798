"""The channels of the per-frame cell sums, for cells of any dimension and basis: the one
place their layout is computed (the compiled kernels take their offsets from it).

A frame adds to every cell k and channel c the sum ``S[k, c] = sum_p w_pk Q_pc``
(:mod:`granavg.engine.kernels`). The channels come in blocks (:data:`BLOCK`), each
declared with its shape - a scalar, a vector (one channel per axis of the cells' basis),
a tensor (one per ordered pair of axes, first index the force or the deformation, second
the branch vector) or ``axial`` (the spin: a scalar about z in 2D, a vector in 3D) - and
the dump columns it reads. In the order of :data:`BLOCKS`:

=========  ==========================  ==========================================
block      channels                    Q_p
=========  ==========================  ==========================================
vol        vol                         V^p (pi h a^2 for a disk, 4/3 pi a^3 a sphere)
mass       mass                        m^p
mom        mom_<i>                     m^p v_i: the momentum
spin       spin (2D) or spin_<i> (3D)  m^p omega (omega_z in 2D, the vector in 3D)
ncontact   ncontact                    V^p C^p
fab        fab_<ij>                    V^p sum_c n_i n_j
sig        sig_<ij>                    sum_c f_i l_j
kin        kin_<ij>                    m^p v_i v_j
def        def_<ij>                    (V^p / a_p^2) sum_c Delta_i l_j
wall       wall_<i>                    the walls' forces (at the contact points)
body       body_<i>                    b^p (gravity, base-plate friction, ...)
dmass      dmass_<j>                   d_j of the mass sum (smoothing kernels only)
dmom       dmom_<ij>                   d_j of the mom_i sum
dsig       dsig_<i>                    sum_j d_j of the sig_ij sum
dkin       dkin_<i>                    sum_j d_j of the kin_ij sum
rinv       rinv                        V^p / r_k (r_k the node's radius in a polar basis)
ispin      ispin (2D) or ispin_<i>     I^p omega: the spin angular momentum
inertia    inertia                     I^p
erot       erot                        I^p |omega|^2 / 2
ekin       ekin                        m^p |v|^2 / 2
cst        cst_<j> (2D), cst_<ij>      sum_c l_j m_z (2D), sum_c l_i m_j (3D): m the
                                       contact couple (rolling, twisting resistance)
kcpl       kcpl_<j> (2D), kcpl_<ij>    v_j I^p omega_z (2D), v_i I^p omega_j (3D)
lever      lever (2D) or lever_<i>     sum_c (delta / 2) n x f: the moment a lever arm
                                       to the surface adds to one to the contact point
cnet       cnet (2D) or cnet_<i>       sum_c m: the contact couples on the particle
wcpl       wcpl (2D) or wcpl_<i>       the same over the walls' contacts alone
ppow       ppow                        sum_c f . (v + omega x l) + m . omega over the
                                       particles' contacts: the power they deliver
wpow       wpow                        the same over the walls' contacts
lpow       lpow                        sum_c ((delta / 2) n x f) . omega
bpow       bpow                        b^p . v: the body force's power
inter      inter_<i>                   a species' partners of other species' forces
                                       (at the contact points; species only)
ninter     ninter                      V^p C^p over the contacts with other species
fabinter   fabinter_<ij>               V^p sum n n over the contacts with other species
ma         ma_<i>                      F^p: the particle's total force (m a; the atoms'
                                       fx fy fz)
dtmass     dtmass                      d/dt of the mass sum (a time kernel's)
dtmom      dtmom_<i>                   d/dt of the mom_i sum (a time kernel's)
jmass      jmass_<i>                   m^p dx_i / dt: the mass flux of the displacements
                                       between consecutive frames, along their
                                       segments (a time kernel's; smoothing kernels)
djmass     djmass                      its divergence: m^p (W(x - x_p(t_f)) -
                                       W(x - x_p(t_f+1))) / dt, the segment's ends
djmom      djmom_<i>                   the divergence of m^p v_i dx_j / dt along the
                                       segment (the displacements' momentum flux, v at
                                       the interval's start), from its ends
impulse    impulse_<i>                 F^p at the interval's end frame (fix ave/atom:
                                       the mean force over the interval), there
=========  ==========================  ==========================================

I^p = k m^p a_p^2 with k = 1/2 for a disk and 2/5 for a sphere (``inertia``). The
``couple`` shape is a vector in 2D (the couple about z, one channel per branch axis)
and a tensor in 3D (first index the branch vector's, second the couple's).

For disks V^p / a_p^2 = pi h, the factor of Eq. 7; a sphere's is 4/3 pi a_p. The 2D
rings' layout, axes ``(r, phi)``, is the one granavg always had (``vol, mass, mom_r,
mom_phi, spin, ncontact, fab_rr, ...``). A new block is one entry here, appended, plus
the kernel code that fills it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

_XYZ = ("x", "y", "z")


@dataclass(frozen=True)
class Block:
    """One block of channels.

    Attributes
    ----------
    name : str
    shape : {"scalar", "vector", "tensor", "axial", "couple"}
    atoms : tuple of str
        The atom columns it reads besides positions and radii (``{v}`` stands for the
        velocity components of the dimension, ``{w}`` the spin's, ``{b}`` the body
        force's).
    contacts : tuple of str
        The contact columns it reads (``{n}`` the normal's components, ``{f}`` the
        normal and tangential forces', ``{m}`` the contact couple's); empty for blocks
        the contacts do not fill.
    optional : tuple of str
        Contact columns it may lack: taken as zero, and said so (the contact couple of
        a law without rolling resistance, or of dumps that do not hold it).
    spread : str
        How a smoothing kernel spreads it over its nodes (:data:`SPREADS`;
        :mod:`granavg.engine.smoothing.sums`).
    of : str
        The block it is spread from (a derivative's, the inverse radius'), or "".
    """

    name: str
    shape: str
    atoms: tuple = ()
    contacts: tuple = ()
    optional: tuple = ()
    spread: str = "particle"
    of: str = ""

    def size(self, dim: int) -> int:
        """Channels of the block in ``dim`` dimensions."""
        return {"scalar": 1, "vector": dim, "tensor": dim * dim,
                "axial": 1 if dim == 2 else dim,
                "couple": dim if dim == 2 else dim * dim}[self.shape]

    def atom_columns(self, dim: int) -> list:
        return _expand(self.atoms, dim)

    def contact_columns(self, dim: int) -> list:
        return _expand(self.contacts, dim)

    def optional_columns(self, dim: int) -> list:
        return _expand(self.optional, dim)


def _expand(names, dim) -> list:
    """Column names with ``{v}``, ``{w}``, ``{b}``, ``{n}``, ``{f}``, ``{a}`` spelled out
    for ``dim`` axes."""
    xyz = _XYZ[:dim]
    groups = {"{v}": [f"v{x}" for x in xyz],
              "{w}": ["omegaz"] if dim == 2 else [f"omega{x}" for x in xyz],
              "{b}": [f"b{x}" for x in xyz], "{n}": [f"n{x}" for x in xyz],
              "{a}": [f"f{x}" for x in xyz],
              "{f}": [f"fn{x}" for x in xyz] + [f"ft{x}" for x in xyz],
              "{m}": ["mz"] if dim == 2 else [f"m{x}" for x in xyz]}
    out = []
    for name in names:
        out += groups.get(name, [name])
    return out


_PAIRS = ("id1", "id2", "wall")
#: Every block, by name, in channel order.
BLOCK = {b.name: b for b in (
    Block("vol", "scalar"),
    Block("mass", "scalar"),
    Block("mom", "vector", ("{v}",)),
    Block("spin", "axial", ("{w}",)),
    Block("ncontact", "scalar", ("id",), _PAIRS),
    Block("fab", "tensor", ("id",), (*_PAIRS, "{n}")),
    Block("sig", "tensor", ("id",), (*_PAIRS, "{f}", "{n}", "overlap"), spread="segment"),
    Block("kin", "tensor", ("{v}",)),
    Block("def", "tensor", ("id",), (*_PAIRS, "{n}", "overlap")),
    Block("wall", "vector", ("id",), (*_PAIRS, "{f}", "{n}", "overlap"), spread="point"),
    Block("body", "vector", ("{b}",)),
    # the derivatives a smoothing kernel gives (granavg.engine.smoothing): d_j of the
    # mass and momentum sums, and the divergences d_j T_ij of the static and kinetic
    # stress sums, along the cells' basis (partial derivatives: the curvature terms of a
    # polar basis are added with the values)
    Block("dmass", "vector", spread="gradient", of="mass"),
    Block("dmom", "tensor", ("{v}",), spread="gradient", of="mom"),
    Block("dsig", "vector", ("id",), (*_PAIRS, "{f}", "{n}", "overlap"),
          spread="force_divergence", of="sig"),
    Block("dkin", "vector", ("{v}",), spread="divergence", of="kin"),
    # 1/r of the node, weighted as the volume (1/r = rinv / vol): the curvature terms of
    # a polar basis, from the sums alone
    Block("rinv", "scalar", spread="inverse_radius", of="vol"),
    # micropolar and energy fields (I = k m a^2 from the masses and radii)
    Block("ispin", "axial", ("{w}",)),
    Block("inertia", "scalar"),
    Block("erot", "scalar", ("{w}",)),
    Block("ekin", "scalar", ("{v}",)),
    Block("cst", "couple", ("id",), (*_PAIRS, "{n}", "overlap", "{m}"), ("{m}",)),
    Block("kcpl", "couple", ("{v}", "{w}")),
    Block("lever", "axial", ("id",), (*_PAIRS, "{f}", "{n}", "overlap")),
    Block("cnet", "axial", ("id",), (*_PAIRS, "{m}"), ("{m}",)),
    Block("wcpl", "axial", ("id",), (*_PAIRS, "{m}"), ("{m}",)),
    # powers (W): what the contacts deliver to each particle, f . (v + omega x l) +
    # m . omega (the particles' contacts, the walls'), the lever moment's, the body force's
    Block("ppow", "scalar", ("id", "{v}", "{w}"), (*_PAIRS, "{f}", "{n}", "overlap", "{m}"),
          ("{m}",)),
    Block("wpow", "scalar", ("id", "{v}", "{w}"), (*_PAIRS, "{f}", "{n}", "overlap", "{m}"),
          ("{m}",)),
    Block("lpow", "scalar", ("id", "{w}"), (*_PAIRS, "{f}", "{n}", "overlap")),
    Block("bpow", "scalar", ("{v}", "{b}")),
    # a species' share of a mixture (granavg.engine.species): the forces of the other
    # species' particles on its particles, at the contact points (as the walls')
    Block("inter", "vector", ("id",), (*_PAIRS, "{f}", "{n}", "overlap"), spread="point"),
    # ... and the share of its coordination and fabric that those contacts make
    Block("ninter", "scalar", ("id",), _PAIRS),
    Block("fabinter", "tensor", ("id",), (*_PAIRS, "{n}")),
    # the particles' total forces (LAMMPS' per-atom f): m a, the inertia every balance
    # law's forces add up to, frame by frame
    Block("ma", "vector", ("{a}",)),
    # time derivatives of the mass and momentum sums: no frame fills them, a time
    # kernel's derivative does (granavg.engine.timing), after the frames' channels
    Block("dtmass", "scalar"),
    Block("dtmom", "vector"),
    # the mass flux of the displacements between consecutive frames (the particles
    # paired by id) and its divergence: the time axis fills them from pairs of frames
    # (granavg.engine.smoothing.displacements), so that d rho/dt + div j = 0 holds
    # whatever happened between the frames
    Block("jmass", "vector", ("id",)),
    Block("djmass", "scalar", ("id",)),
    # ... and of the momentum: the divergence of the displacements' flux of m v (v at the
    # interval's start), and the forces dumped at the interval's end (LAMMPS' fix
    # ave/atom of fx fy fz over the interval: the exact impulse between the frames)
    Block("djmom", "vector", ("id", "{v}")),
    Block("impulse", "vector", ("id", "{a}")),
)}
#: How a smoothing kernel spreads a block over its nodes (:attr:`Block.spread`), each
#: with its weight: ``particle``, the particle's channel at its centre (W); ``segment``,
#: each contact's f (x) l along its branch segments (W's line integral); ``point``, each
#: contact's force at its contact point (W there); ``gradient``, d_j of the block ``of``
#: (dW); ``divergence``, d_j T_ij of the tensor ``of`` (dW); ``force_divergence``, d_j
#: of the segments' block ``of``: each particle's net contact force at its centre less
#: the points' forces (W), the partial derivatives; ``inverse_radius``, the block ``of``
#: times 1/r of the node (W).
SPREADS = ("particle", "segment", "point", "gradient", "divergence", "force_divergence",
           "inverse_radius")
#: Blocks only a smoothing kernel fills.
DERIVATIVE_BLOCKS = tuple(b.name for b in BLOCK.values()
                          if b.spread not in ("particle", "segment", "point"))
#: The blocks in channel order.
BLOCKS = tuple(BLOCK)
#: Blocks the time axis fills from its kernel's derivative (the last in channel order:
#: a frame's channels are the first of any layout's).
TIME_BLOCKS = ("dtmass", "dtmom", "jmass", "djmass", "djmom", "impulse")
#: The time blocks filled from pairs of consecutive frames (their displacements), in
#: channel order.
FLUX_BLOCKS = ("jmass", "djmass", "djmom", "impulse")
#: The blocks a frame fills.
FRAME_BLOCKS = tuple(b for b in BLOCKS if b not in TIME_BLOCKS)
#: Blocks that the particles' contacts fill in the contact pass (``wall`` is filled at
#: the contact points instead).
CONTACT_BLOCKS = ("ncontact", "fab", "sig", "def", "cst", "lever", "cnet", "wcpl", "ppow",
                  "wpow", "lpow")


def pairs(axes) -> tuple:
    """Tensor component names ``ij`` in channel order: rr, rphi, phir, phiphi for
    ``(r, phi)``; xx, xy, xz, yx, ... for ``(x, y, z)``."""
    return tuple(i + j for i in axes for j in axes)


#: Blocks every layout holds (the particles' volume and mass: cheap, and read by the
#: flags and several quantities).
ALWAYS = ("vol", "mass")


@dataclass(frozen=True)
class Layout:
    """Channel names and positions for cells whose basis has these axes, holding the
    ``blocks`` an average needs (all by default; :data:`ALWAYS` always).

    Attributes
    ----------
    axes : tuple of str
        The basis' axes: ``("r", "phi")`` (rings), ``("x", "y")``, ``("x", "y", "z")``
        or ``("r", "phi", "z")`` (cylindrical shells).
    blocks : tuple of str, optional
        The blocks held, in :data:`BLOCKS` order (default: every frame's,
        :data:`FRAME_BLOCKS`).
    offsets : tuple of int
        The first channel of each block, in :data:`BLOCKS` order (-1 for a block not
        held): what the compiled kernels index, for the blocks they are asked to fill.
    """

    axes: tuple
    blocks: tuple = None
    names: tuple = field(init=False)
    index: dict = field(init=False)
    offsets: tuple = field(init=False)

    def __post_init__(self):
        held = FRAME_BLOCKS if self.blocks is None else tuple(
            b for b in BLOCKS if b in self.blocks or b in ALWAYS)
        object.__setattr__(self, "blocks", held)
        names, first = [], []
        for b in BLOCK.values():
            if b.name not in held:
                first.append(-1)
                continue
            first.append(len(names))
            if b.shape in ("vector", "axial", "couple") and b.size(self.dim) == self.dim:
                names += [f"{b.name}_{i}" for i in self.axes]
            elif b.shape in ("tensor", "couple"):
                names += [f"{b.name}_{c}" for c in pairs(self.axes)]
            else:
                names.append(b.name)
        object.__setattr__(self, "names", tuple(names))
        object.__setattr__(self, "index", {n: k for k, n in enumerate(names)})
        object.__setattr__(self, "offsets", tuple(first))

    @property
    def dim(self) -> int:
        return len(self.axes)

    @property
    def n(self) -> int:
        """Number of channels."""
        return len(self.names)

    def first(self, block: str) -> int:
        """Column of the block's first channel."""
        if block not in self.blocks:
            raise KeyError(f"block {block!r} is not in this layout ({', '.join(self.blocks)})")
        return self.offsets[BLOCKS.index(block)]

    def block(self, S, block: str):
        """The block's columns of sums ``S`` (last axis the channels)."""
        k = self.first(block)
        return S[..., k:k + BLOCK[block].size(self.dim)]

    def spin_names(self) -> tuple:
        """Profile names of the spin: ``omega`` (2D, about z), ``omega_<i>`` (3D)."""
        return ("omega",) if self.dim == 2 else tuple(f"omega_{i}" for i in self.axes)


def stacked(S: np.ndarray, layout: Layout, blocks) -> np.ndarray:
    """The columns of the blocks of sums ``S`` that the layout holds, side by side."""
    held = [layout.block(S, b) for b in blocks if b in layout.blocks]
    return np.concatenate(held, axis=-1) if held else S[..., :0]
