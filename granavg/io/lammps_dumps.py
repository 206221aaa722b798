"""Anyone's LAMMPS dumps, no manifest: column aliases, raw pair/local contacts, walls,
in 2D or 3D.

:class:`LammpsDumps` turns a per-atom ``dump custom`` and, optionally, a ``dump local``
of contacts into the frames the engine averages (in the dumps' own units):

- the dimension from the dump (3 where the atoms' z coordinates differ, 2 where there is
  none or all share one) or given (``dim``);
- atom columns by name or alias: ``x``/``xu``/``xs`` (scaled by the box), ``y`` and ``z``
  likewise, ``radius`` or ``diameter``, ``vx vy [vz]``, ``omegaz`` (2D) or ``omegax
  omegay omegaz`` (3D), ``id``, ``type``, ``mass``; or an explicit map for positional
  columns (``omegaz=c_spin[3]``);
- positions are wrapped into the box along its periodic axes (``pp`` in ``ITEM: BOX
  BOUNDS``: unwrapped ``xu`` coordinates, or atoms just outside between re-neighbouring);
- contacts in granavg's format (``id1 id2 wall fnx fny [fnz] ftx fty [ftz] nx ny [nz]
  overlap``), the deck's raw format (``id1 id2 type1 type2 dx dy dist fnx fny ftx fty``),
  or any ``compute pair/local`` + ``compute property/local patom1 patom2`` dump through a
  map (``id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],[dz=c_pl[4],]
  force=...,ftx=...,fty=...[,ftz=...]``); the normal is -d/|d| (d = x_1 - x_2, the
  minimum image pair/local gives across periodic boundaries), the normal force fn or
  force times the same unit vector, the overlap r_1 + r_2 - dist from the atoms' own
  radii;
- LAMMPS' default ``%g`` (6 significant digits) is read as it is: numbers that must
  agree (|d| and dist) are compared within :data:`~granavg.io.frames.CONSISTENCY`, never
  to the last digit;
- a row is a contact where the particles overlap or the pair carries a normal force
  (pair/local lists neighbours within the cutoff, with zero force): a pair touching by
  less than the printed rounding keeps its force with overlap 0; the others are dropped
  and counted; a force between particles that are apart by more than rounding is refused;
- atoms of ``wall_types`` are left out of the packing; their contacts with particles are
  kept as wall contacts (forces and normal as seen by the particle);
- the units are the dump's (``ITEM: UNITS`` or ``units=``; :mod:`granavg.io.dump_units`);
- a path with a ``*`` is a series of files (``dump.*.txt``; :mod:`granavg.io.reader`).
"""

from __future__ import annotations

import itertools
import logging
import math
import re
import sys
from pathlib import Path

import numpy as np

from granavg.errors import ParameterError, UserError, literal, named
from granavg.engine.kernels import lookup
from granavg.io import binary_dump, yaml_dump
from granavg.io.box import Box
from granavg.io.contacts import contact_columns, contact_couples
from granavg.io.dumpfile import open_text
from granavg.io.formats import (ATOM_MAP, CONTACT_MAP, DIM, DT, INERTIA, UNITS,
                                 WALL_TYPES, Format)
from granavg.io.frames import (CONSISTENCY, Columns, Frame, PairedDumps, check_atoms,
                               Rows, check_contacts, check_integers, row_at)
from granavg.io.reader import DumpReader, first_file
from granavg.io.dump_units import choose_units
from granavg.engine import gate

log = logging.getLogger(__name__)

ATOM_ALIASES = {"x": ("x", "xu", "xs", "xsu"), "y": ("y", "yu", "ys", "ysu"),
                "z": ("z", "zu", "zs", "zsu"),
                "radius": ("radius", "diameter"), "vx": ("vx",), "vy": ("vy",), "vz": ("vz",),
                "omegax": ("omegax",), "omegay": ("omegay",), "omegaz": ("omegaz",),
                "id": ("id",), "type": ("type",), "mass": ("mass",),
                "fx": ("fx",), "fy": ("fy",), "fz": ("fz",),
                "bx": (), "by": (), "bz": ()}   # a body force on each atom: named only
