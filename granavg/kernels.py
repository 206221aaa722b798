"""Per-frame sums of the ring averages (Eqs. 1-7): pure numpy kernels, SI units.

For every ring k and channel c a frame contributes ``S[k, c] = sum_p w_pk Q_pc`` with
``w_pk`` the disk's area fraction in the ring (:mod:`granavg.weights`) and Q the
per-particle channel below. Tensors are in each particle's own polar basis
(e_r, e_phi) at its centre, components ordered rr, rphi, phir, phiphi, first index the
force (or the deformation), second the branch vector; nothing is symmetrised.

===========  ==========================================  =========================
channel      Q_p                                           gives (after / V or ratio)
===========  ==========================================  =========================
vol          V^p = pi h a^2                                nu (Eq. 2)
mom_r/phi    V^p v_r, V^p v_phi                            v = <nu v>/<nu> (Eq. 3)
spin         V^p omega                                     omega
ncontact     V^p C^p                                       coordination C
fab_ij       V^p sum_c n_i n_j                             F (Eq. 4)
sig_ij       sum_c f_i l_j,  l = a n                       sigma (Eq. 5)
kin_ij       rho_p V^p v_i v_j                             dynamic stress (Eq. 6)
def_ij       pi h sum_c Delta_i l_j,  Delta = -delta n     eps numerator (Eq. 7)
===========  ==========================================  =========================

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
import scipy.sparse as sp

from .errors import UserError

TENSOR = ("rr", "rphi", "phir", "phiphi")
CHANNELS = ("vol", "mom_r", "mom_phi", "spin", "ncontact",
            *(f"fab_{c}" for c in TENSOR), *(f"sig_{c}" for c in TENSOR),
            *(f"kin_{c}" for c in TENSOR), *(f"def_{c}" for c in TENSOR))
INDEX = {name: k for k, name in enumerate(CHANNELS)}


def polar_basis(x, y):
    """Unit vectors e_r and e_phi at (x, y); each of shape (P, 2)."""
    r = np.hypot(x, y)
    er = np.column_stack([x / r, y / r])
    return er, np.column_stack([-er[:, 1], er[:, 0]])


def _outer(u_r, u_phi, v_r, v_phi):
    """Components rr, rphi, phir, phiphi of u (x) v, shape (n, 4)."""
    return np.column_stack([u_r * v_r, u_r * v_phi, u_phi * v_r, u_phi * v_phi])


def particle_channels(atoms, contacts, h, rho_p, channels):
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
        Which of :data:`CHANNELS` to fill; the others stay zero.

    Returns
    -------
    ndarray, shape (P, len(CHANNELS))
    """
    x, y, a = atoms["x"], atoms["y"], atoms["radius"]
    er, ephi = polar_basis(x, y)
    vol = np.pi * h * a * a
    q = np.zeros((len(x), len(CHANNELS)))
    want = set(channels)
    q[:, INDEX["vol"]] = vol
    if want & {"mom_r", "mom_phi", "kin_rr"}:
        v = np.column_stack([atoms["vx"], atoms["vy"]])
        v_r, v_phi = np.einsum("ij,ij->i", v, er), np.einsum("ij,ij->i", v, ephi)
        q[:, INDEX["mom_r"]], q[:, INDEX["mom_phi"]] = vol * v_r, vol * v_phi
        if "kin_rr" in want:
            q[:, INDEX["kin_rr"]:INDEX["kin_rr"] + 4] = \
                (rho_p * vol)[:, None] * _outer(v_r, v_phi, v_r, v_phi)
    if "spin" in want:
        q[:, INDEX["spin"]] = vol * atoms["omegaz"]
    if want & {"ncontact", "fab_rr", "sig_rr", "def_rr"}:
        _contact_channels(q, atoms, contacts, er, ephi, vol, h, want)
    return q


def _contact_channels(q, atoms, contacts, er, ephi, vol, h, want):
    """Add each contact to both of its disks (only the disk of a wall contact)."""
    ids = atoms["id"]
    i1 = _rows_of(ids, contacts["id1"])
    pair = contacts["wall"] == 0
    i2 = _rows_of(ids, contacts["id2"][pair])
    n = np.column_stack([contacts["nx"], contacts["ny"]])
    f = np.column_stack([contacts["fnx"] + contacts["ftx"], contacts["fny"] + contacts["fty"]])
    delta = contacts["overlap"]
    # side 2 sees the opposite force and normal
    who = np.concatenate([i1, i2])
    n_s = np.concatenate([n, -n[pair]])
    f_s = np.concatenate([f, -f[pair]])
    delta_s = np.concatenate([delta, delta[pair]])
    a_s = atoms["radius"][who]
    n_r, n_phi = np.einsum("ij,ij->i", n_s, er[who]), np.einsum("ij,ij->i", n_s, ephi[who])
    nn = _outer(n_r, n_phi, n_r, n_phi)
    P = len(vol)

    def per_particle(values):
        return np.column_stack([np.bincount(who, values[:, c], P) for c in range(4)])

    if "ncontact" in want:
        q[:, INDEX["ncontact"]] = vol * np.bincount(who, minlength=P)
    if "fab_rr" in want:
        q[:, INDEX["fab_rr"]:INDEX["fab_rr"] + 4] = vol[:, None] * per_particle(nn)
    if "sig_rr" in want:
        f_r, f_phi = np.einsum("ij,ij->i", f_s, er[who]), np.einsum("ij,ij->i", f_s, ephi[who])
        q[:, INDEX["sig_rr"]:INDEX["sig_rr"] + 4] = per_particle(
            a_s[:, None] * _outer(f_r, f_phi, n_r, n_phi))
    if "def_rr" in want:
        q[:, INDEX["def_rr"]:INDEX["def_rr"] + 4] = per_particle(
            (-np.pi * h * delta_s * a_s)[:, None] * nn)


def _rows_of(ids, wanted):
    """Row of each id in the atom ids; an unknown id is a user error."""
    order = None if np.all(ids[1:] > ids[:-1]) else np.argsort(ids, kind="stable")
    sorted_ids = ids if order is None else ids[order]
    rows = np.minimum(np.searchsorted(sorted_ids, wanted), len(ids) - 1)
    bad = sorted_ids[rows] != wanted
    rows = rows if order is None else order[rows]
    if np.any(bad):
        raise UserError(f"the contact dump names atom id {int(wanted[bad][0])}, which is not "
                        "in the atom dump of the same time step; use dumps of the same run")
    return rows


def ring_sums(particle, ring, w, q, n_rings):
    """S[k, c] = sum_p w_pk q[p, c]; shape (n_rings, n_channels)."""
    W = sp.csr_array((w, (ring, particle)), shape=(n_rings, q.shape[0]))
    return W @ q
