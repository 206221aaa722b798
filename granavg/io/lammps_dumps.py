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

import logging
import math
import sys
from pathlib import Path

import numpy as np

from granavg.errors import ParameterError, UserError, literal
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
from granavg.io.dump_columns import (SCALED, couple_columns, dimension, dump_header,
                                     resolve_atoms, resolve_contacts)
from granavg.io.dump_units import choose_units
from granavg.engine import gate

log = logging.getLogger(__name__)

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

    def skip_before(self, time: float) -> bool:
        """Pass over the frames before ``time`` by scanning, their rows not parsed: the
        frames the averaging would leave out, no more. By their ``ITEM: TIME`` where the
        first frame has one, else from the first time step s with s dt >= time (the
        averaging's own test); the contact dump from the first atom frame kept
        (:class:`~granavg.io.frames.PairedDumps`). Not where a window of steps is set (a
        dask worker's) or no time is known; returns whether frames are skipped."""
        if not time > 0 or self.atoms.steps is not None:
            return False
        if self.first().time is not None:
            self.atoms.from_time = time
        elif self.dt is not None:
            s = max(math.ceil(time / self.dt), 0)
            while s > 0 and (s - 1) * self.dt >= time:
                s -= 1
            while s * self.dt < time:
                s += 1
            self.atoms.steps = (s, sys.maxsize)
        else:
            return False
        self.skipped_before = time
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