#: Atom columns that exist only in 3D.
ONLY_3D = ("z", "vz", "omegax", "omegay", "fz", "bz")
SCALED = ("xs", "xsu", "ys", "ysu", "zs", "zsu")


def granavg_columns(dim: int) -> tuple:
    """granavg's own contact columns in ``dim`` dimensions (without the optional
    couple, :func:`couple_columns`)."""
    xyz = "xyz"[:dim]
    return ("id1", "id2", "wall", *(f"fn{x}" for x in xyz), *(f"ft{x}" for x in xyz),
            *(f"n{x}" for x in xyz), "overlap")


def couple_columns(dim: int) -> tuple:
    """The contact couple's columns (on atom 1, N m in SI): ``mz`` in 2D, ``mx my mz``
    in 3D."""
    return ("mz",) if dim == 2 else ("mx", "my", "mz")


def rolling_columns(dim: int) -> tuple:
    """``pair granular``'s outputs the couple is formed from: the rolling force
    ``frx fry [frz]`` (pair/local p5 p6 p7) and, in 3D, the twisting torque ``twist``
    (p9)."""
    return (*(f"fr{x}" for x in "xyz"[:dim]), *(("twist",) if dim == 3 else ()))


def parse_map(text) -> dict:
    """``a=b,c=d`` -> {a: b, c: d} (None: {}); one-line refusal for a malformed map."""
    return ATOM_MAP.parse(text or "")


def dump_header(path):
    """The column names of a dump's first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line, and
    its ``ITEM: UNITS`` as ``(style, "file:line")`` (None if the dump does not say)."""
    path = first_file(path)
    if binary_dump.is_binary(path):
        return binary_dump.header(path)
    if yaml_dump.is_yaml(path):
        return yaml_dump.header(path)
    try:
        with open_text(path, "rb") as fh:
            return _columns_line(fh, path)
    except (OSError, EOFError) as exc:
        raise UserError(f"{path}: not readable ({exc})") from None


def _columns_line(fh, path):
    """Read a text dump up to its first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line (within
    its first 1000 lines): (its column names, the ``ITEM: UNITS`` before it or None)."""
    units, previous = None, ""
    for k, raw in enumerate(fh):
        line = raw.decode("ascii", "replace")
        if previous.startswith("ITEM: UNITS"):
            units = (line.strip(), f"{path}:{k + 1}")
        if line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
            return line.split()[2:], units
        if k > 1000:
            break
        previous = line
    raise UserError(f"{path}: no 'ITEM: ATOMS' or 'ITEM: ENTRIES' header; give a LAMMPS "
                    "dump custom (atoms) or dump local (contacts)")


#: The first frame's rows read to tell a 3D dump at once, by z differing among them
#: (:func:`dimension`; where they all share one z, the whole frame is read).
Z_SAMPLE = 1000


def _first_z(path, zcol, rows: int = Z_SAMPLE) -> np.ndarray:
    """The z of the first ``rows`` atoms of a text dump's first frame, read from its
    text; empty where the frame holds none, the dump is not text or the rows do not
    read (the whole frame's reading then says why)."""
    path = first_file(path)
    if binary_dump.is_binary(path) or yaml_dump.is_yaml(path):
        return np.empty(0)
    try:
        with open_text(path, "rb") as fh:
            names, _ = _columns_line(fh, path)
            k = names.index(zcol)
            z = []
            for raw in itertools.islice(fh, rows):
                if raw.startswith(b"ITEM:"):
                    break
                z.append(float(raw.split()[k]))
        return np.array(z)
    except (OSError, EOFError, UserError, ValueError, IndexError):
        return np.empty(0)


