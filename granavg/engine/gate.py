"""The gate every frame passes before the engine averages it, whatever wrote it.

A reader translates its format into frames and checks only what belongs to the format (a
cut chunk, a missing marker, a set of processor files); everything a frame must satisfy
to be averaged is checked here, once, for every source: LAMMPS' layouts, LIGGGHTS, VTK,
Yade (files and in process), frames in memory, a running LAMMPS. A new format gets every
check by handing its frames to the engine.

:func:`inspect` judges one frame by itself:

- atoms: the columns of the dimension (``x y [z] radius``), all of one length; every
  number finite and below :data:`LARGEST` in size; ids and types integers below 2^53;
  ids unique; radii and masses > 0;
- contacts: columns of one length; every number finite and below :data:`LARGEST`; ids
  integers naming atoms of the frame; wall codes 0, 1 or 2; no disk in contact with
  itself; normals unit vectors within :data:`CONSISTENCY` (refused beyond it, used as
  they are within it; a reader makes them unit); where the contacts carry their disks'
  positions (``x1 y1 [z1] x2 y2 [z2]``), the atoms' positions; a pair's overlap that of
  its atoms' centres and radii (:data:`GEOMETRY`; frames with a box);
- the box (where the frame has one): finite, every edge > 0.

:class:`Gate` adds what needs the frames before: time steps and times strictly
increasing, the same columns in every frame, and a box whose periodic axes keep their
flags and whose periodic lengths change only with the atoms inside it (a deforming
box). It also gives each frame of a sheared (tilted) box its
:class:`~granavg.engine.cells.base.Shear`: the tilt, and its rate from the frame before
(the first frame's from the frame after; a tilt that flips by a period counts as the
change it stands for). The rate is exact for a box sheared at a constant rate (LAMMPS'
``fix deform ... erate`` or ``vel``), first order in the frames' interval otherwise.

A refusal is one line: where (``file:line`` where the frame says where it was read,
``file (timestep T, atom row k)`` where its rows are no lines, a scene's body or
interaction by its ids, ``frame at timestep T, atom row k`` otherwise), what is wrong,
and what to do.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from granavg.engine._checks import contact_rows_checked, not_integers
from granavg.engine.cells.base import Shear
from granavg.engine.kernels import lookup
from granavg.errors import UserError

#: Largest relative disagreement accepted between numbers of one row that are equal in
#: exact arithmetic: |n| and 1 for a stored normal; a contact's stored positions and its
#: atoms'; a pair's centre distance and the sum of its radii less the overlap. A number
#: printed with p significant digits is off by at most 5 x 10^-p of itself, so LAMMPS'
#: default ``%g`` (p = 6) leaves at most about 1e-5 (9.4e-6 measured on a real dump);
#: 1e-4 accepts every format with p >= 5 and refuses real damage.
CONSISTENCY = 1e-4

#: Largest disagreement, relative to r1 + r2, of a pair contact's stored overlap with
#: r1 + r2 - |x1 - x2| from the atoms' positions: the motion of one step (an engine
#: that keeps the contact geometry of the step's start, as Yade; v dt is well below
#: 1e-3 of the radii in a stable run) and the radii's rounding.
GEOMETRY = 1e-3

#: Ids at or beyond 2^53 are not read exactly: dump values are read as doubles, whose
#: integers are exact only below it (two such ids may read as one).
EXACT_IDS = 2.0 ** 53

#: Largest size of a number a frame may hold: its square and the product of two (the
#: kinetic stress, the energies, the stress sums) stay finite doubles (below 1.8e308).
#: No physical value comes near it in any unit system.
LARGEST = 1e150

#: Columns that hold integers: ids (below :data:`EXACT_IDS`), types, wall codes.
IDS = ("id", "id1", "id2")
INTEGERS = {"atoms": ("id", "type"), "contacts": ("id1", "id2", "wall")}

#: Relative tolerance of two frames' periodic box lengths (a box that does not deform).
BOX_TOLERANCE = 1e-9
#: How far, as a share of its length, atoms may lie outside a periodic box that changed
#: its length (LAMMPS folds atoms back into the box only when it rebuilds its neighbour
#: lists: between rebuilds they move out by up to half the neighbour skin, a fraction of
#: a diameter).
OUTSIDE = 0.1

_AXES = ("x", "y", "z")

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Origin:
    """Where a table of a frame was read: the file and the line of its first row (None
    where rows are not lines of one file: a binary file, files of several processors).
    A scene in memory (``scene``: Yade's) names its rows by their ids (a body, an
    interaction) and says what to check there instead of a file's columns."""

    path: str
    line: int | None = None
    scene: str | None = None

    def at(self, row: int, timestep: int, table: str) -> tuple:
        """(where, what to add after the message): ``file:line`` and the timestep, or
        the file with the timestep and the row."""
        if self.line is None:
            return f"{self.path} (timestep {timestep}, {table[:-1]} row {row + 1})", ""
        return f"{self.path}:{self.line + row}", f" (timestep {timestep})"


