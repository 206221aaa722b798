"""What can be averaged: the quantity groups, the channels each needs and the dump
columns each channel reads (Eqs. 2-7). A catalogue without numerics, so that a caller can
decide what to read or simulate (e.g. whether contacts are needed) without the engine.

Profile columns are named in the cells' basis (:func:`columns`): ``v_r, v_phi`` and
tensors ``rr, rphi, phir, phiphi`` (first index the force or the deformation, second the
branch vector) for rings; ``x, y`` and ``xx, xy, yx, yy`` for 2D slabs and grids; three
axes in 3D (``x, y, z``, or ``r, phi, z`` for cylindrical shells).
"""

from __future__ import annotations

from typing import NamedTuple

from granavg.engine.channels import pairs
from granavg.errors import ParameterError

#: Tensor components of the 2D rings (the paper's), in channel order.
TENSOR = pairs(("r", "phi"))


class Quantity(NamedTuple):
    """A quantity group: the channel blocks it needs (:mod:`granavg.engine.channels`)
    and whether it needs the contacts."""
    blocks: tuple
    contacts: bool


QUANTITIES = {
    "nu": Quantity(("vol",), False),
    "rho": Quantity(("vol", "mass"), False),
    "v": Quantity(("vol", "mom"), False),
    "omega": Quantity(("vol", "spin"), False),
    "coordination": Quantity(("vol", "ncontact"), True),
    "F": Quantity(("fab",), True),
    "sigma": Quantity(("sig",), True),
    "dsigma": Quantity(("kin",), False),
    "dsigma_fluct": Quantity(("vol", "mass", "mom", "kin"), False),
    "eps": Quantity(("fab", "def"), True),
    "boundary": Quantity(("wall",), True),
    "body": Quantity(("body",), False),
}


def columns(group: str, axes) -> list:
    """Profile columns of a quantity group in a basis with these axes (``v_r, v_phi``
    for rings, ``v_x, v_y, v_z`` for 3D boxes, ...)."""
    if group in ("nu", "rho", "coordination"):
        return [group]
    if group == "omega":
        return ["omega"] if len(axes) == 2 else [f"omega_{i}" for i in axes]
    if group in ("v", "boundary", "body"):
        return [f"{group}_{i}" for i in axes]
    return [f"{group}_{c}" for c in pairs(axes)]


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
BALANCED = ("sigma", "boundary")


def balanced_names(groups, axes, across: str) -> set:
    """Profile names that the balance of forces fixes in a whole cell (:data:`BALANCED`):
    every boundary component and the stress components with an index ``across`` (the
    direction across the cells, one of ``axes``)."""
    out = {f"sigma_{i}{j}" for i in axes for j in axes if across in (i, j)} \
        if "sigma" in groups else set()
    return out | (set(columns("boundary", axes)) if "boundary" in groups else set())


def atom_columns(block: str, dim: int) -> list:
    """The atom-dump columns a channel block reads (positions and radii for every block:
    the cells' weights)."""
    xyz = ["x", "y", "z"][:dim]
    v = ["vx", "vy", "vz"][:dim]
    return {"mom": v, "kin": v, "spin": ["omegaz"] if dim == 2 else
            ["omegax", "omegay", "omegaz"], "body": ["bx", "by", "bz"][:dim],
            **{b: ["id"] for b in ("ncontact", "fab", "sig", "def", "wall")}
            }.get(block, []) if block != "vol" else [*xyz, "radius"]


def contact_columns(block: str, dim: int) -> list:
    """The contact columns a channel block reads."""
    n = ["nx", "ny", "nz"][:dim]
    f = [*["fnx", "fny", "fnz"][:dim], *["ftx", "fty", "ftz"][:dim]]
    return {"ncontact": ["id1", "id2", "wall"], "fab": ["id1", "id2", "wall", *n],
            "sig": ["id1", "id2", "wall", *f, *n, "overlap"],
            "def": ["id1", "id2", "wall", *n, "overlap"],
            "wall": ["id1", "id2", "wall", *f, *n, "overlap"]}.get(block, [])


def needed_columns(groups, dim: int = 2):
    """Atom-dump and contact-dump columns (with what needs each) for these groups; every
    group needs the particles' positions and radii (their weights in the cells)."""
    atoms = {c: "the cells' weights" for c in [*["x", "y", "z"][:dim], "radius"]}
    contacts = {}
    for g in groups:
        for b in QUANTITIES[g].blocks:
            for c in atom_columns(b, dim):
                atoms.setdefault(c, g)
            for c in contact_columns(b, dim):
                contacts.setdefault(c, g)
    return atoms, contacts


def missing_columns(group: str, atoms, contacts, dim: int) -> list:
    """The columns ``group`` needs that the frames lack: ``atoms`` and ``contacts`` are
    the column names the frames carry (contacts None: no contact data). Positions and
    radii are every group's and are not checked here; masses are (``rho_p`` or a mass
    column).

    Returns
    -------
    list of (str, str)
        ``("atom", name)`` or ``("contact", name)`` of each missing column, in order.
    """
    missing = []
    for b in QUANTITIES[group].blocks:
        missing += [("atom", c) for c in atom_columns(b, dim) if b != "vol" and c not in atoms]
        if contacts is not None:
            missing += [("contact", c) for c in contact_columns(b, dim) if c not in contacts]
    return list(dict.fromkeys(missing))


def groups_for(quantities, have_contacts: bool, have_body: bool = False) -> list:
    """The quantity groups to compute: the requested ones (checked), or all that the
    data allow (without contacts, only those that need none; ``body`` only where the
    frames carry body forces)."""
    if quantities is None:
        return [g for g, q in QUANTITIES.items()
                if (have_contacts or not q.contacts) and (have_body or g != "body")]
    unknown = [q for q in quantities if q not in QUANTITIES]
    if unknown:
        raise ParameterError("quantities", f"{{param}}: unknown quantity {unknown[0]!r}; "
                             f"choose from {', '.join(QUANTITIES)}")
    lacking = [q for q in quantities if QUANTITIES[q].contacts and not have_contacts]
    if lacking:
        raise ParameterError("contacts", f"{lacking[0]} needs the contact dump, and none was "
                             "found; give the contacts ({param}) or run the simulation "
                             "with contacts")
    if "body" in quantities and not have_body:
        raise ParameterError("quantities", "body needs body forces: none acts in this scene "
                             "or was given (gravity, base-plate friction, a force column)")
    return list(quantities)
