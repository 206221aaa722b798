"""Anyone's LAMMPS dumps, no manifest: column aliases, raw pair/local contacts, walls.

:class:`PlainFrames` turns a per-atom ``dump custom`` and, optionally, a ``dump local``
of contacts into the frames the engine averages (SI units):

- atom columns by name or alias: ``x``/``xu``/``xs`` (scaled by the box), ``y`` likewise,
  ``radius`` or ``diameter``, ``vx vy``, ``omegaz``, ``id``, ``type``, ``mass``; or an
  explicit map for positional columns (``omegaz=c_spin[3]``);
- contacts in granavg's format (``id1 id2 wall fnx fny ftx fty nx ny overlap``), the
  deck's raw format (``id1 id2 type1 type2 dx dy dist fnx fny ftx fty``), or any
  ``compute pair/local`` + ``compute property/local patom1 patom2`` dump through a map
  (``id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],
  ftx=c_pl[5],fty=c_pl[6]``); the normal is -(dx, dy)/dist (dx = x_1 - x_2), the normal
  force fnx, fny or force (dx, dy)/dist, the overlap r_1 + r_2 - dist from the atoms'
  own radii; rows that do not touch are dropped and counted;
- atoms of ``wall_types`` are left out of the packing; their contacts with disks are
  kept as wall contacts (forces and normal as seen by the disk).
"""

from __future__ import annotations

import logging

import numpy as np
from isal import igzip

from granavg.errors import UserError
from granavg.io.reader import DumpReader, Frame, check_contacts

log = logging.getLogger(__name__)

ATOM_ALIASES = {"x": ("x", "xu", "xs", "xsu"), "y": ("y", "yu", "ys", "ysu"),
                "radius": ("radius", "diameter"), "vx": ("vx",), "vy": ("vy",),
                "omegaz": ("omegaz",), "id": ("id",), "type": ("type",), "mass": ("mass",)}
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


def header_columns(path) -> list:
    """The column names of a dump's first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line."""
    opener = igzip.open if str(path).endswith(".gz") else open
    try:
        with opener(path, "rb") as fh:
            for k, raw in enumerate(fh):
                line = raw.decode("ascii", "replace")
                if line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
                    return line.split()[2:]
                if k > 1000:
                    break
    except (OSError, EOFError) as exc:
        raise UserError(f"{path}: not readable ({exc})") from None
    raise UserError(f"{path}: no 'ITEM: ATOMS' or 'ITEM: ENTRIES' header; give a LAMMPS "
                    "dump custom (atoms) or dump local (contacts)")


def resolve_atoms(path, explicit: dict) -> dict:
    """Our atom name -> the dump's column, by the explicit map, then by alias."""
    names = header_columns(path)
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
    names = header_columns(path)
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