def where(frame, table: str, row: int) -> tuple:
    """Where row ``row`` of the frame's ``table`` ("atoms", "contacts") comes from, and
    what the message adds after its text (:meth:`Origin.at`)."""
    origin = (getattr(frame, "origin", None) or {}).get(table)
    if origin is not None and origin.scene is not None:
        return f"{origin.path} at step {frame.timestep}, {_named(frame, table, row)}", ""
    if origin is not None:
        return origin.at(row, frame.timestep, table)
    return (f"frame at timestep {frame.timestep} (t = {frame.time:g}), {table[:-1]} row "
            f"{row + 1}", "")


def _named(frame, table: str, row: int) -> str:
    """A scene's row by its ids: ``body 7``, ``interaction 7-12``."""
    cols = frame.atoms if table == "atoms" else frame.contacts
    ids = [cols[k][row] for k in (("id",) if table == "atoms" else ("id1", "id2"))
           if k in cols and row < len(cols[k])]
    shown = "-".join(f"{v:g}" for v in ids) if ids else f"row {row + 1}"
    return f"{'body' if table == 'atoms' else 'interaction'} {shown}"


def source(frame) -> str:
    """The file the frame was read from (its atoms'), else the frame."""
    origin = (getattr(frame, "origin", None) or {}).get("atoms")
    return (f"{origin.path} (timestep {frame.timestep})" if origin is not None
            else f"frame at timestep {frame.timestep} (t = {frame.time:g})")


def refuse(frame, table: str, row: int, what: str, todo: str):
    place, after = where(frame, table, row)
    origin = (getattr(frame, "origin", None) or {}).get(table)
    if origin is not None and origin.scene is not None:
        todo = todo.replace(DAMAGED[table], origin.scene)
    raise UserError(f"{place}: {what}{after}; {todo}")


DAMAGED = {"atoms": "the atom data are damaged, or the column map names the wrong column",
           "contacts": "the contact data are damaged, of another run than the atoms, or "
                       "the column map names the wrong column"}


def _lengths(frame, table: str, cols: dict) -> int:
    """The table's number of rows; refuses columns of different lengths."""
    sizes = {k: len(v) for k, v in cols.items()}
    n = max(sizes.values(), default=0)
    short = next((k for k, m in sizes.items() if m != n), None)
    if short is not None:
        refuse(frame, table, sizes[short], f"column {short} has {sizes[short]} values "
               f"where others have {n}", DAMAGED[table])
    return n


def _finite(frame, table: str, cols: dict) -> None:
    """Refuse a number that is not finite or, in size, beyond :data:`LARGEST`."""
    for name, v in cols.items():
        v = np.asarray(v)
        if v.dtype.kind == "f" and not (np.abs(v) <= LARGEST).all():
            k = int(np.flatnonzero(~(np.abs(v) <= LARGEST))[0])
            what = f"{name} is {v[k]}" if not np.isfinite(v[k]) else \
                f"{name} is {v[k]:g}, beyond {LARGEST:g} (its products overflow)"
            refuse(frame, table, k, what, "the run blew up, or " + DAMAGED[table])


