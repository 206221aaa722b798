"""Per-frame sums of the cell averages (Eqs. 1-7): numpy, and kernels compiled ahead of time
(:mod:`granavg.engine._sums`).

For every cell k and channel c a frame contributes ``S[k, c] = sum_p w_pk Q_pc`` with
``w_pk`` the particle's volume fraction in the cell (:mod:`granavg.engine.weights`) and Q
the per-particle channel of :mod:`granavg.engine.channels` (volume, mass, momentum,
spin, contacts, fabric, stress, kinetic and deformation tensors, wall and body forces).
Vectors and tensors are in each particle's own basis at its centre (e_r, e_phi for
rings, the Cartesian axes for slabs and grids; three axes in 3D), tensors ordered as
:func:`granavg.engine.channels.pairs`, first index the force (or the deformation),
second the branch vector; nothing is symmetrised.

The boundary force density is not spread with the particles' weights: each wall
contact's force on the particle is put in the cell of its contact point
(:func:`wall_points`), where the wall acts (the cell at the edge if the point lies just
beyond it), in the basis there.

The branch vector l ends at the contact point: s = 1/2 (``branch="contact"``, the default,
l_1 - l_2 = r_12) or at the particle's surface, s = 0 (``branch="paper"``, Eq. 5 as
printed); :data:`BRANCHES`.

Eq. 5 as printed carries a factor V^p; with it sigma would not be a stress (N m rather
than Pa). The particle stress is (1/V^p) sum_c f (x) l, so V^p cancels: sigma =
(1/V) sum_p w sum_c f (x) l, which is what the sum rule sum_k V_k sigma_k =
sum_p sum_c f (x) l states. Delta^pc is the contact's normal deformation: the overlap
delta shortens the branch vector, Delta = -delta n (tension-positive, like sigma); Eq. 7's
pi h is V^p / a_p^2 of a disk (4/3 pi a_p for a sphere). The tangential spring is not
included: LAMMPS does not output it, and at the Coulomb limit it is not an elastic
deformation.
"""

from __future__ import annotations

import numpy as np

from granavg.engine._sums import (BLOCK_ORDER, accumulate_contacts, couple_channels,
                                   fill_particles, scatter, scatter_sectors, spin_energy,
                                   table_rows)
from granavg.engine.channels import BLOCKS, CONTACT_BLOCKS, Layout
from granavg.errors import UserError

#: How far each branch vector reaches, as the overlap it gives up: ``contact`` ends at
#: the middle of the overlap, l_p = (a_p - delta / 2) n, so that l_1 - l_2 = r_12 for
#: any two radii (the pair's centre distance: the stress then balances the forces);
#: ``paper`` is Eq. 5 as printed, l_p = a_p n, which reaches past the contact point by
#: delta / 2 and makes sigma too large by about delta / d.
BRANCHES = {"contact": 0.5, "paper": 0.0}
# the compiled kernels index Layout.offsets by these blocks' positions
assert BLOCKS[:len(BLOCK_ORDER)] == BLOCK_ORDER, "granavg.engine._sums is stale"


#: The contact blocks of the first compiled pass, in the order of its flags (the couple
#: and power blocks are :func:`_couple_channels`').
COMPILED_CONTACT_BLOCKS = ("ncontact", "fab", "sig", "def")

_last_rows = (None, None)               # (the arrays looked up, their rows), replaced whole


def contact_rows(atoms, contacts):
    """Rows of each contact's disks among the atoms: (i1, i2), i2 = -1 for a wall
    contact. The last frame's are kept: the cell sums and the per-frame state of one
    frame look them up once."""
    global _last_rows
    key = (atoms["id"], contacts["id1"], contacts["id2"], contacts["wall"])
    last, rows = _last_rows                 # one read: another thread may replace it
    if last is not None and all(a is b for a, b in zip(key, last)):
        return rows
    ids = atoms["id"]
    i1 = rows_of(ids, contacts["id1"])
    rows2, found2 = lookup(ids, contacts["id2"])
    pair = np.asarray(contacts["wall"]) == 0
    if not np.all(found2[pair]):
        _unknown(np.asarray(contacts["id2"])[pair & ~found2][0])
    i2 = np.where(pair, rows2, -1)
    _last_rows = (key, (i1, i2))
    return i1, i2


def frame_rows(frame):
    """The contact rows of a frame (:func:`contact_rows`): the reader's, if it looked
    them up (``frame.rows``), else looked up here."""
    rows = getattr(frame, "rows", None)
    return rows if rows is not None else contact_rows(frame.atoms, frame.contacts)


def _unknown(atom_id):
    raise UserError(f"the contact dump names atom id {int(atom_id)}, which is not in the "
                    "atom dump of the same time step; use dumps of the same run")


