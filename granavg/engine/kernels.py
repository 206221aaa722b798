"""Per-frame sums of the ring averages (Eqs. 1-7): pure numpy kernels, SI units.

For every ring k and channel c a frame contributes ``S[k, c] = sum_p w_pk Q_pc`` with
``w_pk`` the disk's area fraction in the ring (:mod:`granavg.engine.weights`) and Q the
per-particle channel below. Tensors are in each particle's own polar basis
(e_r, e_phi) at its centre, components ordered rr, rphi, phir, phiphi, first index the
force (or the deformation), second the branch vector; nothing is symmetrised.

===========  ==========================================  =========================
channel      Q_p                                           gives (after / V or ratio)
===========  ==========================================  =========================
vol          V^p = pi h a^2                                nu (Eq. 2)
mass         m^p (rho_p V^p, or the dump's mass column)    rho
mom_r/phi    V^p v_r, V^p v_phi                            v = <nu v>/<nu> (Eq. 3)
spin         V^p omega                                     omega
ncontact     V^p C^p                                       coordination C
fab_ij       V^p sum_c n_i n_j                             F (Eq. 4)
sig_ij       sum_c f_i l_j,  l = (a - s delta) n           sigma (Eq. 5)
kin_ij       m^p v_i v_j                                   dynamic stress (Eq. 6)
def_ij       pi h sum_c Delta_i l_j,  Delta = -delta n     eps numerator (Eq. 7)
wall_i       (at the contact points) sum_(wall c) f_i      boundary force density
body_i       b^p (the atoms' ``bx by``: gravity, ...)      body force density
===========  ==========================================  =========================

The boundary force density is not spread with the disks' weights: each wall contact's
force on the disk is put in the cell of its contact point (:func:`wall_points`), where
the wall acts (the cell at the edge if the point lies just beyond it), in the basis
there.

The branch vector l ends at the contact point: s = 1/2 (``branch="contact"``, the default,
l_1 - l_2 = r_12) or at the disk's surface, s = 0 (``branch="paper"``, Eq. 5 as printed);
:data:`BRANCHES`.

Eq. 5 as printed carries a factor V^p; with it sigma would not be a stress (N m rather
than Pa). The particle stress is (1/V^p) sum_c f (x) l, so V^p cancels: sigma =
(1/V) sum_p w sum_c f (x) l, which is what the sum rule sum_k V_k sigma_k =
sum_p sum_c f (x) l states. Delta^pc is the contact's normal deformation: the overlap
delta shortens the branch vector, Delta = -delta n (tension-positive, like sigma). The
tangential spring is not included: LAMMPS does not output it, and at the Coulomb limit
it is not an elastic deformation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from granavg.engine.quantities import TENSOR
from granavg.errors import UserError

CHANNELS = ("vol", "mass", "mom_r", "mom_phi", "spin", "ncontact",
            *(f"fab_{c}" for c in TENSOR), *(f"sig_{c}" for c in TENSOR),
            *(f"kin_{c}" for c in TENSOR), *(f"def_{c}" for c in TENSOR),
            "wall_r", "wall_phi", "body_r", "body_phi")
#: How far each branch vector reaches, as the overlap it gives up: ``contact`` ends at
#: the middle of the overlap, l_p = (a_p - delta / 2) n, so that l_1 - l_2 = r_12 for
#: any two radii (the pair's centre distance: the stress then balances the forces);
#: ``paper`` is Eq. 5 as printed, l_p = a_p n, which reaches past the contact point by
#: delta / 2 and makes sigma too large by about delta / d.
BRANCHES = {"contact": 0.5, "paper": 0.0}
INDEX = {name: k for k, name in enumerate(CHANNELS)}
#: First columns of the channels the compiled kernels fill (global constants: numba
#: compiles them in, and its cache is renewed when this file changes - change the
#: channels here, never elsewhere).
VOL, MASS, MOM, SPIN, NC, FAB, SIG, KIN, DEF, BODY = (
    INDEX[c] for c in ("vol", "mass", "mom_r", "spin", "ncontact", "fab_rr", "sig_rr",
                       "kin_rr", "def_rr", "body_r"))


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
    pair = contacts["wall"] == 0
    i1 = rows_of(atoms["id"], contacts["id1"])
    i2 = np.full(len(i1), -1, dtype=np.int64)
    i2[pair] = rows_of(atoms["id"], contacts["id2"][pair])
    _last_rows = (key, (i1, i2))
    return i1, i2


def particle_channels(atoms, contacts, h, rho_p, channels, basis, branch="contact",
                      rows=None):
    """Per-particle channel values Q_p of one frame.

    Parameters
    ----------
    atoms : dict of ndarray, shape (P,) each
        ``x y radius`` and, as the channels need, ``vx vy omegaz id`` (SI units).
    contacts : dict of ndarray or None
        Contact-dump columns ``id1 id2 wall fnx fny ftx fty nx ny overlap``
        (docs/outputs.md); a disk-disk contact counts for both disks.
    h, rho_p : float
        Disk height (m) and material density (kg/m^3).
    channels : sequence of str
        Which of :data:`CHANNELS` to fill; the others stay zero (``body_r``/``body_phi``
        read the atoms' ``bx by``, the body force on each disk).
    branch : {"contact", "paper"}
        Where the branch vectors of Eqs. 5 and 7 end (:data:`BRANCHES`).
    rows : (ndarray, ndarray), optional
        :func:`contact_rows` of the frame, if already known.
    basis : (ndarray, ndarray)
        Unit vectors (e_1, e_2) at each disk, shape (P, 2) each: the basis of vectors and
        tensors (the cells' ``basis(x, y)``: e_r, e_phi for rings). With a
        ``mass`` column (kg) among the atoms, masses are taken from it instead of
        rho_p V^p (e.g. spheres in a 2D simulation).

    Returns
    -------
    ndarray, shape (P, len(CHANNELS))
    """
    x, y, a = atoms["x"], atoms["y"], atoms["radius"]
    er, ephi = (np.ascontiguousarray(e, float) for e in basis)
    vol = np.pi * h * a * a
    mass = np.asarray(atoms["mass"], float) if "mass" in atoms else rho_p * vol
    q = np.zeros((len(x), len(CHANNELS)))
    want = set(channels)
    zero = np.zeros(len(x))
    moving = bool(want & {"mom_r", "mom_phi", "kin_rr"})
    body = bool(want & {"body_r", "body_phi"})
    _fill_particles(q, vol, mass, *(np.asarray(atoms[c], float) if use else zero
                                    for c, use in (("vx", moving), ("vy", moving),
                                                   ("omegaz", "spin" in want),
                                                   ("bx", body), ("by", body))),
                    er, ephi, moving, "kin_rr" in want, "spin" in want, body)
    if want & {"ncontact", "fab_rr", "sig_rr", "def_rr"}:
        if branch not in BRANCHES:
            raise UserError(f"branch {branch!r}: choose from {', '.join(BRANCHES)}")
        _contact_channels(q, atoms, contacts, er, ephi, vol, h, want, BRANCHES[branch],
                          rows or contact_rows(atoms, contacts))
    return q


@njit(cache=True, nogil=True)
def _fill_particles(q, vol, mass, vx, vy, omz, bx, by, er, ephi, moving, kinetic, spin,
                    body):
    """The particles' own channels in one pass: volume, mass, momentum, the kinetic
    tensor m v (x) v, spin and body force, in the basis (er, ephi)."""
    for p in range(q.shape[0]):
        q[p, VOL], q[p, MASS] = vol[p], mass[p]
        if moving:
            v_r = vx[p] * er[p, 0] + vy[p] * er[p, 1]
            v_phi = vx[p] * ephi[p, 0] + vy[p] * ephi[p, 1]
            q[p, MOM], q[p, MOM + 1] = vol[p] * v_r, vol[p] * v_phi
            if kinetic:
                m = mass[p]
                q[p, KIN], q[p, KIN + 1] = m * v_r * v_r, m * v_r * v_phi
                q[p, KIN + 2], q[p, KIN + 3] = m * v_phi * v_r, m * v_phi * v_phi
        if spin:
            q[p, SPIN] = vol[p] * omz[p]
        if body:
            q[p, BODY] = bx[p] * er[p, 0] + by[p] * er[p, 1]
            q[p, BODY + 1] = bx[p] * ephi[p, 0] + by[p] * ephi[p, 1]


def _contact_channels(q, atoms, contacts, er, ephi, vol, h, want, shorten, rows):
    """Add each contact to both of its disks (only the disk of a wall contact)."""
    i1, i2 = rows
    # columns the wanted channels do not need (e.g. forces for coordination alone) may be
    # absent: they enter only channels that are not kept
    col = {k: np.asarray(contacts[k], float) if k in contacts else np.zeros(len(i1))
           for k in ("fnx", "ftx", "fny", "fty", "nx", "ny", "overlap")}
    keep = np.array([n in want for n in ("ncontact", "fab_rr", "sig_rr", "def_rr")])
    _accumulate_contacts(i1, i2, col["fnx"] + col["ftx"], col["fny"] + col["fty"],
                         col["nx"], col["ny"], col["overlap"], er, ephi,
                         np.asarray(atoms["radius"], float), vol, np.pi * h, shorten, keep, q)


def wall_points(atoms, contacts, branch="contact", rows=None):
    """Contact points and forces on the disks of the wall contacts.

    Returns
    -------
    cx, cy, fx, fy : ndarray, shape (n_wall_contacts,)
        The point x_p + (a_p - s delta) n (s of :data:`BRANCHES`) and the contact's
        total force on the disk.
    """
    k = contacts["wall"] != 0
    p = rows[0][k] if rows is not None else rows_of(atoms["id"], contacts["id1"][k])
    reach = atoms["radius"][p] - BRANCHES[branch] * contacts["overlap"][k]
    return (atoms["x"][p] + reach * contacts["nx"][k], atoms["y"][p] + reach * contacts["ny"][k],
            contacts["fnx"][k] + contacts["ftx"][k], contacts["fny"][k] + contacts["fty"][k])


@njit(cache=True, nogil=True)
def _accumulate_contacts(i1, i2, fx, fy, nx, ny, overlap, er, ephi, a, vol, pih, shorten,
                         keep, q):
    """Add to each disk's channels the sums over its contacts (side 2 sees -f and -n;
    i2 < 0: wall contact), the ``keep``-ed ones of: V^p x count, V^p sum n (x) n,
    sum f (x) l with l = (a - shorten overlap) n, pi h sum Delta (x) l with
    Delta = -overlap n; tensors in the disk's basis (rr, rphi, phir, phiphi)."""
    for c in range(i1.shape[0]):
        for side in range(2):
            p = i1[c] if side == 0 else i2[c]
            if p < 0:
                break
            s = 1.0 if side == 0 else -1.0
            n_r = s * (nx[c] * er[p, 0] + ny[c] * er[p, 1])
            n_phi = s * (nx[c] * ephi[p, 0] + ny[c] * ephi[p, 1])
            f_r = s * (fx[c] * er[p, 0] + fy[c] * er[p, 1])
            f_phi = s * (fx[c] * ephi[p, 0] + fy[c] * ephi[p, 1])
            length = a[p] - shorten * overlap[c]
            d = -pih * overlap[c] * length
            v = vol[p]
            if keep[0]:
                q[p, NC] += v
            if keep[1]:
                q[p, FAB] += v * n_r * n_r
                q[p, FAB + 1] += v * n_r * n_phi
                q[p, FAB + 2] += v * n_phi * n_r
                q[p, FAB + 3] += v * n_phi * n_phi
            if keep[2]:
                q[p, SIG] += length * f_r * n_r
                q[p, SIG + 1] += length * f_r * n_phi
                q[p, SIG + 2] += length * f_phi * n_r
                q[p, SIG + 3] += length * f_phi * n_phi
            if keep[3]:
                q[p, DEF] += d * n_r * n_r
                q[p, DEF + 1] += d * n_r * n_phi
                q[p, DEF + 2] += d * n_phi * n_r
                q[p, DEF + 3] += d * n_phi * n_phi


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
    ids = np.asarray(ids).astype(np.int64)
    wanted = np.asarray(wanted).astype(np.int64)
    if len(ids) == 0:
        return np.zeros(len(wanted), np.int64), np.zeros(len(wanted), bool)
    top = int(ids.max(initial=0))
    if top < 8 * len(ids) + 1_000_000:               # a lookup table: O(P + N)
        table = np.full(top + 2, -1, dtype=np.int64)
        table[ids] = np.arange(len(ids))
        rows = table[np.clip(wanted, 0, top + 1)]
        bad = (rows < 0) | (wanted < 0) | (wanted > top)
    else:                                           # sparse ids: sort and search
        order = np.argsort(ids, kind="stable")
        pos = np.minimum(np.searchsorted(ids[order], wanted), len(ids) - 1)
        rows = order[pos]
        bad = ids[rows] != wanted
    return rows, ~bad


def rows_of(ids, wanted):
    """Row of each id in the atom ids (:func:`lookup`); an unknown id is a user error."""
    rows, found = lookup(ids, wanted)
    bad = ~found
    if np.any(bad):
        raise UserError(f"the contact dump names atom id {int(wanted[bad][0])}, which is not "
                        "in the atom dump of the same time step; use dumps of the same run")
    return rows


def ring_sums(particle, ring, w, q, n_rings):
    """S[k, c] = sum_p w_pk q[p, c]; shape (n_rings, n_channels)."""
    out = np.zeros((n_rings, q.shape[1]))
    _scatter(particle, ring, w, np.ascontiguousarray(q), out)
    return out


@njit(cache=True, nogil=True)
def _scatter(particle, ring, w, q, out):
    for t in range(particle.shape[0]):
        p, k, wt = particle[t], ring[t], w[t]
        for c in range(q.shape[1]):
            out[k, c] += wt * q[p, c]