def integers(frame, table: str, cols: dict, names=None) -> None:
    """Refuse a value of the columns ``names`` (default the table's :data:`INTEGERS`)
    that is not an integer, and an id of 2^53 or more."""
    for name in INTEGERS[table] if names is None else names:
        if name not in cols:
            continue
        v = np.asarray(cols[name], float)
        bad, huge = not_integers(v, name in IDS, EXACT_IDS)       # one compiled pass
        if huge >= 0:
            refuse(frame, table, huge, f"{name} {v[huge]:.17g} is 2^53 or more (ids that "
                   "large are not read exactly: two may read as one)", "renumber the atoms "
                   "(LAMMPS: reset_atoms id) and dump again")
        if bad >= 0:
            refuse(frame, table, bad, f"{name} {v[bad]:g} is not an integer", DAMAGED[table])


def _duplicates(ids) -> int:
    """Row of the second appearance of an id, else -1 (a table where ids are dense)."""
    ids = np.asarray(ids)
    if len(ids) == 0:
        return -1
    lo, hi = ids.min(), ids.max()
    if lo >= 0 and hi < 8 * len(ids) + 1_000_000:
        if np.bincount(ids.astype(np.int64)).max() <= 1:
            return -1
    _, first = np.unique(ids, return_index=True)
    if len(first) == len(ids):
        return -1
    return int(np.setdiff1d(np.arange(len(ids)), first)[0])


def atoms(frame, dim: int) -> None:
    """Judge the frame's atom columns (the module docstring's list)."""
    cols = frame.atoms
    for name in (*_AXES[:dim], "radius"):
        if name not in cols:
            raise UserError(f"{source(frame)}: the atoms have no {name} column (columns: "
                            f"{' '.join(cols)}); dump it, or map it to a column of the dump")
    atom_values(frame)


def atom_values(frame) -> None:
    """Judge the values of the frame's atom columns: one length, integers, finite,
    unique ids, radii and masses > 0 (a reader may call it where the rows are read)."""
    cols = frame.atoms
    _lengths(frame, "atoms", cols)
    integers(frame, "atoms", cols)
    _finite(frame, "atoms", cols)
    if "id" in cols:
        k = _duplicates(cols["id"])
        if k >= 0:
            j = int(np.flatnonzero(np.asarray(cols["id"]) == cols["id"][k])[0])
            origin = (getattr(frame, "origin", None) or {}).get("atoms")
            also = f"line {origin.line + j}" if origin is not None and origin.line \
                is not None else f"row {j + 1}"
            refuse(frame, "atoms", k, f"atom id {int(cols['id'][k])} appears twice (also "
                   f"{also})", DAMAGED["atoms"])
    for name in ("radius", "mass"):
        if name in cols:
            bad = np.flatnonzero(~(np.asarray(cols[name]) > 0))
            if len(bad):
                refuse(frame, "atoms", int(bad[0]), f"{name} {cols[name][bad[0]]:g} is not "
                       "positive", "disks and spheres need a radius and a mass > 0: "
                       + DAMAGED["atoms"])


def contacts(frame, dim: int) -> None:
    """Judge the frame's contact columns (the module docstring's list); sets
    ``frame.rows`` where it can."""
    contact_values(frame, dim)
    cols = frame.contacts
    if "id" in frame.atoms and "id1" in cols:
        rows = _rows(frame, cols)
        if "x1" in cols:
            _positions(frame, cols, rows, dim)
        if "overlap" in cols:
            _overlaps(frame, cols, rows, dim)


def contact_values(frame, dim: int, normalise: bool = False) -> None:
    """Judge the values of the frame's contact columns: one length, integers, finite,
    wall codes, no contact with itself, unit normals within :data:`CONSISTENCY`; a reader
    may call it where the rows are read, with ``normalise``: its normals then made unit
    (the engine's gate does not change a frame)."""
    cols = frame.contacts
    n = _lengths(frame, "contacts", cols)
    integers(frame, "contacts", cols)
    _finite(frame, "contacts", cols)
    axes = [f"n{a}" for a in _AXES[:dim]]
    normals = all(a in cols for a in axes)
    column = {k: np.asarray(cols[k], float) if k in cols else None
              for k in ("id1", "id2", "wall", "nx", "ny", "nz")}
    if not normals:
        column["nx"] = column["ny"] = column["nz"] = None
    elif dim == 2:
        column["nz"] = None
    code, itself, norm, worst, off = contact_rows_checked(n, *column.values())  # one pass
    if code >= 0:
        refuse(frame, "contacts", code, f"wall code {cols['wall'][code]:g} is not 0, 1 or 2",
               DAMAGED["contacts"])
    if itself >= 0:
        refuse(frame, "contacts", itself, f"atom {int(cols['id1'][itself])} is in contact "
               "with itself", DAMAGED["contacts"])
    if normals and off > CONSISTENCY:
        shown = ", ".join(f"{cols[a][worst]:g}" for a in axes)
        refuse(frame, "contacts", worst, f"the contact normal ({shown}) is not a unit "
               f"vector (|n| - 1 = {norm[worst] - 1:.2g}, more than printing's rounding "
               f"{CONSISTENCY:g})", DAMAGED["contacts"])
    if normals and normalise:
        frame.contacts = {**cols, **{a: np.asarray(cols[a]) / norm for a in axes}}


