"""Frames from CSV tables, for DEM codes other than LAMMPS (or a notebook's arrays).

Atoms: one row per disk and frame, columns ``step, time, x, y, radius`` and, as the
quantities need, ``id, vx, vy, omegaz, mass``; a frame's rows are contiguous, frames in
increasing ``step``. Contacts (optional): ``step`` and granavg's contact columns
``id1, id2, wall, fnx, fny, ftx, fty, nx, ny, overlap`` (:mod:`granavg.io.contacts`);
rows with overlap <= 0 are dropped and counted. Units are those of the numbers
(``units=`` names a LAMMPS style for the labels). The files are read whole (pandas).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from granavg.errors import UserError
from granavg.io.formats import UNITS, Format
from granavg.io.frames import Columns, Frame, check_atoms, check_contacts
from granavg.io.dump_units import choose_units

ATOMS = ("step", "time", "x", "y", "radius")
OPTIONAL = ("id", "vx", "vy", "omegaz", "mass")
CONTACTS = ("step", "id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny", "overlap")


def _table(path, need):
    import pandas as pd            # 0.2 s of import: only where a CSV table is read
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise UserError(f"{path}: not a readable CSV table ({str(exc).splitlines()[0]})") \
            from None
    missing = [c for c in need if c not in table.columns]
    if missing:
        raise UserError(f"{path}: column {missing[0]!r} is missing (columns: "
                        f"{', '.join(table.columns)}); write it in the table")
    bad = [c for c in table.columns if not pd.api.types.is_numeric_dtype(table[c])]
    if bad:
        raise UserError(f"{path}: column {bad[0]!r} holds non-numbers")
    blank = np.argwhere(~np.isfinite(table.to_numpy(float)))
    if len(blank):
        row, col = blank[0]
        raise UserError(f"{path}:{row + 2}: no finite value in column "
                        f"{table.columns[col]!r}; the table is damaged")
    step = table["step"].to_numpy()
    back = np.flatnonzero(np.diff(step) < 0)
    if len(back):
        raise UserError(f"{path}:{back[0] + 3}: step {step[back[0] + 1]} after step "
                        f"{step[back[0]]}; a frame's rows must be contiguous, in increasing "
                        "step")
    return table


class CsvFrames:
    """Frames of an atoms CSV and, optionally, a contacts CSV (see the module docstring).

    Parameters
    ----------
    atoms, contacts : path
    units : str, optional
        LAMMPS units style the numbers are in (labels only).
    """

    format_name = "csv"

    def __init__(self, atoms, contacts=None, *, units=None):
        self.atoms_path, self.contacts_path = Path(atoms), contacts
        self.atoms = _table(atoms, ATOMS)
        self.contacts = _table(contacts, CONTACTS) if contacts is not None else None
        if self.contacts is not None:
            if "id" not in self.atoms.columns:
                raise UserError(f"{atoms}: contacts need the atoms' id column")
            extra = np.setdiff1d(self.contacts["step"].unique(), self.atoms["step"].unique())
            if len(extra):
                row = int(np.flatnonzero(self.contacts["step"].to_numpy() == extra[0])[0])
                raise UserError(f"{contacts}:{row + 2}: step {extra[0]} is not a step of "
                                f"{atoms}; use the atom and contact tables of one run")
        self.units = choose_units(None, units)
        self.dropped = {"contacts_not_touching": 0}

    def describe(self) -> dict:
        return {}

    def box(self):
        """x and y bounds of the first frame's disks."""
        first = self.atoms[self.atoms["step"] == self.atoms["step"].iloc[0]]
        x, y, a = (first[c].to_numpy() for c in ("x", "y", "radius"))
        return (float((x - a).min()), float((x + a).max())), \
            (float((y - a).min()), float((y + a).max()))

    def __iter__(self):
        steps = self.atoms["step"].to_numpy()
        cuts = np.flatnonzero(np.diff(steps)) + 1
        c_groups = {}
        if self.contacts is not None:
            cs = self.contacts["step"].to_numpy()
            bounds = np.r_[0, np.flatnonzero(np.diff(cs)) + 1, len(cs)]
            c_groups = {int(cs[a]): (a, b) for a, b in zip(bounds[:-1], bounds[1:])}
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(steps)]):
            rows = self.atoms.iloc[a:b]
            step = int(steps[a])
            cols = {c: rows[c].to_numpy(float) for c in ("x", "y", "radius", *OPTIONAL)
                    if c in rows.columns}
            atoms = check_atoms(self.atoms_path, Columns(cols, _Where(a + 2, step)))
            contacts = None
            if self.contacts is not None:
                lo, hi = c_groups.get(step, (0, 0))
                part = self.contacts.iloc[lo:hi]
                rows_c = {c: part[c].to_numpy(float) for c in CONTACTS[1:]}
                rows_c = check_contacts(self.contacts_path, Columns(rows_c, _Where(lo + 2, step)))
                keep = rows_c["overlap"] > 0
                self.dropped["contacts_not_touching"] += int(np.sum(~keep))
                contacts = {k: v[keep] for k, v in rows_c.items()}
            yield Frame(step, float(rows["time"].iloc[0]), atoms, contacts)


class _Where:
    """The first line and the step of a frame's rows (for the checks' messages)."""

    def __init__(self, line, timestep):
        self.line, self.timestep = line, timestep


FORMAT = Format("csv", "CSV tables: atoms (step, time, x, y, radius, ...) and contacts "
                "(step and granavg's contact columns)",
                lambda path: path.name.endswith((".csv", ".csv.gz")), CsvFrames, (UNITS,))
