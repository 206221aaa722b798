"""The per-contact table: from LAMMPS' pair/local output to granavg's contact dump.

LAMMPS' ``compute pair/local ... cutoff radius`` lists every touching pair once
(``dx = x_1 - x_2``, ``fx fy`` the normal and ``p1 p2`` the tangential force on atom 1)
but not the overlap, which is ``r_1 + r_2 - dist``. :func:`contact_table` adds it, the
unit normal and a wall flag, and puts the wall disk second so that for a wall contact
the forces are those on the disk. Both the in-process writer and the converter of a
LAMMPS-written ``contacts_raw`` dump use it.

Columns of the contact dump (SI units; documented in docs/outputs.md):

=========  =========================================================================
id1, id2   atom ids; id1 is always a disk, id2 a disk or a wall disk
wall       0 disk-disk, 1 contact with the inner (rotating) wall, 2 outer wall
fnx, fny   normal force on atom 1, N
ftx, fty   tangential (friction) force on atom 1, N
nx, ny     unit contact normal from the centre of atom 1 towards atom 2
overlap    r1 + r2 - |x1 - x2| > 0, m
=========  =========================================================================
"""

from __future__ import annotations

import numpy as np

COLUMNS = ["id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny", "overlap"]
FORMAT = ["%d", "%d", "%d"] + ["%.12g"] * 7
RAW_COLUMNS = ["id1", "id2", "type1", "type2", "dx", "dy", "dist", "fnx", "fny", "ftx", "fty"]
#: LAMMPS atom types: 1 small disk, 2 large disk, 3 inner wall, 4 outer wall.
WALL_FLAG_OF_TYPE = np.array([0, 0, 0, 1, 2])


def contact_table(raw: np.ndarray, radius_of_id: np.ndarray) -> np.ndarray:
    """Turn raw pair/local rows into contact-dump rows.

    Parameters
    ----------
    raw : ndarray, shape (n, 11)
        Columns :data:`RAW_COLUMNS` (ids, types, dx, dy, dist in m, forces in N).
    radius_of_id : ndarray, shape (max_id + 1,)
        Radius (m) of each atom by id (:func:`radius_by_id`; disks of one type may differ
        in size).

    Returns
    -------
    ndarray, shape (n, 10)
        Columns :data:`COLUMNS`; rows with overlap <= 0 (not contacts) are dropped.
    """
    raw = np.asarray(raw, dtype=float).reshape(-1, len(RAW_COLUMNS))
    id1, id2, t1, t2, dx, dy, dist, fnx, fny, ftx, fty = raw.T
    t1, t2 = t1.astype(int), t2.astype(int)
    swap = WALL_FLAG_OF_TYPE[t1] > 0          # put the wall disk second
    sign = np.where(swap, -1.0, 1.0)
    length = np.hypot(dx, dy)                 # = dist up to rounding; the normal is unit
    out = np.column_stack([
        np.where(swap, id2, id1), np.where(swap, id1, id2),
        WALL_FLAG_OF_TYPE[np.where(swap, t1, t2)],
        sign * fnx, sign * fny, sign * ftx, sign * fty,
        -sign * dx / length, -sign * dy / length,
        radius_of_id[id1.astype(int)] + radius_of_id[id2.astype(int)] - dist,
    ])
    return out[out[:, 9] > 0]


def radius_by_id(ids, radius) -> np.ndarray:
    """Lookup array for :func:`contact_table`: ``out[id]`` is the radius (m) of atom ``id``
    (ids and radii of every atom, walls included, e.g. from a data file), shape
    (max_id + 1,); NaN where no atom has the id."""
    ids = np.asarray(ids, dtype=int)
    out = np.full(int(ids.max(initial=0)) + 1, np.nan)
    out[ids] = radius
    return out