def _rows(frame, cols) -> tuple:
    """Each contact's rows among the atoms (i1, i2; i2 = -1 for a wall); refuses an id
    the frame's atoms lack."""
    rows = getattr(frame, "rows", None)
    if rows is not None:
        return rows
    ids = frame.atoms["id"]
    i1, found1 = lookup(ids, cols["id1"])
    pair = np.asarray(cols["wall"]) == 0 if "wall" in cols else np.ones(len(i1), bool)
    i2, found2 = lookup(ids, cols["id2"]) if "id2" in cols else (i1, found1)
    lost = ~found1 | (pair & ~found2)
    if lost.any():
        k = int(np.flatnonzero(lost)[0])
        missing = cols["id1"][k] if not found1[k] else cols["id2"][k]
        refuse(frame, "contacts", k, f"atom id {int(missing)} is not among the frame's atoms",
               "use the atom and contact data of one run and time step")
    rows = (i1, np.where(pair, i2, -1))
    try:
        frame.rows = rows
    except AttributeError:
        pass
    return rows


def _positions(frame, cols, rows, dim: int) -> None:
    """Refuse contacts whose stored positions of their disks are not the atoms' (to
    :data:`CONSISTENCY` of the coordinates' size, up to a period of a periodic axis)."""
    i1, i2 = rows
    box = getattr(frame, "box", None)
    for end, i in (("1", i1), ("2", i2)):
        ok = i >= 0
        for a, axis in zip(_AXES[:dim], range(dim)):
            name = f"{a}{end}"
            if name not in cols:
                continue
            x = np.asarray(frame.atoms[a])[i[ok]]
            d = np.asarray(cols[name])[ok] - x
            if box is not None and box.periodic[axis]:
                length = box.hi[axis] - box.lo[axis]
                d = d - length * np.round(d / length)
            scale = np.abs(x) + np.asarray(frame.atoms["radius"])[i[ok]]
            off = np.abs(d) > CONSISTENCY * np.maximum(scale, 1e-300)
            if off.any():
                k = int(np.flatnonzero(ok)[np.flatnonzero(off)[0]])
                refuse(frame, "contacts", k, f"{name} {cols[name][k]:g} but atom "
                       f"{int(frame.atoms['id'][i[k]])} is at {a} = "
                       f"{frame.atoms[a][i[k]]:g}", "the contacts are of another run or "
                       "time step than the atoms: use the dumps of one run")