def _one_each(explicit: dict, param: str) -> None:
    """Refuse a map that names one dump column for two of granavg's columns."""
    seen = {}
    for ours, col in explicit.items():
        if col in seen:
            raise ParameterError(param, f"{{param}} names {literal(col)} for both "
                                 f"{seen[col]} and {ours}; each needs a column of its own")
        seen[col] = ours


def resolve_atoms(path, explicit: dict, dim: int) -> dict:
    """Our atom name -> the dump's column, by the explicit map, then by alias."""
    names, _ = dump_header(path)
    unknown = [k for k in explicit if k not in ATOM_ALIASES]
    if unknown:
        raise ParameterError("atom_map", f"{{param}} {literal(unknown[0])}=...: granavg has "
                             f"no atom column {literal(repr(unknown[0]))}; name one of "
                             f"{' '.join(ATOM_ALIASES)}")
    _one_each(explicit, "atom_map")
    out = {}
    for ours, aliases in ATOM_ALIASES.items():
        if ours in explicit:
            if explicit[ours] not in names:
                raise UserError(f"{path}: column {explicit[ours]!r} (for {ours}) is not in the "
                                f"dump (columns: {' '.join(names)})")
            out[ours] = explicit[ours]
            continue
        if dim == 2 and ours in ONLY_3D:
            continue
        found = [a for a in aliases if a in names]
        if found:
            out[ours] = found[0]
    for need in ("x", "y", *(("z",) if dim == 3 else ()), "radius"):
        if need not in out:
            raise ParameterError("atom_map", f"{literal(path)}: no column for {need} "
                                 f"(columns: {literal(' '.join(names))}); dump it, or name "
                                 f"it with {{param}} {need}=COLUMN")
    return out


def resolve_contacts(path, explicit: dict, dim: int) -> dict:
    """Our contact name -> the dump's column (granavg's, the deck's raw, or a map)."""
    names, _ = dump_header(path)
    own = granavg_columns(dim)
    if not explicit and all(c in names for c in own):
        return {c: c for c in (*own, *couple_columns(dim)) if c in names}
    xyz = "xyz"[:dim]
    known = ("id1", "id2", *(f"d{x}" for x in xyz), "dist", *(f"fn{x}" for x in xyz),
             *(f"ft{x}" for x in xyz), "force", *couple_columns(dim), *rolling_columns(dim))
    unknown = [k for k in explicit if k not in known]
    if unknown:
        hint = " (a 2D dump: no z components)" if dim == 2 and unknown[0].endswith("z") \
            and unknown[0][:-1] + "x" in known else ""
        raise ParameterError("contact_map", f"{{param}} {literal(unknown[0])}=...: granavg "
                             f"has no contact column {literal(repr(unknown[0]))}{hint}; name "
                             f"one of {' '.join(known)}")
    out = {k: v for k, v in explicit.items()}
    for ours in known:
        if ours not in out and ours in names:
            out[ours] = ours
    for ours, col in out.items():
        if col not in names:
            raise UserError(f"{path}: column {col!r} (for {ours}) is not in the dump "
                            f"(columns: {' '.join(names)})")
    _check_couple(path, out, dim)
    _one_each(explicit, "contact_map")
    missing = [c for c in ("id1", "id2", *(f"d{x}" for x in xyz), "dist") if c not in out]
    if not all(f"fn{x}" in out for x in xyz) and "force" not in out:
        missing.append("force (or " + ", ".join(f"fn{x}" for x in xyz) + ")")
    if missing:
        example = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
                   "ftx=c_pl[5],fty=c_pl[6]") if dim == 2 else (
                   "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
                   "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]")
        unnamed = re.compile(r"^c_.+\[\d+\]$")
        if not explicit and names and all(unnamed.match(n) for n in names):
            raise ParameterError("contact_map", f"{literal(path)}: no column for "
                                 f"{missing[0]}: its columns ({names[0]} .. {names[-1]}) are "
                                 "unnamed; LIGGGHTS' compute pair/gran/local: give its "
                                 "keywords ({liggghts} 'pos id force delta'); LAMMPS' "
                                 "pair/local and property/local: map them with {param}, e.g. "
                                 f"{literal(example)}")
        raise ParameterError("contact_map", f"{literal(path)}: no column for {missing[0]}; "
                             "map the pair/local and property/local columns with {param}, "
                             f"e.g. {literal(example)}")
    return out