class PlainFrames:
    """Frames of plain LAMMPS dumps for the engine (see the module docstring).

    Parameters
    ----------
    atoms, contacts : path
        Per-atom dump; per-contact dump or None.
    atom_map, contact_map : dict, optional
        Explicit column maps (our name -> the dump's column).
    wall_types : sequence of int, optional
        Atom types that are walls, not packing.
    dt : float, optional
        Time step (s) for dumps without ``ITEM: TIME``.
    """

    def __init__(self, atoms, contacts=None, *, atom_map=None, contact_map=None,
                 wall_types=(), dt=None):
        self.atoms_path, self.contacts_path = atoms, contacts
        self.amap = resolve_atoms(atoms, atom_map or {})
        self.cmap = resolve_contacts(contacts, contact_map or {}) if contacts else None
        self.wall_types = np.asarray(list(wall_types), dtype=float)
        if len(self.wall_types) and "type" not in self.amap:
            raise UserError(f"{atoms}: --wall-types needs the atoms' type column")
        if self.cmap is not None and "id" not in self.amap:
            raise UserError(f"{atoms}: contacts need the atoms' id column")
        self.dt = dt
        self.dropped = {"contacts_not_touching": 0}

    def __iter__(self):
        ra = DumpReader(self.atoms_path, sorted(set(self.amap.values())))
        rc = DumpReader(self.contacts_path, sorted(set(self.cmap.values()))) \
            if self.cmap is not None else None
        c_iter = iter(rc) if rc is not None else None
        for fa in ra:
            time = fa.time if fa.time is not None else (
                fa.timestep * self.dt if self.dt is not None else None)
            if time is None:
                raise UserError(f"{self.atoms_path}: frames have no ITEM: TIME; give --dt "
                                "(the time step in s)")
            atoms, walls = self._atoms(fa)
            contacts = None
            if c_iter is not None:
                fc = next(c_iter, None)
                if fc is None:
                    log.warning("%s ends before %s; later frames are not used",
                                self.contacts_path, self.atoms_path)
                    return
                if fc.timestep != fa.timestep:
                    raise UserError(f"time steps do not match: {fa.timestep} in "
                                    f"{self.atoms_path} (line {fa.line}) but {fc.timestep} "
                                    f"in {self.contacts_path} (line {fc.line})")
                contacts = self._contacts(fc, atoms, walls)
            yield Frame(fa.timestep, time, atoms, contacts)

    def _atoms(self, fa):
        raw = fa.as_dict()
        col = {ours: raw[theirs] for ours, theirs in self.amap.items()}
        for axis, k in (("x", 0), ("y", 1)):
            if self.amap[axis] in ("xs", "xsu", "ys", "ysu"):
                lo, hi = fa.box[k]
                col[axis] = lo + col[axis] * (hi - lo)
        if self.amap["radius"] == "diameter":
            col["radius"] = 0.5 * col["radius"]
        bad = np.flatnonzero(~(col["radius"] > 0))
        if len(bad):
            raise UserError(f"{self.atoms_path}:{fa.line + bad[0]}: radius "
                            f"{col['radius'][bad[0]]:g} is not positive (timestep "
                            f"{fa.timestep}); disks need a radius > 0 (m)")
        if "id" in col and len(np.unique(col["id"])) < len(col["id"]):
            raise UserError(f"{self.atoms_path}:{fa.line}: an atom id appears twice in "
                            f"timestep {fa.timestep}; the dump is damaged")
        wall = np.isin(col["type"], self.wall_types) if len(self.wall_types) else \
            np.zeros(len(col["x"]), bool)
        walls = {"id": col["id"][wall], "radius": col["radius"][wall]} if "id" in col else {}
        atoms = {k: v[~wall] for k, v in col.items() if k != "type"}
        return atoms, walls

    def _contacts(self, fc, atoms, walls):
        raw = fc.as_dict()
        c = {ours: raw[theirs] for ours, theirs in self.cmap.items()}
        if "wall" in c and "overlap" in c:                      # granavg's own format
            rows = c
        else:
            rows = self._convert(c, fc, atoms, walls)
        keep = rows["overlap"] > 0
        self.dropped["contacts_not_touching"] += int(np.sum(~keep))
        rows = {k: v[keep] for k, v in rows.items()}
        frame = type("F", (), {"as_dict": lambda s: rows, "line": fc.line,
                               "timestep": fc.timestep})()
        return check_contacts(self.contacts_path, frame)

    def _convert(self, c, fc, atoms, walls):
        ids = np.concatenate([atoms["id"], walls.get("id", np.zeros(0))])
        radii = np.concatenate([atoms["radius"], walls.get("radius", np.zeros(0))])
        is_wall = np.concatenate([np.zeros(len(atoms["id"]), bool),
                                  np.ones(len(walls.get("id", [])), bool)])
        order = np.argsort(ids)

        def rows_of(wanted):
            pos = np.clip(np.searchsorted(ids[order], wanted), 0, len(ids) - 1)
            found = ids[order][pos] == wanted
            if not found.all():
                k = int(np.argmin(found))
                raise UserError(f"{self.contacts_path}:{fc.line + k}: atom id "
                                f"{int(wanted[k])} is not in {self.atoms_path} at timestep "
                                f"{fc.timestep}; use the dumps of one run")
            return order[pos]
        i1, i2 = rows_of(c["id1"]), rows_of(c["id2"])
        dist = c["dist"]
        with np.errstate(invalid="ignore", divide="ignore"):
            nx, ny = -c["dx"] / dist, -c["dy"] / dist             # from atom 1 towards atom 2
        if "fnx" in c:
            fnx, fny = c["fnx"], c["fny"]
        else:
            fnx, fny = -c["force"] * nx, -c["force"] * ny         # repulsive along dx
        ftx = c.get("ftx", np.zeros(len(dist)))
        fty = c.get("fty", np.zeros(len(dist)))
        overlap = radii[i1] + radii[i2] - dist
        wall = np.zeros(len(dist))
        w1, w2 = is_wall[i1], is_wall[i2]
        swap = w1 & ~w2                                           # the disk goes first
        sign = np.where(swap, -1.0, 1.0)
        id1 = np.where(swap, c["id2"], c["id1"])
        id2 = np.where(swap, c["id1"], c["id2"])
        wall[w1 ^ w2] = 1.0
        both = w1 & w2
        keep = ~both                                              # wall-wall pairs are not packing
        rows = {"id1": id1, "id2": id2, "wall": wall, "fnx": sign * fnx, "fny": sign * fny,
                "ftx": sign * ftx, "fty": sign * fty, "nx": sign * nx, "ny": sign * ny,
                "overlap": overlap}
        return {k: v[keep] for k, v in rows.items()}