def particle_channels(atoms, contacts, layout: Layout, vol, dfac, rho_p, blocks, basis,
                      reach: float = 0.5, rows=None, first=0, out=None):
    """Per-particle channel values Q_p of one frame.

    Parameters
    ----------
    atoms : dict of ndarray, shape (P,) each
        ``radius`` and, as the blocks need, ``vx vy [vz]``, ``omegaz`` (2D) or
        ``omegax omegay omegaz`` (3D), ``bx by [bz]`` (the body force on each particle),
        ``id``, ``mass`` (then masses come from it instead of rho_p V^p).
    contacts : dict of ndarray or None
        Contact columns ``id1 id2 wall``, the normal ``nx ny [nz]``, the forces on
        particle 1 ``fnx fny [fnz] ftx fty [ftz]`` and ``overlap``; a particle-particle
        contact counts for both.
    layout : Layout
        The channels (:mod:`granavg.engine.channels`).
    vol, dfac : ndarray, shape (P,)
        Particle volumes V^p and Eq. 7's factor V^p / a_p^2.
    rho_p : float
        Material density.
    blocks : collection of str
        Which blocks of :data:`granavg.engine.channels.BLOCKS` to fill (``wall`` is
        filled by the caller); the others stay zero.
    basis : ndarray, shape (P, D, D)
        Unit vectors e_i (rows) at each particle: the basis of vectors and tensors.
    reach : float
        The overlap fraction s the branch vectors of Eqs. 5 and 7 give up: l_p = (a_p -
        s delta) n (:data:`BRANCHES`; 1/2 the contact point, 0 the surface).
    rows : (ndarray, ndarray), optional
        :func:`contact_rows` of the frame, if already known.
    first : int
        ``atoms`` (and vol, dfac, basis) are the frame's particles from row ``first`` on
        (a chunk): the contacts' rows are the frame's.
    out : ndarray, shape (>= P, layout.n), optional
        A buffer to fill (its first P rows are zeroed and returned), reused between
        chunks so that their memory is not allocated anew.

    Returns
    -------
    ndarray, shape (P, layout.n)
    """
    D, P = layout.dim, len(vol)
    E = np.ascontiguousarray(basis, float)
    mass = np.asarray(atoms["mass"], float) if "mass" in atoms else rho_p * vol
    if out is None:
        q = np.zeros((P, layout.n))
    else:
        q = out[:P]
        q.fill(0.0)
    want = set(blocks)
    moving = bool(want & {"mom", "kin"})
    body = "body" in want
    spin_cols = ["omegaz"] if D == 2 else ["omegax", "omegay", "omegaz"]
    zero = np.zeros((P, D))
    stack = _stacker(atoms)
    fill_particles(
        q, _f(vol, float), _f(mass, float),
        stack(["vx", "vy", "vz"][:D]) if moving else zero,
        stack(spin_cols) if "spin" in want else _f(zero[:, :len(spin_cols)]),
        stack(["bx", "by", "bz"][:D]) if body else zero,
        E, moving, "kin" in want, "spin" in want, body, _offsets(layout))
    _spin_and_energy(q, layout, atoms, stack, mass, E, want)
    if "ma" in want and "fx" in atoms:    # the total force, in the basis at the particle
        k = layout.first("ma")
        q[:, k:k + D] = np.einsum("pij,pj->pi", E, stack(["fx", "fy", "fz"][:D]))
    if want & set(CONTACT_BLOCKS):
        if rows is None:
            if first:
                raise ValueError("a chunk of the particles needs the frame's contact rows")
            rows = contact_rows(atoms, contacts)
        f, n, overlap = _contact_vectors(contacts, D, len(rows[0]))
        accumulate_contacts(_f(rows[0], np.int64), _f(rows[1], np.int64), f, n, overlap, E,
                            _f(atoms["radius"], float), _f(vol, float), _f(dfac, float),
                            reach, *(b in want for b in COMPILED_CONTACT_BLOCKS), q,
                            first, _offsets(layout))
        if want & set(COUPLE_BLOCKS):
            _couple_channels(q, layout, atoms, stack, contacts, f, n, overlap, E, want,
                             reach, rows, first)
    if want & {"ninter", "fabinter"} and contacts is not None:
        _partner_channels(q, layout, contacts, rows if rows is not None else
                          contact_rows(atoms, contacts), vol, E, first, want)
    return q


