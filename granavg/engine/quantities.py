"""What can be averaged: the quantity groups, the channels each needs and the dump
columns each channel reads (Eqs. 2-7). A catalogue without numerics, so that a caller can
decide what to read or simulate (e.g. whether contacts are needed) without the engine.

Tensor components are named ``rr, rphi, phir, phiphi`` (first index the force or the
deformation, second the branch vector) in the cells' basis; Cartesian cells rename them
(``xx, xy, yx, yy``; :func:`granavg.engine.geometry.rename`).
"""

from __future__ import annotations

from granavg.errors import ParameterError

#: Tensor components in the engine's channel order.
TENSOR = ("rr", "rphi", "phir", "phiphi")
#: quantity group -> (profile columns, channels it needs, needs contacts)
QUANTITIES = {
    "nu": (["nu"], ["vol"], False),
    "rho": (["rho"], ["vol", "mass"], False),
    "v": (["v_r", "v_phi"], ["vol", "mom_r", "mom_phi"], False),
    "omega": (["omega"], ["vol", "spin"], False),
    "coordination": (["coordination"], ["vol", "ncontact"], True),
    "F": ([f"F_{c}" for c in TENSOR], ["fab_rr"], True),
    "sigma": ([f"sigma_{c}" for c in TENSOR], ["sig_rr"], True),
    "dsigma": ([f"dsigma_{c}" for c in TENSOR], ["kin_rr"], False),
    "dsigma_fluct": ([f"dsigma_fluct_{c}" for c in TENSOR],
                     ["vol", "mass", "mom_r", "mom_phi", "kin_rr"], False),
    "eps": ([f"eps_{c}" for c in TENSOR], ["fab_rr", "def_rr"], True),
    "boundary": (["boundary_r", "boundary_phi"], ["wall_r"], True),
    "body": (["body_r", "body_phi"], ["body_r"], False),
}
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


def balanced_names(groups, across: str = "r") -> set:
    """Profile names that the balance of forces fixes in a whole cell (:data:`BALANCED`):
    every boundary component and all stress components but (along, along), with
    ``across`` ("r" or "phi", in the engine's names) the direction across the cells."""
    along = "phi" if across == "r" else "r"
    out = {f"sigma_{c}" for c in TENSOR if c != along * 2} if "sigma" in groups else set()
    return out | ({"boundary_r", "boundary_phi"} if "boundary" in groups else set())


#: the atom-dump and contact-dump columns each channel reads
ATOM_COLUMNS = {"vol": ["x", "y", "radius"], "mom_r": ["vx", "vy"], "mom_phi": ["vx", "vy"],
                "kin_rr": ["vx", "vy"], "spin": ["omegaz"], "ncontact": ["id"],
                "fab_rr": ["id"], "sig_rr": ["id"], "def_rr": ["id"], "wall_r": ["id"],
                "body_r": ["bx", "by"]}
CONTACT_COLUMNS = {"ncontact": ["id1", "id2", "wall"],
                   "fab_rr": ["id1", "id2", "wall", "nx", "ny"],
                   "sig_rr": ["id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny",
                              "overlap"],
                   "def_rr": ["id1", "id2", "wall", "nx", "ny", "overlap"],
                   "wall_r": ["id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny",
                              "overlap"]}



def needed_columns(groups):
    """Atom-dump and contact-dump columns (with what needs each) for these groups; every
    group needs the disks' positions and radii (their weights in the cells)."""
    atoms, contacts = {"x": "the cells' weights", "y": "the cells' weights",
                       "radius": "the cells' weights"}, {}
    for g in groups:
        for ch in QUANTITIES[g][1]:
            for c in ATOM_COLUMNS.get(ch, []):
                atoms.setdefault(c, g)
            for c in CONTACT_COLUMNS.get(ch, []):
                contacts.setdefault(c, g)
    return atoms, contacts


def groups_for(quantities, have_contacts: bool, have_body: bool = False) -> list:
    """The quantity groups to compute: the requested ones (checked), or all that the
    data allow (without contacts, only those that need none; ``body`` only where the
    frames carry body forces)."""
    if quantities is None:
        return [g for g, (_, _, needs) in QUANTITIES.items()
                if (have_contacts or not needs) and (have_body or g != "body")]
    unknown = [q for q in quantities if q not in QUANTITIES]
    if unknown:
        raise ParameterError("quantities", f"{{param}}: unknown quantity {unknown[0]!r}; "
                             f"choose from {', '.join(QUANTITIES)}")
    lacking = [q for q in quantities if QUANTITIES[q][2] and not have_contacts]
    if lacking:
        raise ParameterError("contacts", f"{lacking[0]} needs the contact dump, and none was "
                             "found; give the contacts ({param}) or run the simulation "
                             "with contacts")
    if "body" in quantities and not have_body:
        raise ParameterError("quantities", "body needs body forces: none acts in this scene "
                             "or was given (gravity, base-plate friction, a force column)")
    return list(quantities)
