"""The frames every input format hands the engine, the checks every format applies to
them, and the pairing of a per-atom with a per-contact frame source by time step.

A *frame source* is any iterable of :class:`Frame` (in increasing time) with an attribute
``dropped`` (dict of counts of rows left out, for the sidecar) and ``units``
(:class:`~granavg.engine.unit_system.UnitSystem`); :mod:`granavg.io.formats` lists the formats
that make them from files.
"""

from __future__ import annotations

import itertools
import logging
import sys
from dataclasses import dataclass

import numpy as np

from granavg.engine.unit_system import SI, UnitSystem
from granavg.errors import ParameterError, UserError, literal
from granavg.io._checks import contact_rows_checked, not_integers
from granavg.io.prefetch import Prefetched

log = logging.getLogger(__name__)


@dataclass
class Frame:
    """One time step: per-atom and (optionally) per-contact columns.

    Attributes
    ----------
    timestep : int
    time : float
    atoms : dict of str -> ndarray, shape (P,)
        ``x y radius`` and, as available, ``vx vy omegaz id mass``.
    contacts : dict of str -> ndarray, shape (C,), or None
        ``id1 id2 wall fnx fny ftx fty nx ny overlap`` (:mod:`granavg.io.contacts`).
    rows : tuple of ndarray, shape (C,) each, or None
        (i1, i2): each contact's rows among the atoms, i2 = -1 for a wall contact, where
        the reader has looked them up (it checks the ids); else None, and the engine
        looks them up (:func:`granavg.engine.kernels.contact_rows`).
    """

    timestep: int
    time: float
    atoms: dict
    contacts: dict | None
    rows: tuple | None = None


#: Largest relative disagreement accepted between numbers of one row that are equal in
#: exact arithmetic: |n| and 1 for a stored normal; |(dx, dy)| and dist, and a pair's
#: centre distance and the sum of its radii where it carries a force (the overlap's
#: sign). A number printed with p significant digits is off by at most 5 x 10^-p of
#: itself, so LAMMPS' default ``%g`` (p = 6) leaves at most about 1e-5 (9.4e-6 measured
#: on a real dump); 1e-4 accepts every format with p >= 5 and refuses real damage.
CONSISTENCY = 1e-4


#: Ids at or beyond 2^53 are not read exactly: dump values are read as doubles, whose
#: integers are exact only below it (two such ids may read as one).
EXACT_IDS = 2.0 ** 53
IDS = ("id", "id1", "id2")


def check_integers(path, frame, cols, names):
    """Refuse a value that should be an integer (an id, a type, a wall code) and is not,
    and an id too large to be read exactly (:data:`EXACT_IDS`)."""
    for name in names:
        if name in cols:
            v = np.asarray(cols[name], float)
            bad, huge = not_integers(v, name in IDS, EXACT_IDS)       # one compiled pass
            if huge >= 0:
                raise UserError(
                    f"{path}:{frame.line + huge}: {name} {v[huge]:.17g} is 2^53 "
                    f"or more (timestep {frame.timestep}); ids that large are not read "
                    "exactly (two may read as one): renumber the atoms (LAMMPS: "
                    "reset_atoms id) and dump again")
            if bad >= 0:
                raise UserError(f"{path}:{frame.line + bad}: {name} {v[bad]:g} is not "
                                f"an integer (timestep {frame.timestep}); the dump is "
                                "damaged, or the column map names the wrong column")


def _has_duplicates(ids) -> bool:
    """Whether an id appears twice: by counting into a table where the ids are dense
    enough (O(n)), else by sorting."""
    if len(ids) == 0:
        return False
    lo, hi = ids.min(), ids.max()
    if lo >= 0 and hi < 8 * len(ids) + 1_000_000:
        return bool(np.bincount(ids.astype(np.int64)).max() > 1)
    return len(np.unique(ids)) < len(ids)


def check_atoms(path, frame) -> dict:
    """The frame's atom columns, after refusing ids or types that are not integers,
    duplicate ids and radii that are not positive (one line naming file, line and
    timestep). ``frame`` has ``as_dict()``, ``line`` and ``timestep``."""
    cols = frame.as_dict()
    check_integers(path, frame, cols, ("id", "type"))
    if "id" in cols and _has_duplicates(cols["id"]):
        ids = cols["id"]
        uniq, first, counts = np.unique(ids, return_index=True, return_counts=True)
        if len(uniq) < len(ids):
            dup = uniq[counts > 1][0]
            rows = np.flatnonzero(ids == dup)
            raise UserError(f"{path}:{frame.line + rows[1]}: atom id {int(dup)} appears twice "
                            f"in timestep {frame.timestep} (also line {frame.line + rows[0]}); "
                            "the dump is damaged")
    for name, why in (("mass", "the dump is damaged, or the column map names the wrong "
                               "column"), ("radius", "disks need a radius > 0")):
        bad = np.flatnonzero(~(cols[name] > 0)) if name in cols else ()
        if len(bad):
            raise UserError(f"{path}:{frame.line + bad[0]}: {name} {cols[name][bad[0]]:g} is "
                            f"not positive (timestep {frame.timestep}); {why}")
    return cols