def _check_couple(path, cmap, dim):
    """A contact couple is mapped whole: all of its own columns, or all of the rolling
    force's (the twisting torque may come with it, or alone), not both."""
    own = [c for c in couple_columns(dim) if c in cmap]
    roll = [c for c in rolling_columns(dim)[:dim] if c in cmap]
    if (own and roll) or 0 < len(own) < len(couple_columns(dim)) or 0 < len(roll) < dim or \
            (own and "twist" in cmap):
        given = [c for c in (*couple_columns(dim), *rolling_columns(dim)) if c in cmap]
        raise ParameterError(
            "contact_map", f"{literal(path)}: the contact couple needs all of "
            f"{literal(' '.join(couple_columns(dim)))} (the couple on atom 1) or of "
            f"{literal(' '.join(rolling_columns(dim)))} (pair granular's p5 p6"
            f"{' p7, p9' if dim == 3 else ''}), not {literal(' '.join(given))}")


def dimension(path, explicit_map, dim=None) -> tuple:
    """The dump's dimension and why: ``dim`` if given (3 needs a z column), else 3 where
    the z coordinates of the first frame that holds atoms differ, 2 where there is no z
    column or they all share one (a 2D LAMMPS run writes z = 0). Frames with no atom (a
    pour before its first insertion) are passed over.

    Returns
    -------
    dim : int
    why : str
        The reason, for messages that depend on it ("has no z column", ...).
    """
    names, _ = dump_header(path)
    zcol = explicit_map.get("z") or next((a for a in ATOM_ALIASES["z"] if a in names), None)
    if dim not in (None, 2, 3):
        raise ParameterError("dim", f"{{param}} {dim}: give 2 or 3")
    if dim == 3 and zcol is None:
        raise ParameterError("dim", f"{literal(path)}: {{param}} 3 needs a z column "
                             f"(columns: {literal(' '.join(names))}); dump z, or name it "
                             "with {atom_map} z=COLUMN")
    if dim == 3 or (dim is not None and zcol is None):
        return dim, "given"
    if zcol is None:
        return 2, f"{first_file(path)} has no z column"
    if dim is None:
        z = _first_z(path, zcol)
        if len(z) and np.ptp(z) > 0:
            return 3, "z differs"               # the whole first frame not parsed for it
    frame = next((f for f in DumpReader(path, [zcol], readers=1) if len(f.data)), None)
    if frame is None:
        raise UserError(f"{path}: no frame holds an atom; give a dump of a run with atoms")
    z = frame.column(zcol)
    if dim == 2:
        if np.ptp(z) > 0:
            log.warning(named("%s: {dim} 2, but the atoms' z differ (by up to %g in the "
                              "first frame with atoms): they are averaged as disks in the "
                              "x-y plane"), path, np.ptp(z))
        return 2, "given"
    if np.ptp(z) > 0:
        return 3, "z differs"
    return 2, (f"every atom of the first frame with atoms ({row_at(frame.path, frame, 0)}, "
               f"timestep {frame.timestep}) has z = {z[0]:g}")


