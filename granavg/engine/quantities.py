"""What can be averaged: each quantity one :class:`Quantity` of :data:`QUANTITIES`,
declaring the channel blocks it needs (and through them the dump columns, and whether the
contacts are needed), its profile columns in any basis and how its values come from the
time-averaged cell sums (Eqs. 2-7). Its errors come from the same function applied to
the sums of time blocks and sectors (:mod:`granavg.engine.profiles`,
:mod:`granavg.engine.uncertainty.structure`). numpy only, no compiled code: a caller
can decide what to read or simulate (e.g. whether contacts are needed) without the
engine's kernels.

Profile columns are named in the cells' basis (:func:`columns`): ``v_r, v_phi`` and
tensors ``rr, rphi, phir, phiphi`` (first index the force or the deformation, second the
branch vector) for rings; ``x, y`` and ``xx, xy, yx, yy`` for 2D slabs and grids; three
axes in 3D (``x, y, z``, or ``r, phi, z`` for cylindrical shells).

What a set of quantities needs of the data (columns, contacts, body forces) is
:mod:`granavg.engine.requirements`. A new quantity is one entry of :data:`QUANTITIES`,
plus a block of :mod:`granavg.engine.channels` and its kernel code only if it needs new
per-particle or per-contact sums (docs/extending.md).
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass
from typing import Callable

import numpy as np

from granavg.engine.channels import BLOCK, pairs

#: Tensor components of the 2D rings (the paper's), in channel order.
TENSOR = pairs(("r", "phi"))


@dataclass(frozen=True)
class Quantity:
    """One quantity.

    Attributes
    ----------
    name : str
        Its name in ``quantities`` and the prefix of its profile columns.
    blocks : tuple of str
        The channel blocks its values need (:data:`granavg.engine.channels.BLOCK`).
    shape : {"scalar", "vector", "tensor", "axial", "couple"}
        How its columns are named in a basis (:func:`columns`; ``couple``: a vector in
        2D, a tensor in 3D).
    value : callable
        ``value(S, V, layout) -> dict of column -> ndarray (n_cells,)`` from the mean
        cell sums ``S`` (n_cells, n_channels) and the cell volumes ``V``.
    unit : str
        Its physical dimension, in the named units of a unit system
        (:meth:`granavg.engine.unit_system.UnitSystem.unit`): ``"{force}/{length}^3"``,
        ``"1/{time}"``, ``"1"`` for a pure number; its unit follows in any system.
    needs_mass : bool
        Its values need the particles' masses (a mass column or a material density).
    balanced : callable, optional
        ``balanced(axes, across) -> set of column names`` the balance of forces fixes in
        a whole cell (their errors come from time alone; :data:`BALANCED`).
    flag : callable, optional
        ``flag(S, layout) -> ndarray of bool (n_cells,)``: cells where its value is
        undefined, flagged with :attr:`flag_name`.
    flag_name : str
    smooth : bool
        It needs a smoothing kernel with a continuous edge (its values are derivatives
        of the coarse-grained fields, :mod:`granavg.engine.smoothing`).
    in_time : bool
        It needs a time kernel (its values are time derivatives of the fields smoothed
        in time, :mod:`granavg.engine.timing`).
    species : bool
        It is defined for a species of a mixture (:mod:`granavg.engine.species`): the
        forces between species.
    phases : bool
        Its values come from the frames' interleaved phases, which the averager keeps
        for it (:class:`~granavg.engine.cell_average.Phase`): the time quadrature's
        error of a balance law, estimated from the data; ``value`` gives NaN.
    by_name : bool
        Computed only where asked for by name, not among "all the data allow": a
        diagnostic whose cost is its own (the displacements' mass flux along their
        segments: 1.2 times the time of fields in time with the balance laws), or one
        that means what it says only for some dumps (the momentum between frames: with
        the forces' means over each interval, not the instantaneous forces).
    help : str
        What it is, in words (the command line's help).
    """

    name: str
    blocks: tuple
    shape: str
    value: Callable
    _: KW_ONLY
    unit: str
    needs_mass: bool = False
    balanced: Callable | None = None
    flag: Callable | None = None
    flag_name: str = ""
    smooth: bool = False
    in_time: bool = False
    species: bool = False
    phases: bool = False
    by_name: bool = False
    help: str = ""

    @property
    def contacts(self) -> bool:
        """Whether it needs the contacts."""
        return any(BLOCK[b].contacts for b in self.blocks)

    def columns(self, axes) -> list:
        return columns(self.name, axes)


def columns(group: str, axes) -> list:
    """Profile columns of a quantity in a basis with these axes (``v_r, v_phi`` for
    rings, ``v_x, v_y, v_z`` for 3D boxes, ...)."""
    shape = QUANTITIES[group].shape
    if shape == "scalar" or (shape == "axial" and len(axes) == 2):
        return [group]
    if shape in ("vector", "axial") or (shape == "couple" and len(axes) == 2):
        return [f"{group}_{i}" for i in axes]
    return [f"{group}_{c}" for c in pairs(axes)]


def _inverse_volume(S, layout):
    vol = S[:, layout.index["vol"]]
    return np.where(vol > 0, 1.0 / vol, np.nan)


def _inverse_mass(S, layout):
    mass = S[:, layout.index["mass"]]
    return np.where(mass > 0, 1.0 / mass, np.nan)


def _per_mass_of_particles(block):
    """Columns of a block over the particles' mass in the cell: the mass-weighted means
    (v = <m^p v> / <m^p>, so that rho v is the momentum density; Eq. 3's volume weights
    for a single material density)."""
    def value(S, V, layout, name):
        inv_mass = _inverse_mass(S, layout)
        part = layout.block(S, block)
        return {n: part[:, k] * inv_mass for k, n in enumerate(columns(name, layout.axes))}
    return value


def _per_cell_volume(block):
    """Columns of a block over the cell's volume (F, sigma, force densities)."""
    def value(S, V, layout, name):
        part = layout.block(S, block)
        return {n: part[:, k] / V for k, n in enumerate(columns(name, layout.axes))}
    return value


def _ratio(block, name):
    def value(S, V, layout, _name):
        return {name: S[:, layout.index[block]] / V}
    return value


def _coordination_of(block):
    """Contacts per particle from a block of V^p x count sums."""
    def value(S, V, layout, name):
        return {name: S[:, layout.index[block]] * _inverse_volume(S, layout)}
    return value


_coordination = _coordination_of("ncontact")


def _fluctuation(S, V, layout, name):
    """(sum m v v - rho v v) / V: the kinetic stress about the cell's mean flow (v
    mass-weighted, so that sum m v v - m_cell v v is the fluctuations' own)."""
    inv_mass = _inverse_mass(S, layout)
    mom, kin, D = layout.block(S, "mom"), layout.block(S, "kin"), layout.dim
    out = {}
    for k, n in enumerate(columns(name, layout.axes)):
        a, b = mom[:, k // D], mom[:, k % D]
        out[n] = (kin[:, k] - a * b * inv_mass) / V          # rho v v = P P / M
    return out


def _singular(S, layout):
    """Cells whose fabric cannot be inverted (eps undefined)."""
    D = layout.dim
    fab = layout.block(S, "fab").reshape(-1, D, D)
    det = np.linalg.det(fab)
    scale = np.einsum("kij,kij->k", fab, fab)
    return ~(np.abs(det) > 1e-12 * scale ** (D / 2))


def _eps(S, V, layout, name):
    """eps = ((V^p/a^2) sum Delta (x) l) . (sum V^p n (x) n)^-1 per cell (Eq. 7)."""
    D = layout.dim
    fab = layout.block(S, "fab").reshape(-1, D, D)
    dfm = layout.block(S, "def").reshape(-1, D, D)
    ok = ~_singular(S, layout)
    eps = np.full(dfm.shape, np.nan)
    if np.any(ok):
        eps[ok] = dfm[ok] @ np.linalg.inv(fab[ok])
    return {f"{name}_{c}": eps.reshape(-1, D * D)[:, k]
            for k, c in enumerate(pairs(layout.axes))}


def _flagged_cells(S, layout):
    """The per-cell flag of the singular fabric, for each cell: |det| not above 1e-12
    of the fabric's size to the power D."""
    D = layout.dim
    fab = layout.block(S, "fab").reshape(-1, D, D)
    det, scale = np.linalg.det(fab), np.sum(fab ** 2, axis=(1, 2))
    return ~(np.abs(det) > 1e-12 * scale ** (D / 2))


def _across_components(axes, across):
    """The stress components with an index across the cells (rr, rphi, phir for rings):
    the tractions on the cells' own faces, fixed by the balance of forces in a cell."""
    return {f"sigma_{i}{j}" for i in axes for j in axes if across in (i, j)}


def _all_components(axes, across):
    return set(columns("boundary", axes))


def _values(fn, name):
    return lambda S, V, layout: fn(S, V, layout, name)


def _curvature(S, layout):
    """1/r of each node in a polar basis (the ``rinv`` block over ``vol``), else None."""
    if layout.axes[:2] != ("r", "phi"):
        return None
    return S[:, layout.index["rinv"]] * _inverse_volume(S, layout)


def _gradient(S, layout):
    """L_ij = d v_i / d x_j at each node, shape (n, D, D), from the kernel's derivatives:
    v = P / M (P, M the momentum and mass sums), d_j v_i = (d_j P_i - v_i d_j M) / M,
    plus in a polar basis the curvature terms L_rphi -= v_phi / r, L_phiphi += v_r / r."""
    D = layout.dim
    inv_mass = _inverse_mass(S, layout)
    v = layout.block(S, "mom") * inv_mass[:, None]
    dP = layout.block(S, "dmom").reshape(-1, D, D)
    dM = layout.block(S, "dmass")
    L = (dP - v[:, :, None] * dM[:, None, :]) * inv_mass[:, None, None]
    rinv = _curvature(S, layout)
    if rinv is not None:
        L[:, 0, 1] -= v[:, 1] * rinv
        L[:, 1, 1] += v[:, 0] * rinv
    return L


def _tensor_columns(T, layout, name):
    D = layout.dim
    return {f"{name}_{c}": T.reshape(-1, D * D)[:, k] for k, c in enumerate(pairs(layout.axes))}


def _gradv(S, V, layout, name):
    return _tensor_columns(_gradient(S, layout), layout, name)


def _rate(S, V, layout, name):
    """D = (L + L^T) / 2 (Eq. 13)."""
    L = _gradient(S, layout)
    return _tensor_columns(0.5 * (L + np.swapaxes(L, 1, 2)), layout, name)


def _spin_rate(S, V, layout, name):
    """W_ij = (L_ji - L_ij) / 2: W_rphi = (dv_phi/dr + v_phi/r) / 2 for a flow v_phi(r),
    the rotation rate, equal to Omega in a rigid rotation (Eq. 14's sign)."""
    L = _gradient(S, layout)
    return _tensor_columns(0.5 * (np.swapaxes(L, 1, 2) - L), layout, name)


def _div(S, V, layout, block, div_block):
    """(div T)_i = sum_j d_j T_ij per node volume, shape (n, D): the kernel's partial
    derivatives, plus in a polar basis the curvature terms (T_rr - T_phiphi)/r,
    (T_rphi + T_phir)/r and, in 3D, T_zr / r."""
    D = layout.dim
    div = layout.block(S, div_block) / V[:, None]
    rinv = _curvature(S, layout)
    if rinv is not None:
        T = (layout.block(S, block) / V[:, None]).reshape(-1, D, D)
        div = div.copy()
        div[:, 0] += (T[:, 0, 0] - T[:, 1, 1]) * rinv
        div[:, 1] += (T[:, 0, 1] + T[:, 1, 0]) * rinv
        if D == 3:
            div[:, 2] += T[:, 2, 0] * rinv
    return div


def _divergence(block, div_block):
    """The columns of :func:`_div`."""
    def value(S, V, layout, name):
        div = _div(S, V, layout, block, div_block)
        return {n: div[:, k] for k, n in enumerate(columns(name, layout.axes))}
    return value


def _continuity(S, V, layout, name):
    """d rho/dt + div j at each node, j the mass flux of the displacements between
    frames (:mod:`granavg.engine.smoothing.displacements`): zero to round-off at any
    frame interval by summation by parts
    (:meth:`~granavg.engine.timing.axes.Smoothed.flux_hits`), but where particles
    appear or vanish between frames (a source)."""
    return {name: (S[:, layout.index["dtmass"]] + S[:, layout.index["djmass"]]) / V}


def _continuity_v(S, V, layout, name):
    """d rho/dt + div(rho v) at each node, rho v from the dumped velocities: the time
    kernel's derivative of the mass sum plus the divergence of the momentum sum (its
    trace, and P_r / r in a polar basis); zero up to the time quadrature of the frames,
    which misses by the collisions it does not resolve."""
    D = layout.dim
    div = np.trace(layout.block(S, "dmom").reshape(-1, D, D), axis1=1, axis2=2)
    rinv = _curvature(S, layout)
    if rinv is not None:
        div = div + layout.block(S, "mom")[:, 0] * rinv
    return {name: (S[:, layout.index["dtmass"]] + div) / V}


def _impulse_balance(S, V, layout, name):
    """d(rho v)/dt + div j_p - F at each node: the momentum's change between frames (the
    time kernel's derivative of the momentum sums, the displacements' momentum flux)
    against the forces dumped at each interval's end, weighed as the displacements'
    flux is (:meth:`~granavg.engine.timing.axes.Smoothed.flux_hits`). Zero, whatever
    happened between the frames, where those forces are the interval's means (LAMMPS'
    fix ave/atom): they then carry the exact impulse; with instantaneous forces it
    misses by the collisions the frames do not resolve."""
    res = (layout.block(S, "dtmom") + layout.block(S, "djmom") -
           layout.block(S, "impulse")) / V[:, None]
    return {n: res[:, k] for k, n in enumerate(columns(name, layout.axes))}


def _momentum_balance(S, V, layout, name):
    """d(rho v)/dt - div(sigma - dsigma) - b - t at each node (dsigma = sum m v v, the
    momentum flux; b, t the body and boundary force densities where the average holds
    them): zero up to the time quadrature of the frames."""
    res = layout.block(S, "dtmom") / V[:, None] - _div(S, V, layout, "sig", "dsig") \
        + _div(S, V, layout, "kin", "dkin")
    for force in ("body", "wall", "inter"):
        if force in layout.blocks:
            res = res - layout.block(S, force) / V[:, None]
    return {n: res[:, k] for k, n in enumerate(columns(name, layout.axes))}


#: The blocks of the momentum balance in time (and of its quadrature error's estimate).
_MOMENTUM_BLOCKS = ("vol", "mass", "mom", "sig", "dsig", "kin", "dkin", "rinv", "dtmom")


def _from_phases(S, V, layout, name):
    """NaN: the averager fills these from the frames' phases (``phases``)."""
    return {name: np.full(len(V), np.nan)}


def _granular_temperature(S, V, layout, name):
    """T = tr(sum m v v - m_cell v v) / (D m_cell): the kinetic energy of the velocity
    fluctuations about the cell's mean flow per mass and degree of freedom (v the
    mass-weighted mean velocity), m^2/s^2 in SI."""
    D = layout.dim
    mass = S[:, layout.index["mass"]]
    mom, kin = layout.block(S, "mom"), layout.block(S, "kin")
    trace = sum(kin[:, k * D + k] for k in range(D))
    with np.errstate(invalid="ignore", divide="ignore"):
        return {name: (trace - np.sum(mom * mom, axis=1) / mass) / (D * mass)}


def _rotational_temperature(S, V, layout, name):
    """T_rot = (sum I |omega|^2 - |sum I omega|^2 / sum I) / (n_rot m_cell): the energy
    of the spins' fluctuations about the cell's inertia-weighted mean spin, per mass and
    rotational degree of freedom (n_rot = 1 in 2D, 3 in 3D), m^2/s^2 in SI."""
    D = layout.dim
    mass, inertia = S[:, layout.index["mass"]], S[:, layout.index["inertia"]]
    spin = layout.block(S, "ispin")
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.sum(spin * spin, axis=1) / inertia
        return {name: (2.0 * S[:, layout.index["erot"]] - mean) / ((1 if D == 2 else 3) * mass)}


#: Every quantity, by name.
QUANTITIES = {q.name: q for q in (
    Quantity("nu", ("vol",), "scalar", _values(_ratio("vol", "nu"), "nu"),
             unit="1", help="volume fraction, Eq. 2"),
    Quantity("rho", ("vol", "mass"), "scalar", _values(_ratio("mass", "rho"), "rho"),
             needs_mass=True, unit="{mass}/{length}^3", help="density"),
    Quantity("v", ("vol", "mass", "mom"), "vector", _values(_per_mass_of_particles("mom"), "v"),
             unit="{length}/{time}", help="velocity (mass-weighted; Eq. 3 for one material)"),
    Quantity("omega", ("vol", "mass", "spin"), "axial",
             _values(_per_mass_of_particles("spin"), "omega"),
             unit="rad/{time}",
             help="spin (mass-weighted)"),
    Quantity("coordination", ("vol", "ncontact"), "scalar",
             _values(_coordination, "coordination"), unit="1", help="contacts per particle"),
    Quantity("F", ("fab",), "tensor", _values(_per_cell_volume("fab"), "F"),
             unit="1", help="fabric, Eq. 4"),
    Quantity("coordination_inter", ("vol", "ninter"), "scalar",
             _values(_coordination_of("ninter"), "coordination_inter"), species=True,
             unit="1", help="a species' contacts per particle with particles of the other "
                            "species (with its own: coordination less these)"),
    Quantity("F_inter", ("fabinter",), "tensor", _values(_per_cell_volume("fabinter"),
                                                         "F_inter"), species=True,
             unit="1", help="a species' fabric of its contacts with the other species (of "
                            "those with its own: F less this)"),
    Quantity("sigma", ("sig",), "tensor", _values(_per_cell_volume("sig"), "sigma"),
             balanced=_across_components, unit="{stress}", help="static stress, Eq. 5"),
    Quantity("dsigma", ("kin",), "tensor", _values(_per_cell_volume("kin"), "dsigma"),
             needs_mass=True, unit="{momentum_flux}", help="dynamic stress, Eq. 6"),
    Quantity("dsigma_fluct", ("vol", "mass", "mom", "kin"), "tensor",
             _values(_fluctuation, "dsigma_fluct"), needs_mass=True,
             unit="{momentum_flux}", help="kinetic stress about the mean flow"),
    Quantity("eps", ("fab", "def"), "tensor", _values(_eps, "eps"), flag=_flagged_cells,
             flag_name="singular_fabric", unit="1", help="elastic strain, Eq. 7"),
    Quantity("boundary", ("wall",), "vector", _values(_per_cell_volume("wall"), "boundary"),
             balanced=_all_components,
             unit="{force}/{length}^3",
             help="force density of the walls"),
    Quantity("f_inter", ("inter",), "vector", _values(_per_cell_volume("inter"), "f_inter"),
             balanced=_all_components, species=True, unit="{force}/{length}^3",
             help="force density on a species from the particles of the others, at the "
                  "contact points (zero for the whole mixture)"),
    Quantity("ma", ("ma",), "vector", _values(_per_cell_volume("ma"), "ma"),
             unit="{force}/{length}^3",
             help="the particles' total forces (m a, the atoms' fx fy fz) as a force "
                  "density: what the stress divergence and the force densities add up to, "
                  "frame by frame"),
    Quantity("body", ("body",), "vector", _values(_per_cell_volume("body"), "body"),
             unit="{force}/{length}^3",
             help="body force density: gravity, base-plate friction, a force column"),
    Quantity("gradv", ("vol", "mass", "mom", "dmass", "dmom", "rinv"), "tensor",
             _values(_gradv, "gradv"), smooth=True,
             unit="1/{time}", help="velocity gradient d v_i / d x_j (smoothing kernels only)"),
    Quantity("D", ("vol", "mass", "mom", "dmass", "dmom", "rinv"), "tensor", _values(_rate, "D"),
             smooth=True,
             unit="1/{time}",
             help="deformation rate, Eq. 13 (smoothing kernels only)"),
    Quantity("W", ("vol", "mass", "mom", "dmass", "dmom", "rinv"), "tensor",
             _values(_spin_rate, "W"), smooth=True,
             unit="1/{time}", help="rotation rate, Eq. 14 (smoothing kernels only)"),
    Quantity("divsigma", ("vol", "sig", "dsig", "rinv"), "vector",
             _values(_divergence("sig", "dsig"), "divsigma"), smooth=True,
             unit="{stress}/{length}",
             help="divergence of the static stress (smoothing kernels only)"),
    Quantity("divdsigma", ("vol", "kin", "dkin", "rinv"), "vector",
             _values(_divergence("kin", "dkin"), "divdsigma"), needs_mass=True, smooth=True,
             unit="{momentum_flux}/{length}",
             help="divergence of the dynamic stress (smoothing kernels only)"),
    # fields in time (granavg.engine.timing): time derivatives and balance laws
    Quantity("drho_dt", ("vol", "mass", "dtmass"), "scalar",
             _values(_per_cell_volume("dtmass"), "drho_dt"), needs_mass=True,
             in_time=True, unit="{mass}/{length}^3/{time}",
             help="d rho / dt (time kernels only)"),
    Quantity("dmomentum_dt", ("vol", "mass", "mom", "dtmom"), "vector",
             _values(_per_cell_volume("dtmom"), "dmomentum_dt"), needs_mass=True,
             in_time=True, unit="{momentum_flux}/{length}",
             help="d(rho v) / dt (time kernels only)"),
    Quantity("mass_flux", ("vol", "mass", "jmass"), "vector",
             _values(_per_cell_volume("jmass"), "mass_flux"), needs_mass=True, smooth=True,
             in_time=True, by_name=True, unit="{mass}/{length}^2/{time}",
             help="mass flux of the displacements between frames (rho v where the frames "
                  "resolve the motion; smoothing and time kernels, atoms' ids)"),
    Quantity("continuity", ("vol", "mass", "dtmass", "djmass"),
             "scalar", _values(_continuity, "continuity"), needs_mass=True, smooth=True,
             in_time=True, unit="{mass}/{length}^3/{time}",
             help="the continuity residual d rho/dt + div j, j the displacements' mass "
                  "flux: zero at any frame interval (smoothing and time kernels, atoms' "
                  "ids)"),
    Quantity("impulse_balance", ("vol", "mass", "mom", "dtmom", "djmom", "impulse"),
             "vector", _values(_impulse_balance, "impulse_balance"), needs_mass=True,
             smooth=True, in_time=True, by_name=True, unit="{momentum_flux}/{length}",
             help="d(rho v)/dt + div j_p - F: the momentum's change between frames against "
                  "the forces dumped at each interval's end, zero where they are fix "
                  "ave/atom means over the interval (smoothing and time kernels, atoms' "
                  "ids and fx fy [fz])"),
    Quantity("continuity_v", ("vol", "mass", "mom", "dmass", "dmom", "rinv", "dtmass"),
             "scalar", _values(_continuity_v, "continuity_v"), needs_mass=True, smooth=True,
             in_time=True, unit="{mass}/{length}^3/{time}",
             help="d rho/dt + div(rho v) with the dumped velocities: how far frames at "
                  "this interval resolve the motion (smoothing and time kernels)"),
    Quantity("momentum_balance", _MOMENTUM_BLOCKS, "vector",
             _values(_momentum_balance, "momentum_balance"), needs_mass=True, smooth=True,
             in_time=True, unit="{momentum_flux}/{length}",
             help="the momentum balance's residual d(rho v)/dt - div(sigma - dsigma) - b "
                  "- t (smoothing and time kernels)"),
    Quantity("momentum_quadrature", _MOMENTUM_BLOCKS, "scalar",
             _values(_from_phases, "momentum_quadrature"), needs_mass=True, smooth=True,
             in_time=True, phases=True, unit="{momentum_flux}/{length}",
             help="the time quadrature's error of momentum_balance at the frames' interval, "
                  "estimated from the data: half the difference of the residuals of the "
                  "even and odd frames (smoothing and time kernels)"),
    Quantity("momentum_quadrature_2h", _MOMENTUM_BLOCKS, "scalar",
             _values(_from_phases, "momentum_quadrature_2h"), needs_mass=True, smooth=True,
             in_time=True, phases=True, unit="{momentum_flux}/{length}",
             help="the same at twice the frames' interval (every fourth frame's residuals): "
                  "how the error grows with the interval"),
    # micropolar fields (granavg.analysis.spin_balance) and energy
    Quantity("mu", ("cst",), "couple", _values(_per_cell_volume("cst"), "mu"),
             unit="{force}/{length}",
             help="couple stress of the contact couples, sum l m / V (first index the "
                  "branch vector's)"),
    Quantity("dmu", ("kcpl",), "couple", _values(_per_cell_volume("kcpl"), "dmu"),
             needs_mass=True,
             unit="{couple_flux}",
             help="flux of spin angular momentum, sum v I omega / V"),
    Quantity("spin_density", ("ispin",), "axial",
             _values(_per_cell_volume("ispin"), "spin_density"), needs_mass=True,
             unit="{mass}/({length} {time})",
             help="angular momentum density of the spins, sum I omega / V"),
    Quantity("lever", ("lever",), "axial", _values(_per_cell_volume("lever"), "lever"),
             unit="{stress}",
             help="moment density (delta/2) n x f that a lever arm to the particle's "
                  "surface (pair gran/*) adds to one to the contact point"),
    Quantity("couple_density", ("cnet",), "axial",
             _values(_per_cell_volume("cnet"), "couple_density"),
             unit="{stress}",
             help="net contact couple on the particles, sum m / V: what the couple "
                  "stress's divergence stands for in a cell"),
    Quantity("boundary_couple", ("wcpl",), "axial",
             _values(_per_cell_volume("wcpl"), "boundary_couple"),
             unit="{stress}", help="the walls' contact couples on the particles, per volume"),
    Quantity("contact_power", ("ppow",), "scalar",
             _values(_ratio("ppow", "contact_power"), "contact_power"),
             unit="{force}/({length}^2 {time})",
             help="power the particles' contacts deliver, sum f.(v + omega x l) + m.omega "
                  "/ V: in a steady state's time average minus their dissipation rate"),
    Quantity("wall_power", ("wpow",), "scalar",
             _values(_ratio("wpow", "wall_power"), "wall_power"),
             unit="{force}/({length}^2 {time})",
             help="power the walls' contacts deliver to the particles"),
    Quantity("lever_power", ("lpow",), "scalar",
             _values(_ratio("lpow", "lever_power"), "lever_power"),
             unit="{force}/({length}^2 {time})",
             help="power of the lever moment (delta/2) n x f (pair gran/* styles)"),
    Quantity("body_power", ("body", "bpow"), "scalar",
             _values(_ratio("bpow", "body_power"), "body_power"),
             unit="{force}/({length}^2 {time})",
             help="power of the body forces, sum b.v / V (minus the base plate's "
                  "dissipation rate)"),
    Quantity("ekin", ("ekin",), "scalar", _values(_ratio("ekin", "ekin"), "ekin"),
             needs_mass=True, unit="{momentum_flux}", help="translational kinetic energy density"),
    Quantity("erot", ("erot",), "scalar", _values(_ratio("erot", "erot"), "erot"),
             needs_mass=True, unit="{momentum_flux}", help="rotational kinetic energy density"),
    Quantity("temperature", ("vol", "mass", "mom", "kin"), "scalar",
             _values(_granular_temperature, "temperature"), needs_mass=True,
             unit="({length}/{time})^2", help="translational granular temperature"),
    Quantity("temperature_rot", ("mass", "ispin", "inertia", "erot"), "scalar",
             _values(_rotational_temperature, "temperature_rot"), needs_mass=True,
             unit="({length}/{time})^2", help="rotational granular temperature"),
)}


#: granavg's own quantities (:func:`register` adds others).
BUILT_IN = tuple(QUANTITIES)

#: What the balance of forces fixes in a whole cell: the tractions on the cell's own
#: faces. A cell's summed stress is the traction on its boundary, and the components
#: with the normal across the cells (rr, phir and, the static stress being symmetric,
#: rphi for rings: the radial force and the torque through a circle) are the same for
#: every sector of it; so is the walls' force on a cell at a wall (``boundary``: the
#: traction on its wall face). Sectors differ there only by the tractions on their
#: cuts, which cancel in the cell, so their spread is no measure of the cell's frozen
#: disorder (measured: it overstates the spread between realisations 3-5 times,
#: docs/errors.md), and a balance law that holds in every packing would get the cuts'
#: noise as its error. These get errors from time alone, lower bounds: a packing's
#: frozen pressure and torque are global, the same in every sector, and only
#: realisations sample them.
BALANCED = tuple(q for q, spec in QUANTITIES.items() if spec.balanced is not None)


def balanced_names(groups, axes, across: str) -> set:
    """Profile names that the balance of forces fixes in a whole cell (:data:`BALANCED`),
    ``across`` the direction across the cells (one of ``axes``)."""
    out = set()
    for g in groups:
        if QUANTITIES[g].balanced is not None:
            out |= QUANTITIES[g].balanced(axes, across)
    return out


#: How a quantity's columns are named in a basis (:func:`columns`).
SHAPES = ("scalar", "vector", "tensor", "axial", "couple")


def contract(q: Quantity) -> None:
    """What a quantity must declare (``ValueError`` with the reason): a name that is an
    identifier; channel blocks that exist; a shape; a unit written in a unit system's
    named units; a help text."""
    from granavg.engine.unit_system import SI

    if not q.name.isidentifier():
        raise ValueError(f"its name {q.name!r} must be an identifier (a column prefix)")
    unknown = [b for b in q.blocks if b not in BLOCK]
    if unknown:
        raise ValueError(f"block {unknown[0]!r} is not a channel block "
                         f"(granavg.engine.channels: {', '.join(BLOCK)})")
    if q.shape not in SHAPES:
        raise ValueError(f"shape {q.shape!r}: choose from {', '.join(SHAPES)}")
    try:
        SI.unit(q.unit)
    except (KeyError, IndexError, ValueError) as exc:
        raise ValueError(f"unit {q.unit!r} is not written in a unit system's named units "
                         f"({{length}}, {{time}}, {{mass}}, {{force}}, {{stress}}, ...): "
                         f"{exc}") from None
    if not q.help:
        raise ValueError("it needs a help text (what it is, in words)")


def register(q: Quantity) -> Quantity:
    """Add a quantity of your own (checked against :func:`contract`); returns it."""
    if q.name in QUANTITIES:
        raise ValueError(f"quantity {q.name!r} exists")
    try:
        contract(q)
    except ValueError as exc:
        raise ValueError(f"quantity {q.name!r} breaks its contract: {exc}") from None
    QUANTITIES[q.name] = q
    return q


def unregister(name: str) -> None:
    """Remove a quantity added with :func:`register`."""
    if name in BUILT_IN:
        raise ValueError(f"{name!r} is one of granavg's own quantities")
    QUANTITIES.pop(name, None)


def quantity_of(column: str):
    """The quantity a profile column (value or ``_sem``) belongs to: the one with the
    longest name it starts with (``dsigma_fluct_rr`` -> dsigma_fluct); None for the
    cells' own columns."""
    name = column[:-4] if column.endswith("_sem") else column
    found = [q for q in QUANTITIES if name == q or name.startswith(q + "_")]
    return QUANTITIES[max(found, key=len)] if found else None


#: Units of the columns every table has besides its cells' coordinates and quantities.
CELL_COLUMNS = {"V": "{length}^3", "n_frames": "1", "n_runs": "1"}


def column_units(columns, system, coordinates: dict) -> dict:
    """The unit of each column in a unit system: ``coordinates`` the cells' own
    (:meth:`~granavg.engine.cells.base.Cells.coordinate_units`), the table's counts and
    volumes (:data:`CELL_COLUMNS`), each quantity's from its declared dimension (errors
    as their values). A column of none of these is an error: every quantity declares its
    unit."""
    out = {}
    for c in columns:
        q = quantity_of(c)
        dimension = coordinates.get(c) or CELL_COLUMNS.get(c) or (q.unit if q else None)
        if dimension is None:
            raise KeyError(f"column {c!r}: no quantity declares it")
        out[c] = system.unit(dimension)
    return out


def catalogue() -> str:
    """The quantities in words, for help texts: ``nu (volume fraction, Eq. 2), ...``."""
    return ", ".join(f"{q.name} ({q.help})" if q.help else q.name
                     for q in QUANTITIES.values())


for _q in QUANTITIES.values():           # granavg's own keep the contract too
    contract(_q)