def _overlaps(frame, cols, rows, dim: int) -> None:
    """Refuse pair contacts whose overlap is not that of their atoms: r1 + r2 - |x1 - x2|
    (nearest image along periodic axes) within :data:`GEOMETRY` of r1 + r2, plus
    :data:`CONSISTENCY` of the coordinates' size (printed positions). Frames without a
    box (its periodic axes unknown) are not judged."""
    box = getattr(frame, "box", None)
    i1, i2 = rows
    pair = np.flatnonzero(i2 >= 0)
    if box is None or not len(pair) or any(getattr(box, "tilt", (0.0,)) or ()):
        return                                  # (a tilted box: its images are not judged)
    j1, j2 = i1[pair], i2[pair]
    d2, reach = np.zeros(len(pair)), np.zeros(len(pair))
    for axis, a in enumerate(_AXES[:dim]):
        x = np.asarray(frame.atoms[a], float)
        d = x[j1] - x[j2]
        if box.periodic[axis]:
            length = box.hi[axis] - box.lo[axis]
            d = d - length * np.round(d / length)
        d2 += d * d
        reach += np.abs(x[j1]) + np.abs(x[j2])
    r = np.asarray(frame.atoms["radius"], float)
    size = r[j1] + r[j2]
    overlap = np.asarray(cols["overlap"], float)[pair]
    off = np.abs(np.sqrt(d2) - (size - overlap)) > GEOMETRY * size + CONSISTENCY * reach
    if off.any():
        k = int(np.flatnonzero(off)[0])
        refuse(frame, "contacts", int(pair[k]), f"the overlap {overlap[k]:g} of atoms "
               f"{int(frame.atoms['id'][j1[k]])} and {int(frame.atoms['id'][j2[k]])} is not "
               f"that of their centres and radii ({size[k] - np.sqrt(d2[k]):g})",
               "the contacts' distance column is wrong, or the contacts are of another "
               "run or time step than the atoms: check the column map, use the dumps of "
               "one run")


def box(frame) -> None:
    """Refuse a box that is not finite or has an edge <= 0."""
    b = getattr(frame, "box", None)
    if b is None:
        return
    lo, hi = np.asarray(b.lo, float), np.asarray(b.hi, float)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.all(hi > lo)):
        raise UserError(f"{source(frame)}: the box bounds {list(zip(lo, hi))} are not "
                        "finite with hi > lo; the box lines are damaged")


def inspect(frame, dim: int) -> None:
    """Judge one frame by itself (the module docstring's list); one-line refusals."""
    atoms(frame, dim)
    if frame.contacts is not None:
        contacts(frame, dim)
    box(frame)