class LammpsDumps(PairedDumps):
    """Frames of anyone's LAMMPS dumps for the engine (see the module docstring).

    Parameters
    ----------
    atoms, contacts : path
        Per-atom dump; per-contact dump or None (a ``*`` in a name: a file series).
    atom_map, contact_map : dict, optional
        Explicit column maps (our name -> the dump's column).
    wall_types : sequence of int, optional
        Atom types that are walls, not packing.
    dt : float, optional
        Time step for dumps without ``ITEM: TIME``, in the dump's time unit.
    units : str, optional
        LAMMPS units style of dumps without ``ITEM: UNITS``; must agree with the header
        where there is one.
    dim : {2, 3}, optional
        The dimension (default from the dump: :func:`dimension`).
    steps : (int, int), optional
        Only the frames with first <= timestep <= last (a dask worker's chunk).
    named_steps : bool, optional
        With ``steps``, on ``dump.*`` series: only the files whose names put them in the
        window are opened (:class:`~granavg.io.reader.DumpReader`).
    inertia : {"disk", "sphere"}, optional
        The particles' moment of inertia, m a^2 / 2 or 2/5 m a^2 (the spin fields). 3D:
        spheres. 2D, not given: spheres where the mass column scales as a^3 (sphere
        masses: LAMMPS' ``fix nve/sphere`` without ``disc`` turns them as spheres),
        else disks (:func:`inertia_of`).

    Attributes
    ----------
    units : UnitSystem
        The dumps' units (:func:`granavg.io.dump_units.choose_units`).
    dim : int
    amap, cmap : dict
        The column maps used (our name -> the dump's column), for the sidecar.
    """

    def __init__(self, atoms, contacts=None, *, atom_map=None, contact_map=None,
                 wall_types=(), dt=None, units=None, dim=None, steps=None, inertia=None,
                 named_steps=False):
        stated = dump_header(atoms)[1]
        said = dump_header(contacts)[1] if contacts is not None else None
        unit_system = choose_units(stated or said, units)   # one dump saying them is enough
        if said is not None and stated is not None:
            if choose_units(said, None).style != unit_system.style:
                raise UserError(f"{said[1]}: the contact dump says 'units {said[0]}', the "
                                f"atom dump's units are {unit_system.style}; use the dumps "
                                "of one run")
        self._head = (atoms, None)
        self.skipped_before = None
        self.dim, self.dim_reason = dimension(atoms, atom_map or {}, dim)
        self.amap = resolve_atoms(atoms, atom_map or {}, self.dim)
        self.cmap = resolve_contacts(contacts, contact_map or {}, self.dim) \
            if contacts else None
        self.wall_types = np.asarray(list(wall_types), dtype=float)
        if len(self.wall_types) and "type" not in self.amap:
            raise ParameterError("wall_types", f"{literal(atoms)}: {{param}} needs the atoms' "
                                 "type column")
        if self.cmap is not None and "id" not in self.amap:
            raise UserError(f"{atoms}: contacts need the atoms' id column")
        if inertia not in (None, "disk", "sphere") or (self.dim == 3 and inertia == "disk"):
            raise ParameterError("inertia", f"{{param}} {inertia}: give disk or sphere "
                                 "(3D: sphere)")
        self.inertia = (inertia, "given") if inertia else None
        window = dict(steps=steps, named_steps=named_steps)
        super().__init__(DumpReader(atoms, sorted(set(self.amap.values())), **window,
                                    prepare=self._atoms),
                         DumpReader(contacts, sorted(set(self.cmap.values())), **window)
                         if self.cmap is not None else None, dt, unit_system)

    format_name = "lammps"

    def skip_before(self, t_min: float) -> bool:
        """Pass over the frames before ``t_min`` by scanning, their rows not parsed: the
        frames the averaging would leave out, no more. By their ``ITEM: TIME`` where the
        first frame has one, else from the first time step s with s dt >= t_min (the
        averaging's own test); the contact dump from the first atom frame kept
        (:class:`~granavg.io.frames.PairedDumps`). Not where a window of steps is set (a
        dask worker's) or no time is known; returns whether frames are skipped."""
        if not t_min > 0 or self.atoms.steps is not None:
            return False
        if self.first().time is not None:
            self.atoms.from_time = t_min
        elif self.dt is not None:
            s = max(math.ceil(t_min / self.dt), 0)
            while s > 0 and (s - 1) * self.dt >= t_min:
                s -= 1
            while s * self.dt < t_min:
                s += 1
            self.atoms.steps = (s, sys.maxsize)
        else:
            return False
        self.skipped_before = t_min
        return True

    def describe(self) -> dict:
        """The options the frames were read with, for the sidecar."""
        shape, why = self.inertia or (("sphere", "3D") if self.dim == 3 else
                                      ("disk", "no frame read"))
        return {"atom_columns": self.amap, "contact_columns": self.cmap,
                **({"scanned_past": f"the frames before t = {self.skipped_before:g}, "
                                    "rows not parsed"}
                   if self.skipped_before is not None else {}),
                "wall_types": [int(t) for t in self.wall_types], "dt": self.dt,
                "dim": self.dim, "inertia": {"shape": shape, "I": INERTIA_TEXT[shape],
                                             "why": why}}

    def box(self):
        """The bounds of the atom dump's first frame's cell (of a tilted box: its own,
        not its bounding box's; :class:`~granavg.io.box.Box`), one (lo, hi) per axis of
        the dimension."""
        return Box.of(self.first()).bounds(self.dim)

    def periodic(self) -> tuple:
        """Per axis of the dimension, whether the box is periodic along it (``pp``)."""
        return tuple(b == "pp" for b in self.first().boundary[:self.dim])

    def tilt(self) -> tuple:
        """The first frame's tilt factors (xy, xz, yz): zeros for an orthogonal box."""
        return Box.of(self.first()).tilt

    def first(self):
        """The atom dump's first frame (its box and boundary; its header alone, the rows
        left to the frames' reading), read once."""
        path, frame = self._head
        if frame is None:
            frame = DumpReader(path, []).first_header()
            if frame is None:
                raise UserError(f"{self.atoms.path}: holds no frame")
            self._head = (path, frame)
        return frame

    def frame(self, fa, fc) -> Frame:
        atoms, walls = fa.prepared or self._atoms(fa)     # done on a reader thread, or here
        atoms = self._turned(atoms)
        contacts = self._contacts(fc, atoms, walls) if fc is not None else None
        return Frame(fa.timestep, self.time(fa), atoms, contacts, box=Box.of(fa),
                     origin=self.origin(fa, fc, lines=not walls))

    def _atoms(self, fa):
        """The atoms' columns (ours, unscaled, wrapped into the box, checked) and the
        walls' ids and radii of one frame: no state, so the reader threads run it."""
        raw = fa.as_dict()
        col = check_atoms(fa.path, Columns({ours: raw[theirs] for ours, theirs in
                                            self.amap.items()}, fa))    # as in the file
        axes = "xyz"[:self.dim]
        box = Box.of(fa)
        scaled = [self.amap[a] in SCALED for a in axes]
        if box.tilted and any(scaled):
            if not all(scaled):
                raise UserError(f"{fa.path}: the box is tilted and only some coordinates "
                                "are scaled; dump x y z, or xs ys zs")
            col.update(zip(axes, box.unscale([col[a] for a in axes], self.dim)))
        elif any(scaled):
            for k, axis in enumerate(axes):
                if scaled[k]:
                    lo, hi = fa.box[k]
                    col[axis] = lo + col[axis] * (hi - lo)
        gate.inside(Rows(fa.path, fa, "atoms", col), box, self.dim)      # before folding
        col.update(zip(axes, box.wrap([col[a] for a in axes], self.dim)))  # periodic axes
        if self.amap["radius"] == "diameter":
            col["radius"] = 0.5 * col["radius"]
        if not len(self.wall_types):
            return col, {}
        wall = np.isin(col["type"], self.wall_types)
        walls = {"id": col["id"][wall], "radius": col["radius"][wall]} if "id" in col else {}
        return {k: v[~wall] for k, v in col.items()}, walls

    def _turned(self, atoms):
        """The atoms with their moments of inertia where they are not the engine's
        default for the dimension (2D: spheres), decided once (:func:`inertia_of`)."""
        if self.dim == 3:
            return atoms
        if self.inertia is None and len(atoms["radius"]):
            self.inertia = inertia_of(atoms)
            if self.inertia[0] == "sphere" or "cannot tell" in self.inertia[1]:
                log.info("2D particles turn as %ss (I = %s): %s; the inertia option "
                         "names the shape otherwise",
                         self.inertia[0], INERTIA_TEXT[self.inertia[0]], self.inertia[1])
        if self.inertia is not None and self.inertia[0] == "sphere" and "mass" in atoms:
            atoms["inertia"] = 0.4 * atoms["mass"] * atoms["radius"] ** 2
        elif self.inertia is not None and self.inertia[0] == "sphere":
            raise ParameterError("inertia", "{param} sphere in 2D needs the atoms' mass "
                                 "column (their masses are otherwise a disk's)")
        return atoms

    def _contacts(self, fc, atoms, walls):
        rows = self._rows(fc, atoms, walls)
        packing = rows.pop("packing")
        rows = check_contacts(fc.path, Columns(rows, fc))
        touching = self._touching(rows, fc)
        self.dropped["contacts_not_touching"] += int(np.sum(packing & ~touching))
        keep = packing & touching
        return {k: v[keep] for k, v in rows.items()}

    def _rows(self, fc, atoms, walls) -> dict:
        """The contact frame's rows as granavg's columns (:func:`~granavg.io.contacts.
        contact_columns`' ``packing`` and ``reach`` included), not yet checked."""
        raw = fc.as_dict()
        c = {ours: raw[theirs] for ours, theirs in self.cmap.items()}
        check_integers(fc.path, fc, c, ("id1", "id2"))
        if "wall" in c and "overlap" in c:                      # granavg's own format
            return dict(c, packing=np.ones(len(c["id1"]), bool))
        return self._convert(c, fc, atoms, walls)

    def _touching(self, rows, fc):
        """Contacts among the rows: overlap > 0, or a normal force (the overlap of a pair
        touching by less than the printed rounding, set to 0). A force between particles
        apart by more than rounding is refused: the radius column is not the radius."""
        overlap = rows["overlap"]
        force = np.zeros(len(overlap), bool)
        for x in "xyz"[:self.dim]:
            force |= rows[f"fn{x}"] != 0
        gap = force & (overlap <= 0)
        reach = rows.pop("reach", None)
        if gap.any():
            far = gap & (-overlap > CONSISTENCY * reach) if reach is not None else \
                np.zeros_like(gap)
            if far.any():
                k = int(np.flatnonzero(far)[0])
                raise UserError(
                    f"{row_at(fc.path, fc, k)}: atoms {int(rows['id1'][k])} and "
                    f"{int(rows['id2'][k])} carry a normal force but are {-overlap[k]:.3g} "
                    f"apart by their radii (timestep {fc.timestep}); check the radius or "
                    f"diameter column ({self.amap['radius']}) of the atom dump {self.atoms.path}")
            rows["overlap"] = overlap = np.where(gap, 0.0, overlap)
        return (overlap > 0) | force

    def _convert(self, c, fc, atoms, walls):
        ids = np.concatenate([atoms["id"], walls.get("id", np.zeros(0))])
        radii = np.concatenate([atoms["radius"], walls.get("radius", np.zeros(0))])
        is_wall = np.concatenate([np.zeros(len(atoms["id"]), int),
                                  np.ones(len(walls.get("id", [])), int)])
        (i1, found1), (i2, found2) = lookup(ids, c["id1"]), lookup(ids, c["id2"])
        self.unknown_ids(fc, c, found1, found2)
        xyz = "xyz"[:self.dim]
        dist = c["dist"]
        d = np.column_stack([c[f"d{x}"] for x in xyz])
        length = np.sqrt(np.sum(d * d, axis=1)) if self.dim == 3 else np.hypot(d[:, 0],
                                                                                 d[:, 1])
        off = np.abs(length - dist) > CONSISTENCY * dist
        if off.any():
            k = int(np.flatnonzero(off)[0])
            what = "(dx, dy)" if self.dim == 2 else "(dx, dy, dz)"
            raise UserError(f"{row_at(fc.path, fc, k)}: |{what}| = {length[k]:g} "
                            f"but dist = {dist[k]:g} (timestep {fc.timestep}), more apart "
                            "than printing's rounding; the dump is damaged or the column map "
                            "names the wrong columns")
        if all(f"fn{x}" in c for x in xyz):
            fn = np.column_stack([c[f"fn{x}"] for x in xyz])
        else:                                                 # repulsive along d
            fn = c["force"][:, None] * d / length[:, None]
        # without tangential forces the quantities that need them are left out
        ft = np.column_stack([c[f"ft{x}"] for x in xyz]) \
            if all(f"ft{x}" in c for x in xyz) else None
        return contact_columns(c["id1"], c["id2"], d, dist, fn, ft, is_wall[i1], is_wall[i2],
                               radii[i1], radii[i2], self._couples(c, d, dist, radii[i1],
                                                                   radii[i2]))

    def _couples(self, c, d, dist, r1, r2):
        """The contact couple on atom 1 from the mapped columns (the couple itself, or
        pair granular's rolling force and twisting torque); None if the dump has none."""
        own = couple_columns(self.dim)
        if all(k in c for k in own):
            return c["mz"] if self.dim == 2 else np.column_stack([c[k] for k in own])
        roll = [f"fr{x}" for x in "xyz"[:self.dim]]
        fr = np.column_stack([c[k] for k in roll]) if all(k in c for k in roll) else None
        if fr is None and "twist" not in c:
            return None
        return contact_couples(d, dist, fr, c.get("twist"), r1, r2)


