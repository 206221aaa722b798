"""The per-contact table: from LAMMPS' pair/local output to granavg's contact dump.

LAMMPS' ``compute pair/local`` lists atom pairs (``dx = x_1 - x_2``, ``fx fy`` the
normal and ``p1 p2`` the tangential force on atom 1) but not the overlap, which is
``r_1 + r_2 - dist``. :func:`contact_columns` adds it, the unit normal and a wall flag,
and puts the wall atom second so that for a wall contact the forces are those on the
disk. Every contact source goes through it: the in-process writer and the converter of a
LAMMPS-written ``contacts_raw`` dump (:func:`contact_table`) and anyone's pair/local
dumps (:mod:`granavg.io.lammps_dumps`).

Columns of the contact dump (SI units; documented in docs/outputs.md; in 3D with
``fnz``, ``ftz`` and ``nz`` too):

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


def contact_columns(id1, id2, d, dist, fn, ft, wall1, wall2, r1, r2) -> dict:
    """Pair/local quantities of atom pairs -> granavg's contact columns: the one
    conversion every contact source goes through, in 2D or 3D.

    Parameters
    ----------
    id1, id2 : ndarray, shape (n,)
        Atom ids of each pair.
    d : ndarray, shape (n, D)
        ``x_1 - x_2`` (dx, dy[, dz]), and ``dist`` shape (n,) the centre distance (as
        printed: they agree only to the printed precision; the normal is d over its own
        length).
    fn, ft : ndarray, shape (n, D)
        Normal and tangential force on atom 1; ``ft`` None where the data hold no
        tangential force (then the result has no ``ft<x>`` columns).
    wall1, wall2 : ndarray of int, shape (n,)
        Wall code of each atom: 0 a particle of the packing, 1 or 2 a wall.
    r1, r2 : ndarray, shape (n,)
        Radii.

    Returns
    -------
    dict of str -> ndarray, shape (n,)
        ``id1 id2 wall``, ``fn<x>``, ``ft<x>``, ``n<x>`` for the D axes x, y[, z] and
        ``overlap``, with the wall atom second (its forces and normal as seen by the
        particle), plus ``packing`` (False for wall-wall pairs) and ``reach`` (r1 + r2).
    """
    d, fn = np.asarray(d, float), np.asarray(fn, float)
    ft = None if ft is None else np.asarray(ft, float)
    swap = (wall1 > 0) & (wall2 == 0)                 # the particle goes first
    sign = np.where(swap, -1.0, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        length = np.sqrt(np.sum(d * d, axis=1)) if d.shape[1] == 3 else np.hypot(d[:, 0],
                                                                                   d[:, 1])
        n = -d / length[:, None]                      # from atom 1 towards atom 2
    out = {"id1": np.where(swap, id2, id1), "id2": np.where(swap, id1, id2),
           "wall": np.where(swap, wall1, wall2).astype(float)}
    for k, x in enumerate("xyz"[:d.shape[1]]):
        out[f"fn{x}"] = sign * fn[:, k]
        if ft is not None:
            out[f"ft{x}"] = sign * ft[:, k]
    for k, x in enumerate("xyz"[:d.shape[1]]):
        out[f"n{x}"] = sign * n[:, k]
    out.update({"overlap": r1 + r2 - dist, "packing": (wall1 == 0) | (wall2 == 0),
                "reach": r1 + r2})
    return out


def contact_table(raw: np.ndarray, radius_of_id: np.ndarray) -> np.ndarray:
    """Raw pair/local rows of granavg's deck -> contact-dump rows
    (:func:`contact_columns`; wall codes from the atom types).

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
    c = contact_columns(id1, id2, np.column_stack([dx, dy]), dist,
                        np.column_stack([fnx, fny]), np.column_stack([ftx, fty]),
                        WALL_FLAG_OF_TYPE[t1.astype(int)], WALL_FLAG_OF_TYPE[t2.astype(int)],
                        radius_of_id[id1.astype(int)], radius_of_id[id2.astype(int)])
    keep = c["packing"] & (c["overlap"] > 0)
    return np.column_stack([c[k] for k in COLUMNS])[keep]


def radius_by_id(ids, radius) -> np.ndarray:
    """Lookup array for :func:`contact_table`: ``out[id]`` is the radius (m) of atom ``id``
    (ids and radii of every atom, walls included, e.g. from a data file), shape
    (max_id + 1,); NaN where no atom has the id."""
    ids = np.asarray(ids, dtype=int)
    out = np.full(int(ids.max(initial=0)) + 1, np.nan)
    out[ids] = radius
    return out
