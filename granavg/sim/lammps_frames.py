"""Frames taken from a running LAMMPS (no files): this rank's atoms and contacts, and
their gathering to rank 0 under MPI. SI units.

Columns are those of granavg's dumps (docs/outputs.md), as float64 arrays, so the same
:func:`granavg.io.contacts.contact_table` and averaging kernels consume them.
"""

from __future__ import annotations

import numpy as np

from granavg.io.contacts import RAW_COLUMNS

#: per-atom columns taken from LAMMPS, in dump order
ATOM_COLUMNS = ["id", "type", "x", "y", "vx", "vy", "omegaz", "radius", "mass"]


def local_atoms(lmp) -> np.ndarray:
    """This rank's disks (types 1, 2; not wall disks), shape (n, 9), :data:`ATOM_COLUMNS`."""
    n = lmp.extract_global("nlocal")
    get = lmp.numpy.extract_atom
    typ = np.asarray(get("type")[:n])
    cols = np.column_stack([np.asarray(get("id")[:n], float), typ.astype(float),
                            np.asarray(get("x")[:n, :2]), np.asarray(get("v")[:n, :2]),
                            np.asarray(get("omega")[:n, 2]), np.asarray(get("radius")[:n]),
                            np.asarray(get("rmass")[:n])])
    return cols[typ <= 2]


def local_radii(lmp) -> np.ndarray:
    """This rank's atoms (wall disks included): id and radius (m), shape (n, 2)."""
    n = lmp.extract_global("nlocal")
    get = lmp.numpy.extract_atom
    return np.column_stack([np.asarray(get("id")[:n], float), np.asarray(get("radius")[:n])])


def local_contacts(lmp, lammps) -> np.ndarray:
    """This rank's rows of ``compute cprop`` + ``cpair`` (the deck's pair/local), shape
    (n, 11), columns :data:`granavg.io.contacts.RAW_COLUMNS`, or (n, 13) with the rolling
    force of a rolling-resistance law (:data:`~granavg.io.contacts.RAW_ROLLING`); each
    pair is on one rank."""
    loc, arr = lammps.LMP_STYLE_LOCAL, lammps.LMP_TYPE_ARRAY
    width = 4 + lmp.extract_compute("cpair", loc, lammps.LMP_SIZE_COLS)
    prop = lmp.numpy.extract_compute("cprop", loc, arr)
    pair = lmp.numpy.extract_compute("cpair", loc, arr)
    if prop is None or pair is None or not np.size(prop):      # no contact on this rank
        return np.empty((0, width))
    prop = np.asarray(prop).reshape(-1, 4)
    return np.hstack([prop, np.asarray(pair).reshape(len(prop), width - 4)])


def gather(comm, rows: np.ndarray):
    """All ranks' rows on rank 0 (in rank order), ``None`` on the others; ``comm=None``
    (one process) returns ``rows``."""
    if comm is None or comm.size == 1:
        return rows
    parts = comm.gather(rows, root=0)
    return np.vstack(parts) if comm.rank == 0 else None


def atoms_by_id(rows: np.ndarray) -> dict:
    """Rows of :func:`local_atoms` as dump columns, sorted by id (as the atom dump)."""
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    return dict(zip(ATOM_COLUMNS, rows.T))