def _partner_channels(q, layout, contacts, rows, vol, E, first, want):
    """A species' share of a frame (:mod:`granavg.engine.species`): the part of each
    particle's coordination and fabric that its contacts with other species make,
    V^p x count and V^p sum n (x) n over them, in the basis E."""
    D, P = layout.dim, q.shape[0]
    i1 = np.asarray(rows[0]) - first
    k = np.flatnonzero((np.asarray(contacts["wall"]) == PARTNER) & (i1 >= 0) & (i1 < P))
    if not len(k):
        return
    p = i1[k]
    v = np.asarray(vol, float)[p]
    if "ninter" in want:
        q[:, layout.index["ninter"]] += np.bincount(p, v, minlength=P)
    if "fabinter" in want:
        n = np.column_stack([np.asarray(contacts["n" + x], float)[k] for x in "xyz"[:D]])
        nb = np.einsum("kij,kj->ki", E[p], n)
        fab = (v[:, None, None] * nb[:, :, None] * nb[:, None, :]).reshape(len(k), D * D)
        first_col = layout.first("fabinter")
        for c in range(D * D):
            q[:, first_col + c] += np.bincount(p, fab[:, c], minlength=P)


#: I = k m a^2: a disk's k (2D) and a sphere's (3D).
INERTIA = {2: 0.5, 3: 0.4}


#: The blocks of :func:`granavg.engine._sums.spin_energy`, in its ``off`` order.
SPIN_ENERGY_BLOCKS = ("ispin", "inertia", "erot", "ekin", "kcpl", "bpow")


def _spin_and_energy(q, layout, atoms, stack, mass, E, want):
    """The micropolar and energy channels of the particles: I omega, I, I |omega|^2 / 2,
    m |v|^2 / 2, the spin's flux v (x) I omega, in the basis E, and the body force's power
    b . v (:func:`granavg.engine._sums.spin_energy`; I = k m a^2 unless the atoms carry
    ``inertia``)."""
    if not want & set(SPIN_ENERGY_BLOCKS):
        return
    D, P = layout.dim, q.shape[0]
    inertia = _f(atoms["inertia"], float) if "inertia" in atoms else \
        INERTIA[D] * mass * np.asarray(atoms["radius"], float) ** 2
    spins = ["omegaz"] if D == 2 else ["omegax", "omegay", "omegaz"]
    w = stack(spins) if want & {"ispin", "erot", "kcpl"} else np.zeros((P, len(spins)))
    v = stack(["vx", "vy", "vz"][:D]) if want & {"ekin", "kcpl", "bpow"} else np.zeros((P, D))
    b = stack(["bx", "by", "bz"][:D]) if "bpow" in want else np.zeros((P, D))
    off = np.array([layout.first(k) if k in want else -1 for k in SPIN_ENERGY_BLOCKS],
                   np.int64)
    spin_energy(q, _f(mass, float), _f(inertia, float), v, w, b, E, off)


#: The blocks of :func:`_couple_channels`.
COUPLE_BLOCKS = ("cst", "lever", "cnet", "wcpl", "ppow", "wpow", "lpow")


def _couple_channels(q, layout, atoms, stack, contacts, f, n, overlap, E, want, shorten,
                     rows, first):
    """The contacts' couple and power channels, each contact on both of its particles
    (side 2 sees -n, -f, -m; a wall contact on its particle alone): sum_c l (x) m
    (``cst``), the moment (delta / 2) n x f that a lever arm to the surface adds to one
    to the contact point (``lever``), sum_c m (``cnet``; ``wcpl``: of the walls'), the
    power the contacts deliver to the particle, f . (v + omega x l) + m . omega
    (``ppow``: of the particles' contacts, ``wpow``: of the walls'), and that of the
    lever moment (``lpow``): :func:`granavg.engine._sums.couple_channels` (f, n,
    overlap: :func:`_contact_vectors`)."""
    D = layout.dim
    i1, i2 = rows
    names = ["mz"] if D == 2 else ["mx", "my", "mz"]
    m = np.column_stack([_f(contacts[k], float) if k in contacts else np.zeros(len(i1))
                         for k in names])
    powers = bool(want & {"ppow", "wpow", "lpow"})
    P = q.shape[0]
    v = stack(["vx", "vy", "vz"][:D]) if want & {"ppow", "wpow"} else np.zeros((P, D))
    spins = ["omegaz"] if D == 2 else ["omegax", "omegay", "omegaz"]
    w = stack(spins) if powers else np.zeros((P, len(spins)))
    off = np.array([layout.first(b) if b in want else -1 for b in COUPLE_BLOCKS],
                   np.int64)
    couple_channels(_f(i1, np.int64), _f(i2, np.int64), n, f, m, overlap, E,
                    _f(atoms["radius"], float), v, w, shorten, q, first, off)


def _stack(columns, names):
    """Columns as one array, shape (P, len(names))."""
    return np.column_stack([np.asarray(columns[c], float) for c in names])


def _stacker(columns):
    """:func:`_stack` of ``columns``, each set of names stacked once."""
    done = {}

    def stack(names):
        key = tuple(names)
        if key not in done:
            done[key] = _stack(columns, names)
        return done[key]
    return stack


_f = np.ascontiguousarray


