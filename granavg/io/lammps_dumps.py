"""Anyone's LAMMPS dumps, no manifest: column aliases, raw pair/local contacts, walls.

:class:`LammpsDumps` turns a per-atom ``dump custom`` and, optionally, a ``dump local``
of contacts into the frames the engine averages (SI units):

- atom columns by name or alias: ``x``/``xu``/``xs`` (scaled by the box), ``y`` likewise,
  ``radius`` or ``diameter``, ``vx vy``, ``omegaz``, ``id``, ``type``, ``mass``; or an
  explicit map for positional columns (``omegaz=c_spin[3]``);
- contacts in granavg's format (``id1 id2 wall fnx fny ftx fty nx ny overlap``), the
  deck's raw format (``id1 id2 type1 type2 dx dy dist fnx fny ftx fty``), or any
  ``compute pair/local`` + ``compute property/local patom1 patom2`` dump through a map
  (``id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],
  ftx=c_pl[5],fty=c_pl[6]``); the normal is -(dx, dy)/|(dx, dy)| (dx = x_1 - x_2),
  the normal force fnx, fny or force times the same unit vector, the overlap
  r_1 + r_2 - dist from the atoms' own radii;
- LAMMPS' default ``%g`` (6 significant digits) is read as it is: numbers that must
  agree (|(dx, dy)| and dist) are compared within
  :data:`~granavg.io.reader.CONSISTENCY`, never to the last digit;
- a row is a contact where the disks overlap or the pair carries a normal force
  (pair/local lists neighbours within the cutoff, with zero force): a pair touching by
  less than the printed rounding keeps its force with overlap 0; the others are dropped
  and counted; a force between disks that are apart by more than rounding is refused;
- atoms of ``wall_types`` are left out of the packing; their contacts with disks are
  kept as wall contacts (forces and normal as seen by the disk);
- the units are the dump's (``ITEM: UNITS`` or ``units=``; :mod:`granavg.io.units`).
"""

from __future__ import annotations

import numpy as np
from isal import igzip

from granavg.errors import UserError
from granavg.engine.kernels import lookup
from granavg.io.contacts import contact_columns
from granavg.io.dumpfile import open_text
from granavg.io.formats import Format
from granavg.io.frames import (CONSISTENCY, Columns, Frame, PairedDumps, check_atoms,
                               check_contacts, check_integers)
from granavg.io.reader import DumpReader
from granavg.io.units import choose_units

ATOM_ALIASES = {"x": ("x", "xu", "xs", "xsu"), "y": ("y", "yu", "ys", "ysu"),
                "radius": ("radius", "diameter"), "vx": ("vx",), "vy": ("vy",),
                "omegaz": ("omegaz",), "id": ("id",), "type": ("type",), "mass": ("mass",),
                "bx": (), "by": ()}             # a body force on each atom: named only
GRANAVG = ("id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny", "overlap")


def parse_map(text) -> dict:
    """``a=b,c=d`` -> {a: b, c: d}; one-line refusal for a malformed map."""
    out = {}
    for part in filter(None, (p.strip() for p in (text or "").split(","))):
        key, sep, value = part.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise UserError(f"column map {part!r}: expected NAME=COLUMN, e.g. id1=c_pp[1]")
        out[key.strip()] = value.strip()
    return out


def dump_header(path):
    """The column names of a dump's first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line, and
    its ``ITEM: UNITS`` as ``(style, "file:line")`` (None if the dump does not say)."""
    opener = igzip.open if str(path).endswith(".gz") else open
    units, previous = None, ""
    try:
        with opener(path, "rb") as fh:
            for k, raw in enumerate(fh):
                line = raw.decode("ascii", "replace")
                if previous.startswith("ITEM: UNITS"):
                    units = (line.strip(), f"{path}:{k + 1}")
                if line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
                    return line.split()[2:], units
                if k > 1000:
                    break
                previous = line
    except (OSError, EOFError) as exc:
        raise UserError(f"{path}: not readable ({exc})") from None
    raise UserError(f"{path}: no 'ITEM: ATOMS' or 'ITEM: ENTRIES' header; give a LAMMPS "
                    "dump custom (atoms) or dump local (contacts)")


def resolve_atoms(path, explicit: dict) -> dict:
    """Our atom name -> the dump's column, by the explicit map, then by alias."""
    names, _ = dump_header(path)
    out = {}
    for ours, aliases in ATOM_ALIASES.items():
        if ours in explicit:
            if explicit[ours] not in names:
                raise UserError(f"{path}: column {explicit[ours]!r} (for {ours}) is not in the "
                                f"dump (columns: {' '.join(names)})")
            out[ours] = explicit[ours]
            continue
        found = [a for a in aliases if a in names]
        if found:
            out[ours] = found[0]
    for need in ("x", "y", "radius"):
        if need not in out:
            raise UserError(f"{path}: no column for {need} (columns: {' '.join(names)}); "
                            f"dump it, or name it with --atom-columns {need}=COLUMN")
    return out