def check_contacts(path, frame) -> dict:
    """The frame's contact columns, after refusing rows that make no sense: an id that is
    not an integer, a disk in contact with itself, an unknown wall code, a normal that is
    not a unit vector within :data:`CONSISTENCY`. Normals are returned normalised."""
    cols = frame.as_dict()

    def fail(row, what):
        raise UserError(f"{path}:{frame.line + row}: {what} (timestep {frame.timestep}); "
                        "the contact dump is damaged or not in granavg's format")
    check_integers(path, frame, cols, ("id1", "id2", "wall"))
    n = len(next(iter(cols.values()))) if cols else 0
    axes = [a for a in ("nx", "ny", "nz") if a in cols] if "nx" in cols and "ny" in cols \
        else []
    column = {k: np.asarray(cols[k], float) if k in cols else None
              for k in ("id1", "id2", "wall", "nx", "ny", "nz")}
    if not axes:
        column["nx"] = column["ny"] = column["nz"] = None
    code, itself, norm, worst, off = contact_rows_checked(n, *column.values())  # one pass
    if code >= 0:
        fail(code, f"wall code {cols['wall'][code]:g} is not 0, 1 or 2")
    if itself >= 0:
        fail(itself, f"atom {int(cols['id1'][itself])} is in contact with itself")
    if axes:
        if off > CONSISTENCY:
            shown = ", ".join(f"{cols[a][worst]:g}" for a in axes)
            fail(worst, f"the contact normal ({shown}) is not a unit vector (|n| - 1 = "
                 f"{norm[worst] - 1:.2g}, more than printing's rounding)")
        cols = {**cols, **{a: cols[a] / norm for a in axes}}
    return cols


class Columns:
    """Columns with the line and time step of the dump frame they came from (what the
    checks need to name file:line)."""

    def __init__(self, columns: dict, frame):
        self.columns, self.line, self.timestep = columns, frame.line, frame.timestep

    def as_dict(self) -> dict:
        return dict(self.columns)


def _file(frame, reader):
    """The file a frame is in (one file of a series), else the reader's path."""
    return getattr(frame, "path", None) or reader.path


class PairedDumps:
    """Frames of a per-atom dump paired by time step with those of a per-contact dump;
    a format adapter subclasses it and turns each pair into a :class:`Frame`
    (:meth:`frame`).

    Parameters
    ----------
    atoms : DumpReader
    contacts : DumpReader or None
        Without it, frames carry ``contacts=None`` (density and velocity need none).
    dt : float, optional
        Time step, for dumps without ``ITEM: TIME``.
    units : UnitSystem
        The dumps' units.
    """

    def __init__(self, atoms, contacts=None, dt=None, units: UnitSystem = SI):
        self.atoms, self.contacts, self.dt, self.units = atoms, contacts, dt, units
        #: rows dropped because they do not touch, for the sidecar
        self.dropped = {"contacts_not_touching": 0}

    def __iter__(self):
        atoms = iter(self.atoms)
        skipping = getattr(self.atoms, "steps", None) is not None or \
            getattr(self.atoms, "from_time", None) is not None
        if self.contacts is not None and skipping and getattr(self.contacts, "steps", 0) is None:
            # the atom dump's early frames are scanned past: the contact dump's up to its
            # first frame kept
            first = next(atoms, None)
            if first is not None:
                self.contacts.steps = (first.timestep, sys.maxsize)
                atoms = itertools.chain([first], atoms)
        # the contact dump is read ahead on a thread of its own: the two files'
        # decompression and parsing (both GIL-free) overlap
        c_iter = iter(Prefetched(self.contacts)) if self.contacts is not None else None
        try:
            yield from self._paired(atoms, c_iter)
        finally:
            if c_iter is not None:
                c_iter.close()

    def _paired(self, atoms, c_iter):
        for k, fa in enumerate(atoms):
            fc = None
            if c_iter is not None:
                fc = next(c_iter, None)
                if fc is None:
                    log.warning("%s ends at frame %d; the %d-th and later frames of %s are "
                                "not used", self.contacts.path, k, k + 1, self.atoms.path)
                    return
                if fc.timestep != fa.timestep:
                    raise UserError(
                        f"time steps do not match: frame {k + 1} is timestep {fa.timestep} in "
                        f"{_file(fa, self.atoms)} (line {fa.line}) but {fc.timestep} in "
                        f"{_file(fc, self.contacts)} (line {fc.line}); use dumps of the same "
                        "run")
            yield self.frame(fa, fc)

    def frame(self, fa, fc) -> Frame:
        """The engine's frame of one atom-dump frame and its contact-dump frame (or None)."""
        raise NotImplementedError

    def time(self, frame) -> float:
        """The frame's time: ``ITEM: TIME``, else timestep x ``dt``."""
        if frame.time is not None:
            return frame.time
        if self.dt is None:
            raise ParameterError("dt", f"{literal(self.atoms.path)}: frames have no ITEM: "
                                 "TIME and no time step is known; give the time step "
                                 "({param}, or the run directory whose manifest has it)")
        return frame.timestep * self.dt

    def unknown_ids(self, fc, rows, known):
        """Refuse contact rows whose atom ids are not among the frame's atoms."""
        if not known.all():
            k = int(np.argmin(known))
            raise UserError(f"{_file(fc, self.contacts)}:{fc.line + k}: atom id "
                            f"{int(rows['id1'][k]) if 'id1' in rows else '?'} (or its partner)"
                            f" is not in {self.atoms.path} at timestep {fc.timestep}; use the "
                            "atom and contact dumps of one run")
