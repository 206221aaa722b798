"""The per-contact table: from LAMMPS' pair/local output to granavg's contact dump.

LAMMPS' ``compute pair/local`` lists atom pairs (``dx = x_1 - x_2``, ``fx fy`` the
normal and ``p1 p2`` the tangential force on atom 1; with ``pair granular``, ``p5 p6
[p7]`` the rolling-resistance force and ``p9`` the twisting torque) but not the overlap,
which is ``r_1 + r_2 - dist``, nor the contact couple: :func:`contact_couples` forms it
from the rolling force with the law's own lever arm. :func:`contact_columns` adds it, the unit normal and a wall flag,
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
mz         the contact couple on atom 1 (rolling and, in 3D, twisting resistance), N m:
           beyond the moment of the forces; 0 for a law without it (``mx my mz`` in 3D)
=========  =========================================================================

The couple is what ``pair granular``'s rolling and twisting models add to the torque
(LAMMPS 2025.7.22, checked against per-atom torques to 3e-16 in tests/test_couples.py):
R_eff (n_21 x F_r) + tau_twist n_21 on atom 1, its opposite on atom 2, with n_21 the unit
vector from atom 2 to atom 1 (``dx / dist``), R_eff = r1 r2 / (r1 + r2), F_r the rolling
force (``p5 p6 p7``) and tau_twist ``p9``.
"""

from __future__ import annotations

import numpy as np

COLUMNS = ["id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny", "overlap", "mz"]
FORMAT = ["%d", "%d", "%d"] + ["%.12g"] * 8
RAW_COLUMNS = ["id1", "id2", "type1", "type2", "dx", "dy", "dist", "fnx", "fny", "ftx", "fty"]
#: The deck's raw columns with a rolling-resistance law (``pair granular``: p5 p6).
RAW_ROLLING = ["frx", "fry"]
#: LAMMPS atom types: 1 small disk, 2 large disk, 3 inner wall, 4 outer wall.
WALL_FLAG_OF_TYPE = np.array([0, 0, 0, 1, 2])


def contact_couples(d, dist, fr, twist, r1, r2):
    """The contact couple on atom 1 of ``pair granular``'s rolling and twisting models.

    Parameters
    ----------
    d : ndarray, shape (n, D)
        ``x_1 - x_2``; ``dist`` shape (n,) its length.
    fr : ndarray, shape (n, D), or None
        The rolling-resistance force (pair/local ``p5 p6 [p7]``); None: none.
    twist : ndarray, shape (n,), or None
        The twisting torque along ``d / dist`` (pair/local ``p9``, 3D); None: none.
    r1, r2 : ndarray, shape (n,)
        Radii.

    Returns
    -------
    ndarray, shape (n,) in 2D (the z component), (n, 3) in 3D
        R_eff (n_21 x F_r) + tau_twist n_21, n_21 = d / dist, N m.
    """
    d = np.asarray(d, float)
    D = d.shape[1]
    n21 = d / np.asarray(dist, float)[:, None]
    reff = r1 * r2 / (r1 + r2)
    if D == 2:
        m = np.zeros(len(d)) if fr is None else \
            reff * (n21[:, 0] * fr[:, 1] - n21[:, 1] * fr[:, 0])
        return m
    m = np.zeros((len(d), 3)) if fr is None else reff[:, None] * np.cross(n21, fr)
    if twist is not None:
        m = m + np.asarray(twist, float)[:, None] * n21
    return m


def contact_columns(id1, id2, d, dist, fn, ft, wall1, wall2, r1, r2, m=None) -> dict:
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
    m : ndarray, shape (n,) in 2D or (n, 3) in 3D, optional
        The contact couple on atom 1 (:func:`contact_couples`); None: the data hold none
        (then the result has no ``m<x>`` columns).

    Returns
    -------
    dict of str -> ndarray, shape (n,)
        ``id1 id2 wall``, ``fn<x>``, ``ft<x>``, ``n<x>`` for the D axes x, y[, z],
        ``overlap`` and the couple ``mz`` (2D) or ``mx my mz`` (3D), with the wall atom second (its forces and normal as seen by the
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
    if m is not None:
        m = np.asarray(m, float)
        if m.ndim == 1:
            out["mz"] = sign * m
        else:
            for k, x in enumerate("xyz"):
                out[f"m{x}"] = sign * m[:, k]
    out.update({"overlap": r1 + r2 - dist, "packing": (wall1 == 0) | (wall2 == 0),
                "reach": r1 + r2})
    return out


def contact_table(raw: np.ndarray, radius_of_id: np.ndarray) -> np.ndarray:
    """Raw pair/local rows of granavg's deck -> contact-dump rows
    (:func:`contact_columns`; wall codes from the atom types).

    Parameters
    ----------
    raw : ndarray, shape (n, 11) or (n, 13)
        Columns :data:`RAW_COLUMNS` (ids, types, dx, dy, dist in m, forces in N), then
        with a rolling-resistance law :data:`RAW_ROLLING` (its force, N); without them
        the law has no couple (``mz`` 0).
    radius_of_id : ndarray, shape (max_id + 1,)
        Radius (m) of each atom by id (:func:`radius_by_id`; disks of one type may differ
        in size).

    Returns
    -------
    ndarray, shape (n, 11)
        Columns :data:`COLUMNS`; rows with overlap <= 0 (not contacts) are dropped.
    """
    raw = np.asarray(raw, dtype=float)
    raw = raw.reshape(-1, raw.shape[-1] if raw.ndim == 2 else len(RAW_COLUMNS))
    id1, id2, t1, t2, dx, dy, dist, fnx, fny, ftx, fty = raw[:, :len(RAW_COLUMNS)].T
    d = np.column_stack([dx, dy])
    r1, r2 = radius_of_id[id1.astype(int)], radius_of_id[id2.astype(int)]
    fr = raw[:, len(RAW_COLUMNS):] if raw.shape[1] > len(RAW_COLUMNS) else None
    c = contact_columns(id1, id2, d, dist,
                        np.column_stack([fnx, fny]), np.column_stack([ftx, fty]),
                        WALL_FLAG_OF_TYPE[t1.astype(int)], WALL_FLAG_OF_TYPE[t2.astype(int)],
                        r1, r2, contact_couples(d, dist, fr, None, r1, r2))
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