def _offsets(layout: Layout) -> np.ndarray:
    """The blocks' first channels as the compiled kernels take them."""
    return np.asarray(layout.offsets, np.int64)


def _contact_vectors(contacts, D: int, n_contacts: int):
    """The contacts' total force f = f_n + f_t and normal n, shape (C, D) each, and their
    overlaps (C,). Columns the wanted channels do not need (forces for coordination
    alone) may be absent: zeros, which enter only channels that are not kept."""
    col = {k: _f(contacts[k], float) if k in contacts else np.zeros(n_contacts)
           for k in ("fnx", "fny", "fnz", "ftx", "fty", "ftz", "nx", "ny", "nz", "overlap")}
    f = np.column_stack([col["fn" + x] + col["ft" + x] for x in "xyz"[:D]])
    n = np.column_stack([col["n" + x] for x in "xyz"[:D]])
    return f, n, col["overlap"]


#: The wall code of a contact with a particle of another species, in a species' share
#: of a frame (:mod:`granavg.engine.species`): its partner acts as a wall would, on the
#: particle alone, at the contact point; walls have codes > 0, particle pairs 0.
PARTNER = -1
#: Which contacts :func:`wall_points` takes: the walls', the other species' particles',
#: or both.
POINT_CONTACTS = {"wall": lambda code: code > 0, "inter": lambda code: code < 0,
                  "both": lambda code: code != 0}


def wall_points(atoms, contacts, dim=2, reach: float = 0.5, rows=None, which="wall"):
    """Contact points and forces on the particles of the wall contacts (``which``:
    ``wall``; ``inter``, the contacts with particles of another species; ``both``,
    :data:`POINT_CONTACTS`).

    Returns
    -------
    points, forces : ndarray, shape (n_wall_contacts, dim)
        The point x_p + (a_p - s delta) n (s: ``reach``, of :data:`BRANCHES`) and the contact's
        total force on the particle.
    """
    k = POINT_CONTACTS[which](np.asarray(contacts["wall"]))
    p = rows[0][k] if rows is not None else rows_of(atoms["id"], contacts["id1"][k])
    arm = atoms["radius"][p] - reach * contacts["overlap"][k]
    xyz = "xyz"[:dim]
    points = np.column_stack([atoms[x][p] + arm * contacts["n" + x][k] for x in xyz])
    forces = np.column_stack([contacts["fn" + x][k] + contacts["ft" + x][k] for x in xyz])
    return points, forces


def lookup(ids, wanted):
    """Row of each wanted id among ``ids`` and whether it was found.

    Parameters
    ----------
    ids : ndarray, shape (P,)
        The frame's atom ids (unique integers, any order).
    wanted : ndarray, shape (N,)

    Returns
    -------
    rows : ndarray of int, shape (N,)
        Meaningful where ``found``.
    found : ndarray of bool, shape (N,)
    """
    ids, wanted = np.asarray(ids), np.asarray(wanted)
    if len(ids) == 0:
        return np.zeros(len(wanted), np.int64), np.zeros(len(wanted), bool)
    top = int(ids.max())
    if ids.min() >= 0 and top < 8 * len(ids) + 1_000_000:         # a table: O(P + N)
        rows = table_rows(ids, wanted, top)
        return rows, rows >= 0
    ids, wanted = ids.astype(np.int64), wanted.astype(np.int64)   # sparse: sort and search
    order = np.argsort(ids, kind="stable")
    rows = order[np.minimum(np.searchsorted(ids[order], wanted), len(ids) - 1)]
    return rows, ids[rows] == wanted


def rows_of(ids, wanted):
    """Row of each id in the atom ids (:func:`lookup`); an unknown id is a user error."""
    rows, found = lookup(ids, wanted)
    if not np.all(found):
        _unknown(np.asarray(wanted)[~found][0])
    return rows


def cell_sums(particle, ring, w, q, n_rings):
    """S[k, c] = sum_p w_pk q[p, c]; shape (n_cells, n_channels)."""
    out = np.zeros((n_rings, q.shape[1]))
    scatter(_f(particle, np.int64), _f(ring, np.int64), _f(w, float), _f(q, float), out)
    return out


def sector_sums(particle, cell, w, sector, share, k, q, n_cells):
    """S[cell * k + s, c] = sum_p w_p,cell share_p,s q[p, c]: the cells' sums split over
    their sectors (:meth:`~granavg.engine.cells.base.Cells.sector_shares`), shape
    (n_cells * k, n_channels); the sectors of a cell add up to its sums (the shares of a
    particle sum to 1)."""
    out = np.zeros((n_cells * int(k), q.shape[1]))
    scatter_sectors(_f(particle, np.int64), _f(cell, np.int64), _f(w, float),
                          _f(sector, np.int64), _f(share, float), int(k), _f(q, float), out)
    return out