class Gate:
    """The checks of a sequence of frames: each by itself (:func:`inspect`), and against
    the frames before it (time steps and times, columns, periodic box).

    Parameters
    ----------
    dim : int
        The frames' dimension (the cells').
    """

    def __init__(self, dim: int):
        self.dim = dim
        self.last = None            # the frame before: (timestep, time, where)
        self.columns = None         # the first frame's atom and contact columns
        self.periodic = None        # the first frame's periodic flags and lengths
        self.seen = ()              # frames admitted ahead of their turn (the head)
        #: the first two frames' spacing (None before two)
        self.spacing = None
        self.tilts = None           # the frame before's (time, tilt, lengths)

    def admit(self, frame) -> None:
        """Refuse the frame, in one line, if it cannot be averaged after those before."""
        if any(frame is f for f in self.seen):
            return
        inspect(frame, self.dim)
        self._sequence(frame)

    def ahead(self, frames) -> None:
        """Admit ``frames`` now (an averager's head) and pass them later; the first
        frame of a sheared box takes the tilt's rate to the second."""
        for frame in frames:
            self.admit(frame)
        self.seen = tuple(frames)
        first = frames[0] if frames else None
        if getattr(first, "shear", None) is None:
            return
        if len(frames) > 1 and getattr(frames[1], "shear", None) is not None:
            first.shear = Shear(first.shear.tilt, frames[1].shear.rate)
        elif len(frames) == 1:
            log.warning("%s: one frame of a tilted box: the tilt's rate (two frames give "
                        "it) is taken as 0, so images across its sheared faces move as "
                        "their atoms do", source(first))

    def _sequence(self, frame) -> None:
        step, t = frame.timestep, frame.time
        if self.last is not None:
            step0, t0, at0 = self.last
            if not step > step0:
                raise UserError(f"{source(frame)}: timestep {step} does not follow "
                                f"timestep {step0} of {at0}; frames must come in "
                                "increasing time (remove the repeated or stray frames)")
            if not t > t0:
                raise UserError(f"{source(frame)}: time {t:.17g} does not follow time "
                                f"{t0:.17g} of {at0} while the timestep increases; the "
                                "times are damaged (or a wrong time step: give the run's)")
            if self.spacing is None:
                self.spacing = t - t0
        self.last = (step, t, source(frame))
        cols = (frozenset(frame.atoms), None if frame.contacts is None
                else frozenset(frame.contacts))
        if self.columns is None:
            self.columns = cols
        elif cols != self.columns:
            self._columns_differ(frame, cols)
        self._box(frame)

    def _columns_differ(self, frame, cols) -> None:
        (a0, c0), (a1, c1) = self.columns, cols
        if c0 is None or c1 is None:
            what = "has no contacts" if c1 is None else "has contacts"
            raise UserError(f"{source(frame)}: {what}, unlike the first frame; every frame "
                            "must carry the same data (the dumps are damaged or mixed)")
        lost, extra = sorted((a0 - a1) | (c0 - c1)), sorted((a1 - a0) | (c1 - c0))
        what = f"lacks the column {lost[0]}" if lost else f"has the column {extra[0]}"
        raise UserError(f"{source(frame)}: {what}, unlike the first frame; every frame "
                        "must carry the same columns (the dumps are damaged or mixed)")

    def _box(self, frame) -> None:
        b = getattr(frame, "box", None)
        if b is None:
            return
        self._shear(frame, b)
        flags = tuple(bool(p) for p in b.periodic[:self.dim])
        lengths = np.subtract(b.hi, b.lo)[:self.dim]
        if self.periodic is None:
            self.periodic = (flags, lengths)
            return
        flags0, lengths0 = self.periodic
        self.periodic = (flags0, lengths)
        if flags != flags0:
            raise UserError(f"{source(frame)}: periodic along {_axes(flags)}, where the "
                            f"first frame is periodic along {_axes(flags0)}; the box lines "
                            "are damaged, or the dumps are of several runs")
        for k in range(self.dim):
            if flags[k] and abs(lengths[k] - lengths0[k]) > BOX_TOLERANCE * lengths0[k]:
                self._deformed(frame, b, k, lengths0[k])

    def _shear(self, frame, b) -> None:
        """The frame's :class:`~granavg.engine.cells.base.Shear` (None for a box that is
        not tilted and was not before): its tilt, and the rate from the frame before
        (xy and xz flip by lx, yz by ly)."""
        tilt = tuple(float(v) for v in getattr(b, "tilt", (0.0, 0.0, 0.0)))
        rate = (0.0, 0.0, 0.0)
        if self.tilts is not None:
            t0, tilt0, lengths = self.tilts
            dt = frame.time - t0
            flips = (lengths[0], lengths[0], lengths[1])
            rate = tuple(float((v - v0) - p * np.round((v - v0) / p)) / dt if p > 0 else 0.0
                         for v, v0, p in zip(tilt, tilt0, flips))
        self.tilts = (frame.time, tilt, np.subtract(b.hi, b.lo))
        if any(tilt) or any(rate):
            frame.shear = Shear(tilt, rate)

    def _deformed(self, frame, b, k: int, before: float) -> None:
        """Accept a periodic length that changed from the frame before (a deforming
        box: LAMMPS' fix deform, Yade's cell) where the atoms lie in the new box
        (:func:`inside`)."""
        inside(frame, b, self.dim, f", where the frame before's is {before:g},")


def inside(frame, b, dim: int, said: str = "") -> None:
    """Refuse atoms that lie outside a periodic axis of box ``b`` by more than
    :data:`OUTSIDE` of its length and a diameter (damaged box lines: the atoms would be
    folded into a box that is not theirs); a reader calls it before it folds them. A
    tilted box is not judged (its atoms lie within its parallelepiped, not its bounds)."""
    if any(getattr(b, "tilt", (0.0,)) or ()):
        return
    r = np.max(np.asarray(frame.atoms["radius"], float), initial=0.0)
    for k in range(dim):
        if not b.periodic[k]:
            continue
        x = np.asarray(frame.atoms[_AXES[k]], float)
        length = b.hi[k] - b.lo[k]
        beyond = float(np.max(np.maximum(b.lo[k] - x, x - b.hi[k]), initial=0.0))
        if beyond > OUTSIDE * length + 2 * r:
            raise UserError(f"{source(frame)}: the periodic box is {length:g} long in "
                            f"{_AXES[k]}{said} and atoms lie up to {beyond:g} outside it; "
                            "the box lines are damaged, or the dumps are of several runs")


def _axes(flags) -> str:
    return " ".join(a for a, p in zip(_AXES, flags) if p) or "no axis"