def resolve_contacts(path, explicit: dict) -> dict:
    """Our contact name -> the dump's column (granavg's, the deck's raw, or a map)."""
    names, _ = dump_header(path)
    if not explicit and all(c in names for c in GRANAVG):
        return {c: c for c in GRANAVG}
    out = {k: v for k, v in explicit.items()}
    for ours in ("id1", "id2", "dx", "dy", "dist", "fnx", "fny", "ftx", "fty", "force"):
        if ours not in out and ours in names:
            out[ours] = ours
    for ours, col in out.items():
        if col not in names:
            raise UserError(f"{path}: column {col!r} (for {ours}) is not in the dump "
                            f"(columns: {' '.join(names)})")
    missing = [c for c in ("id1", "id2", "dx", "dy", "dist") if c not in out]
    if not ("fnx" in out and "fny" in out) and "force" not in out:
        missing.append("force (or fnx, fny)")
    if missing:
        raise UserError(f"{path}: no column for {missing[0]}; map the pair/local and "
                        "property/local columns with --contact-columns, e.g. id1=c_pp[1],"
                        "id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
                        "ftx=c_pl[5],fty=c_pl[6]")
    return out


class LammpsDumps(PairedDumps):
    """Frames of anyone's LAMMPS dumps for the engine (see the module docstring).

    Parameters
    ----------
    atoms, contacts : path
        Per-atom dump; per-contact dump or None.
    atom_map, contact_map : dict, optional
        Explicit column maps (our name -> the dump's column).
    wall_types : sequence of int, optional
        Atom types that are walls, not packing.
    dt : float, optional
        Time step for dumps without ``ITEM: TIME``, in the dump's time unit.
    units : str, optional
        LAMMPS units style of dumps without ``ITEM: UNITS``; must agree with the header
        where there is one.

    Attributes
    ----------
    units : UnitSystem
        The dumps' units (:func:`granavg.io.units.choose_units`).
    amap, cmap : dict
        The column maps used (our name -> the dump's column), for the sidecar.
    """

    def __init__(self, atoms, contacts=None, *, atom_map=None, contact_map=None,
                 wall_types=(), dt=None, units=None):
        unit_system = choose_units(dump_header(atoms)[1], units)
        if contacts is not None and (said := dump_header(contacts)[1]) is not None:
            if choose_units(said, None).style != unit_system.style:
                raise UserError(f"{said[1]}: the contact dump says 'units {said[0]}', the "
                                f"atom dump's units are {unit_system.style}; use the dumps "
                                "of one run")
        self.amap = resolve_atoms(atoms, atom_map or {})
        self.cmap = resolve_contacts(contacts, contact_map or {}) if contacts else None
        self.wall_types = np.asarray(list(wall_types), dtype=float)
        if len(self.wall_types) and "type" not in self.amap:
            raise UserError(f"{atoms}: --wall-types needs the atoms' type column")
        if self.cmap is not None and "id" not in self.amap:
            raise UserError(f"{atoms}: contacts need the atoms' id column")
        super().__init__(DumpReader(atoms, sorted(set(self.amap.values()))),
                         DumpReader(contacts, sorted(set(self.cmap.values())))
                         if self.cmap is not None else None, dt, unit_system)

    format_name = "lammps"

    def describe(self) -> dict:
        """The options the frames were read with, for the sidecar."""
        return {"atom_columns": self.amap, "contact_columns": self.cmap,
                "wall_types": [int(t) for t in self.wall_types], "dt": self.dt}

    def box(self):
        """The box bounds (x, y) of the atom dump's first frame."""
        for frame in DumpReader(self.atoms.path, []):
            return frame.box[0], frame.box[1]
        raise UserError(f"{self.atoms.path}: holds no frame")

    def frame(self, fa, fc) -> Frame:
        atoms, walls = self._atoms(fa)
        contacts = self._contacts(fc, atoms, walls) if fc is not None else None
        return Frame(fa.timestep, self.time(fa), atoms, contacts)

    def _atoms(self, fa):
        raw = fa.as_dict()
        col = {ours: raw[theirs] for ours, theirs in self.amap.items()}
        for axis, k in (("x", 0), ("y", 1)):
            if self.amap[axis] in ("xs", "xsu", "ys", "ysu"):
                lo, hi = fa.box[k]
                col[axis] = lo + col[axis] * (hi - lo)
        if self.amap["radius"] == "diameter":
            col["radius"] = 0.5 * col["radius"]
        col = check_atoms(self.atoms.path, Columns(col, fa))
        wall = np.isin(col["type"], self.wall_types) if len(self.wall_types) else \
            np.zeros(len(col["x"]), bool)
        walls = {"id": col["id"][wall], "radius": col["radius"][wall]} if "id" in col else {}
        atoms = {k: v[~wall] for k, v in col.items() if k != "type"}
        return atoms, walls

    def _contacts(self, fc, atoms, walls):
        raw = fc.as_dict()
        c = {ours: raw[theirs] for ours, theirs in self.cmap.items()}
        check_integers(self.contacts.path, fc, c, ("id1", "id2"))
        if "wall" in c and "overlap" in c:                      # granavg's own format
            rows = dict(c, packing=np.ones(len(c["id1"]), bool))
        else:
            rows = self._convert(c, fc, atoms, walls)
        packing = rows.pop("packing")
        rows = check_contacts(self.contacts.path, Columns(rows, fc))
        touching = self._touching(rows, fc)
        self.dropped["contacts_not_touching"] += int(np.sum(packing & ~touching))
        keep = packing & touching
        return {k: v[keep] for k, v in rows.items()}

    def _touching(self, rows, fc):
        """Contacts among the rows: overlap > 0, or a normal force (the overlap of a pair
        touching by less than the printed rounding, set to 0). A force between disks
        apart by more than rounding is refused: the radius column is not the radius."""
        overlap = rows["overlap"]
        force = (rows["fnx"] != 0) | (rows["fny"] != 0)
        gap = force & (overlap <= 0)
        reach = rows.pop("reach", None)
        if gap.any():
            far = gap & (-overlap > CONSISTENCY * reach) if reach is not None else \
                np.zeros_like(gap)
            if far.any():
                k = int(np.flatnonzero(far)[0])
                raise UserError(
                    f"{self.contacts.path}:{fc.line + k}: atoms {int(rows['id1'][k])} and "
                    f"{int(rows['id2'][k])} carry a normal force but are {-overlap[k]:.3g} "
                    f"apart by their radii (timestep {fc.timestep}); check the radius or "
                    f"diameter column ({self.amap['radius']}) of {self.atoms.path}")
            rows["overlap"] = overlap = np.where(gap, 0.0, overlap)
        return (overlap > 0) | force

    def _convert(self, c, fc, atoms, walls):
        ids = np.concatenate([atoms["id"], walls.get("id", np.zeros(0))])
        radii = np.concatenate([atoms["radius"], walls.get("radius", np.zeros(0))])
        is_wall = np.concatenate([np.zeros(len(atoms["id"]), int),
                                  np.ones(len(walls.get("id", [])), int)])
        (i1, found1), (i2, found2) = lookup(ids, c["id1"]), lookup(ids, c["id2"])
        self.unknown_ids(fc, c, found1 & found2)
        dist = c["dist"]
        length = np.hypot(c["dx"], c["dy"])
        off = np.abs(length - dist) > CONSISTENCY * dist
        if off.any():
            k = int(np.flatnonzero(off)[0])
            raise UserError(f"{self.contacts.path}:{fc.line + k}: |(dx, dy)| = {length[k]:g} "
                            f"but dist = {dist[k]:g} (timestep {fc.timestep}), more apart "
                            "than printing's rounding; the dump is damaged or the column map "
                            "names the wrong columns")
        if "fnx" in c:
            fnx, fny = c["fnx"], c["fny"]
        else:                                                 # repulsive along dx
            fnx, fny = c["force"] * c["dx"] / length, c["force"] * c["dy"] / length
        zero = np.zeros(len(dist))
        return contact_columns(c["id1"], c["id2"], c["dx"], c["dy"], dist, fnx, fny,
                               c.get("ftx", zero), c.get("fty", zero), is_wall[i1],
                               is_wall[i2], radii[i1], radii[i2])


def _claims(path) -> bool:
    """A LAMMPS text dump (plain or gzip) starts with an ``ITEM:`` line."""
    try:
        with open_text(path) as fh:
            return fh.read(5) == "ITEM:"
    except (OSError, EOFError, UnicodeDecodeError):
        return False


FORMAT = Format("lammps", "LAMMPS text dumps: dump custom (atoms) and dump local (contacts: "
                "pair/local + property/local, or granavg's own columns)", _claims, LammpsDumps,
                ("atom_map", "contact_map", "wall_types", "dt", "units"))