#: The moments of inertia, in words.
INERTIA_TEXT = {"disk": "m a^2 / 2", "sphere": "2/5 m a^2"}
#: Masses scale as a^k within this relative spread.
SCALING = 1e-3


def inertia_of(atoms) -> tuple:
    """How 2D particles turn, from their masses: ``("sphere", why)`` where the mass
    column scales as a^3 (sphere masses, as ``fix pour`` and ``create_atoms`` without
    ``set density/disc`` give; LAMMPS' ``fix nve/sphere`` without ``disc`` then turns
    them with 2/5 m a^2), else ``("disk", why)``."""
    if "mass" not in atoms:
        return "disk", "no mass column: the masses are a disk's (the material density)"
    m, a = np.asarray(atoms["mass"], float), np.asarray(atoms["radius"], float)
    spread = {k: float(np.std(m / a ** k) / np.mean(m / a ** k)) for k in (2, 3)}
    if spread[3] < SCALING < spread[2]:
        return "sphere", "the masses scale as a^3 (sphere masses)"
    if spread[2] < SCALING < spread[3]:
        return "disk", "the masses scale as a^2 (disk masses)"
    return "disk", ("cannot tell from the masses (one size, or mixed densities): taken "
                    "as disks")


def _claims(path) -> bool:
    """A LAMMPS text dump (plain or gzip; the first of a series) starts with an ``ITEM:``
    line, a binary one with its format header (:mod:`granavg.io.binary_dump`), a ``dump
    yaml`` with its first document (:mod:`granavg.io.yaml_dump`)."""
    try:
        if "*" in Path(path).name or "%" in Path(path).name:
            path = first_file(path)
        if binary_dump.is_binary(path) or yaml_dump.is_yaml(path):
            return True
        with open_text(path) as fh:
            return fh.read(5) == "ITEM:"
    except (OSError, EOFError, UnicodeDecodeError, UserError):
        return False


FORMAT = Format("lammps", "LAMMPS dumps, text, binary or yaml: dump custom (atoms) and dump "
                "local (contacts: pair/local + property/local, or granavg's own columns)",
                _claims, LammpsDumps,
                (ATOM_MAP, CONTACT_MAP, WALL_TYPES, DT, UNITS, DIM, INERTIA, "steps",
                 "named_steps"))
