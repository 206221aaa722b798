"""What a set of quantities (:data:`granavg.engine.quantities.QUANTITIES`) needs of the
data: the atom and contact columns their channel blocks read, whether they need body
forces, and which quantities to compute from what the data allow (the requested ones
checked, or all that can be)."""

from __future__ import annotations

from granavg.engine.channels import BLOCK
from granavg.engine.quantities import QUANTITIES
from granavg.errors import ParameterError


def atom_columns(block: str, dim: int) -> list:
    """The atom-dump columns a channel block reads (positions and radii for every block:
    the cells' weights)."""
    if block == "vol":
        return [*["x", "y", "z"][:dim], "radius"]
    return BLOCK[block].atom_columns(dim)


def contact_columns(block: str, dim: int) -> list:
    """The contact columns a channel block reads."""
    return BLOCK[block].contact_columns(dim)


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
                if c not in BLOCK[b].optional_columns(dim):
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
            optional = BLOCK[b].optional_columns(dim)
            missing += [("contact", c) for c in contact_columns(b, dim)
                        if c not in contacts and c not in optional]
    return list(dict.fromkeys(missing))


def optional_columns(groups, dim: int = 2) -> dict:
    """Contact columns these groups read where the data hold them and take as zero
    where not (the contact couple), with the group that reads each."""
    out = {}
    for g in groups:
        for b in QUANTITIES[g].blocks:
            for c in BLOCK[b].optional_columns(dim):
                out.setdefault(c, g)
    return out


def needs_body(groups) -> bool:
    """Whether these groups need the particles' body forces (``body``, ``body_power``)."""
    return any("body" in QUANTITIES[g].blocks for g in groups)


def groups_for(quantities, have_contacts: bool, have_body: bool = False,
               smooth: bool = False, in_time: bool = False, species: bool = False,
               have_forces: bool = False) -> list:
    """The quantity groups to compute: the requested ones (checked), or all that the
    data allow but those computed by name only (``by_name``; without contacts, only
    those that need none; ``body`` only where the frames carry body forces; the
    derivatives only with a ``smooth`` kernel, the time derivatives only with a time
    kernel, ``in_time``; the forces between species only with ``species``; the
    particles' total forces only where the atoms carry them, ``have_forces``)."""
    if quantities is None:
        return [g for g, q in QUANTITIES.items() if not q.by_name
                and (have_contacts or not q.contacts) and (have_body or "body" not in q.blocks)
                and (smooth or not q.smooth) and (in_time or not q.in_time)
                and (species or not q.species)
                and (have_forces or not {"ma", "impulse"} & set(q.blocks))]
    alone = [q for q in quantities if q in QUANTITIES and QUANTITIES[q].species
             and not species]
    if alone:
        raise ParameterError("quantities", f"{alone[0]} is a force between species: it "
                             "needs the particles split into species ({species})")
    timeless = [q for q in quantities if q in QUANTITIES and QUANTITIES[q].in_time
                and not in_time]
    if timeless:
        from granavg.engine.timing import names as time_kernels
        raise ParameterError("quantities", f"{timeless[0]} is a time derivative of the "
                             "fields: it needs fields smoothed in time ({time_kernel} "
                             f"{time_kernels()}, with {{time_width}} and {{times}})")
    rough = [q for q in quantities if q in QUANTITIES and QUANTITIES[q].smooth and not smooth]
    if rough:
        from granavg.engine.smoothing import names
        raise ParameterError("quantities", f"{rough[0]} is a derivative of the coarse-"
                             "grained fields: it needs a smoothing kernel continuous at "
                             f"its edge ({{kernel}} {names(smooth_only=True)}, with "
                             "{width})")
    unknown = [q for q in quantities if q not in QUANTITIES]
    if unknown:
        raise ParameterError("quantities", f"{{param}}: unknown quantity {unknown[0]!r}; "
                             f"choose from {', '.join(QUANTITIES)}")
    lacking = [q for q in quantities if QUANTITIES[q].contacts and not have_contacts]
    if lacking:
        raise ParameterError("quantities", f"{lacking[0]} needs the contact dump, and none "
                             "was found; give the contacts ({contacts}) or run the "
                             "simulation with contacts")
    bodiless = [q for q in quantities if "body" in QUANTITIES[q].blocks and not have_body]
    if bodiless:
        raise ParameterError("quantities", f"{bodiless[0]} needs body forces: none acts in "
                             "this scene or was given (gravity, base-plate friction, a force "
                             "column)")
    return list(quantities)
