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

from granavg.engine import gate
from granavg.engine.gate import CONSISTENCY, Origin
from granavg.engine.unit_system import SI, UnitSystem
from granavg.errors import ParameterError, UserError, literal
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
    box : Box or None
        The frame's cell (:class:`~granavg.io.box.Box`), where the format gives one: the
        engine's gate checks it and its periods from frame to frame.
    origin : dict or None
        ``{"atoms": Origin, "contacts": Origin}``: where the tables were read
        (:class:`~granavg.engine.gate.Origin`), for the gate's messages.
    shear : Shear or None
        A sheared box's tilt and its rate (:class:`~granavg.engine.cells.base.Shear`),
        which the engine's gate sets from the frames' boxes.
    """

    timestep: int
    time: float
    atoms: dict
    contacts: dict | None
    rows: tuple | None = None
    box: object | None = None
    origin: dict | None = None
    shear: object | None = None

    def to_pandas(self, table: str = "atoms"):
        """The ``atoms`` or ``contacts`` columns as a :class:`pandas.DataFrame` (one row
        per atom or contact)."""
        import pandas as pd

        if table not in ("atoms", "contacts"):
            raise ParameterError("table", f"{{param}} {table!r}: give 'atoms' or 'contacts'")
        cols = getattr(self, table)
        if cols is None:
            raise UserError(f"time step {self.timestep}: the frame has no contacts (give "
                            "the contact dump)")
        return pd.DataFrame({k: np.asarray(v) for k, v in cols.items()})


class Rows:
    """One table of a dump frame as a frame of the gate (:mod:`granavg.engine.gate`):
    its messages name the file and line (or row, where ``line`` is None)."""

    def __init__(self, path, frame, table: str, cols: dict):
        self.timestep, self.time = frame.timestep, 0.0
        self.origin = {table: Origin(str(path), frame.line)}
        self.atoms = cols if table == "atoms" else {}
        self.contacts = cols if table == "contacts" else None


def check_integers(path, frame, cols, names):
    """Refuse a value that should be an integer (an id, a type, a wall code) and is not,
    and an id too large to be read exactly (:func:`granavg.engine.gate.integers`), read
    at ``frame.line`` of ``path``."""
    gate.integers(Rows(path, frame, "contacts", cols), "contacts", cols, names)


def check_atoms(path, frame) -> dict:
    """The frame's atom columns, judged where they are read (the gate's checks of values,
    :func:`granavg.engine.gate.atom_values`: messages name file and line). ``frame`` has
    ``as_dict()``, ``line`` (None: rows are not lines) and ``timestep``."""
    cols = frame.as_dict()
    gate.atom_values(Rows(path, frame, "atoms", cols))
    return cols


def check_contacts(path, frame) -> dict:
    """The frame's contact columns, judged where they are read (the gate's checks of
    values, :func:`granavg.engine.gate.contact_values`); normals returned normalised."""
    rows = Rows(path, frame, "contacts", frame.as_dict())
    gate.contact_values(rows, 3 if "nz" in rows.contacts else 2, normalise=True)
    return rows.contacts


class Columns:
    """Columns with the line and time step of the dump frame they came from (what the
    checks need to name file:line)."""

    def __init__(self, columns: dict, frame):
        self.columns, self.line, self.timestep = columns, frame.line, frame.timestep

    def as_dict(self) -> dict:
        return dict(self.columns)


def _line(frame) -> str:
    """`` (line L)`` of a dump frame read from lines, else nothing."""
    return "" if frame.line is None else f" (line {frame.line})"


def row_at(path, frame, k: int) -> str:
    """Where row ``k`` of a dump frame is: ``path:line``, or, where its rows are no
    lines (a binary file, processors' files), ``path (timestep T, row k)``."""
    if frame.line is None:
        return f"{path} (timestep {frame.timestep}, row {k + 1})"
    return f"{path}:{frame.line + k}"


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
                        f"{_file(fa, self.atoms)}{_line(fa)} but {fc.timestep} in "
                        f"{_file(fc, self.contacts)}{_line(fc)}; use dumps of the same run")
            yield self.frame(fa, fc)
        whole = getattr(self.atoms, "steps", None) is None and \
            getattr(self.atoms, "from_time", None) is None
        if c_iter is not None and whole:
            try:
                more = next(c_iter, None)
            except UserError:               # a damaged frame that is not used
                more = None
            if more is not None:
                log.warning("%s ends before timestep %d of %s: that frame and any later "
                            "are not used", self.atoms.path, more.timestep,
                            self.contacts.path)

    def frame(self, fa, fc) -> Frame:
        """The engine's frame of one atom-dump frame and its contact-dump frame (or None)."""
        raise NotImplementedError

    def origin(self, fa, fc=None, lines: bool = True) -> dict:
        """Where a frame's tables were read (:class:`~granavg.engine.gate.Origin`): the
        atom dump frame's file and, where its rows are the file's lines in order
        (``lines``: none left out; a text file, not a processor's share), its first
        line; the contact dump's file (its rows converted, some dropped: no line)."""
        path = _file(fa, self.atoms)
        out = {"atoms": Origin(str(path), fa.line if lines and "%" not in str(path)
                               else None)}
        if fc is not None:
            out["contacts"] = Origin(str(_file(fc, self.contacts)))
        return out

    def headers(self) -> list:
        """(timestep, time) of every frame of the atom dump, its rows not parsed."""
        from granavg.io.reader import DumpReader
        return [(h.timestep, self.time(h)) for h in
                DumpReader(self.atoms.path, [], headers_only=True)]

    def time(self, frame) -> float:
        """The frame's time: ``ITEM: TIME``, else timestep x ``dt``."""
        if frame.time is not None:
            return frame.time
        if self.dt is None:
            raise ParameterError("dt", f"{literal(self.atoms.path)}: frames have no ITEM: "
                                 "TIME and no time step is known; give the time step "
                                 "({param}, or the run directory whose manifest has it)")
        return frame.timestep * self.dt

    def unknown_ids(self, fc, rows, found1, found2):
        """Refuse contact rows whose atom ids are not among the frame's atoms (``found1``,
        ``found2``: whether each row's id1, id2 is; a wall partner counts as found),
        naming the first id that is not."""
        known = found1 & found2
        if not known.all():
            k = int(np.argmin(known))
            name = "id1" if not found1[k] else "id2"
            raise UserError(f"{row_at(_file(fc, self.contacts), fc, k)}: atom id "
                            f"{int(rows[name][k])} is not in {self.atoms.path} at timestep "
                            f"{fc.timestep}; use the atom and contact dumps of one run")
