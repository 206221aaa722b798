"""A small reference DEM in 2D with LAMMPS' contact law and integrator (SI units).

It exists to check LAMMPS runs and granavg's averaging against an independent engine
with the same physics; it is not a production engine (numpy, no MPI, no neighbour skin:
candidate pairs come from a k-d tree every step). It follows, operation for operation,
so that results agree to round-off:

- ``pair gran/hooke/history`` (Kn Kt gamma_n gamma_t mu, dampflag 1): for a pair in
  contact (r < r_i + r_j), with del = x_i - x_j, the normal force on i
  ``(kn (r_i + r_j - r) / r - m_eff gamma_n (v_r . del) / r^2) del``; the tangential
  spring (history) advanced by ``dt v_t`` (v_t the relative tangential velocity of the
  contact points), projected back onto the tangent plane, the tangential force
  ``-(kt shear + m_eff gamma_t v_t)`` capped at ``mu |F_n|`` with LAMMPS' rescaling of
  the history; torque ``-r_i (del x F_t)_z / r``. m_eff = m_i m_j / (m_i + m_j), or the
  free disk's mass when the other is frozen (a wall).
- ``fix nve/sphere disc`` (velocity Verlet, moment of inertia m r^2 / 2) with
  ``fix enforce2d``: half kick, drift, forces, half kick.
- ``fix move rotate 0 0 0 0 0 1 T`` for a rotating wall ring: at step n its disks sit
  at their start positions turned by Omega n dt about the origin, move with
  v = Omega z x r and spin at Omega; like all wall disks they are frozen (infinite mass).
- ``compute pair/local`` for the contact dump: forces re-evaluated after the step from
  the stored (updated) springs and the end-of-step velocities, as LAMMPS' ``single()``.

The contact law's constants come from :func:`granavg.sim.contact_law.to_lammps`, the same
function the decks use.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from granavg.sim.contact_law import LammpsCoefficients


@dataclass
class Disks:
    """State of N disks (SI units); ``frozen`` disks never move (walls)."""

    x: np.ndarray            # (N, 2) m
    v: np.ndarray            # (N, 2) m/s
    omega: np.ndarray        # (N,) rad/s
    radius: np.ndarray       # (N,) m
    mass: np.ndarray         # (N,) kg
    frozen: np.ndarray = None
    force: np.ndarray = field(default=None, repr=False)
    torque: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        n = len(self.radius)
        self.frozen = np.zeros(n, bool) if self.frozen is None else np.asarray(self.frozen)
        self.force = np.zeros((n, 2))
        self.torque = np.zeros(n)


class ReferenceDEM:
    """Integrate :class:`Disks` with LAMMPS' ``gran/hooke/history`` and ``nve/sphere``.

    Parameters
    ----------
    disks : Disks
    coeffs : LammpsCoefficients
        From :func:`granavg.sim.contact_law.to_lammps`.
    dt : float
        Time step, s.
    rotating : ndarray of bool, shape (N,), optional
        Frozen disks turned rigidly about the origin at ``Omega`` (rad/s,
        counter-clockwise) from their positions at step 0.
    Omega : float
    """

    def __init__(self, disks: Disks, coeffs: LammpsCoefficients, dt: float,
                 rotating=None, Omega: float = 0.0):
        self.d, self.c, self.dt = disks, coeffs, dt
        self.step_count = 0
        self.history = (np.empty(0, int), np.empty((0, 2)))   # sorted pair keys, springs
        self.rotating = np.zeros(len(disks.radius), bool) if rotating is None \
            else np.asarray(rotating, bool)
        if np.any(self.rotating & ~disks.frozen):
            raise ValueError("rotating wall disks must be frozen")
        self.Omega, self.x0 = Omega, disks.x[self.rotating].copy()
        self.skin, self._neigh, self.rebuilds = 0.5 * disks.radius.min(), None, 0
        self.contacts = None
        self.compute_forces(update_history=False)       # like LAMMPS' setup

    def pairs(self):
        """Touching pairs (i < j, not both frozen, sorted), from a Verlet list: candidate
        pairs within r_i + r_j + skin come from a k-d tree, rebuilt only when some disk
        has moved more than skin/2 since (as LAMMPS' ``neigh_modify check yes``)."""
        x, r = self.d.x, self.d.radius
        if self._neigh is None or np.max(np.sum((x - self._neigh[2]) ** 2, axis=1)) \
                > (0.5 * self.skin) ** 2:
            ij = cKDTree(x).query_pairs(2.0 * r.max() + self.skin, output_type="ndarray")
            ij = ij[np.lexsort((ij[:, 1], ij[:, 0]))] if len(ij) else np.empty((0, 2), int)
            ij = ij[~(self.d.frozen[ij[:, 0]] & self.d.frozen[ij[:, 1]])]
            self._neigh = (ij[:, 0], ij[:, 1], x.copy())
            self.rebuilds += 1
        i, j, _ = self._neigh
        dist2 = np.sum((x[i] - x[j]) ** 2, axis=1)
        touch = dist2 < (r[i] + r[j]) ** 2
        return i[touch], j[touch]

    def compute_forces(self, update_history=True):
        """Forces and torques of the current positions and velocities (LAMMPS'
        ``compute()``); ``contacts`` then holds i, j, normal and tangential force on i."""
        i, j, fn, ft, tor3 = self._contact_forces(update_history)
        d, n = self.d, len(self.d.radius)
        fx, fy = fn[:, 0] + ft[:, 0], fn[:, 1] + ft[:, 1]
        d.force[:, 0] = np.bincount(i, fx, n) - np.bincount(j, fx, n)
        d.force[:, 1] = np.bincount(i, fy, n) - np.bincount(j, fy, n)
        d.torque[:] = -(np.bincount(i, d.radius[i] * tor3, n) + np.bincount(j, d.radius[j] * tor3, n))
        self.contacts = (i, j, fn, ft)

    def contact_rows(self):
        """What LAMMPS' ``compute pair/local dx dy dist fx fy p1 p2`` reports now.

        Returns
        -------
        i, j : ndarray of int, shape (n,)
            Disk indices of each touching pair (i < j).
        rows : ndarray, shape (n, 7)
            dx dy dist (m; dx = x_i - x_j), normal force on i, tangential force on i (N),
            re-evaluated from the stored springs and the current velocities (``single()``).
        """
        i, j, fn, ft, _ = self._contact_forces(update_history=False)
        dx = self.d.x[i] - self.d.x[j]
        return i, j, np.column_stack([dx, np.hypot(dx[:, 0], dx[:, 1]), fn, ft])

    def _contact_forces(self, update_history):
        """Per-contact forces, each operation in LAMMPS' order (vectorised over contacts)."""
        d, c, dt = self.d, self.c, self.dt
        i, j = self.pairs()
        delx, dely = d.x[i, 0] - d.x[j, 0], d.x[i, 1] - d.x[j, 1]
        rsq = delx * delx + dely * dely
        r = np.sqrt(rsq)
        rinv, rsqinv = 1.0 / r, 1.0 / rsq
        vr1, vr2 = d.v[i, 0] - d.v[j, 0], d.v[i, 1] - d.v[j, 1]
        vnnr = vr1 * delx + vr2 * dely
        vt1, vt2 = vr1 - delx * vnnr * rsqinv, vr2 - dely * vnnr * rsqinv
        wr3 = (d.radius[i] * d.omega[i] + d.radius[j] * d.omega[j]) * rinv
        mi, mj = d.mass[i], d.mass[j]
        meff = np.where(d.frozen[j], mi, np.where(d.frozen[i], mj, mi * mj / (mi + mj)))
        ccel = c.kn * (d.radius[i] + d.radius[j] - r) * rinv - meff * c.gamma_n * vnnr * rsqinv
        vtr1, vtr2 = vt1 + dely * wr3, vt2 - delx * wr3
        keys = i * len(d.radius) + j
        s1, s2 = self._old_history(keys)
        if update_history:
            s1, s2 = s1 + vtr1 * dt, s2 + vtr2 * dt
        shrmag = np.sqrt(s1 * s1 + s2 * s2)
        rsht = (s1 * delx + s2 * dely) * rsqinv
        if update_history:
            s1, s2 = s1 - rsht * delx, s2 - rsht * dely
        fs1 = -(c.kt * s1 + meff * c.gamma_t * vtr1)
        fs2 = -(c.kt * s2 + meff * c.gamma_t * vtr2)
        fs = np.sqrt(fs1 * fs1 + fs2 * fs2)
        mu = np.where(d.frozen[i] | d.frozen[j], c.mu_wall, c.mu)
        fn = mu * np.abs(ccel * r)
        slide = fs > fn
        with np.errstate(invalid="ignore", divide="ignore"):
            scale = np.where(slide, fn / fs, 1.0)
            t1, t2 = meff * c.gamma_t * vtr1 / c.kt, meff * c.gamma_t * vtr2 / c.kt
        rescale = slide & (shrmag != 0.0)
        s1 = np.where(rescale, scale * (s1 + t1) - t1, s1)
        s2 = np.where(rescale, scale * (s2 + t2) - t2, s2)
        fs1 = np.where(slide, np.where(rescale, fs1 * scale, 0.0), fs1)
        fs2 = np.where(slide, np.where(rescale, fs2 * scale, 0.0), fs2)
        tor3 = rinv * (delx * fs2 - dely * fs1)
        if update_history:
            self.history = (keys, np.column_stack([s1, s2]))
        return (i, j, np.column_stack([delx * ccel, dely * ccel]), np.column_stack([fs1, fs2]),
                tor3)

    def _old_history(self, keys):
        """Tangential springs of these contacts from the last step (0 for new ones)."""
        old_keys, old = self.history
        pos = np.minimum(np.searchsorted(old_keys, keys), max(len(old_keys) - 1, 0))
        found = (old_keys[pos] == keys) if len(old_keys) else np.zeros(len(keys), bool)
        return (np.where(found, old[pos, 0], 0.0) if len(old_keys) else np.zeros(len(keys)),
                np.where(found, old[pos, 1], 0.0) if len(old_keys) else np.zeros(len(keys)))

    def step(self):
        """One velocity-Verlet step of ``fix nve/sphere disc`` + ``enforce2d`` (and
        ``fix move rotate`` for the rotating ring)."""
        d, dt = self.d, self.dt
        free = ~d.frozen
        dtf = 0.5 * dt
        dtfm = (dtf / d.mass[free])[:, None]
        dtirotate = (dtf / 0.5) / (d.radius[free] * d.radius[free] * d.mass[free])
        d.v[free] += dtfm * d.force[free]
        d.x[free] += dt * d.v[free]
        d.omega[free] += dtirotate * d.torque[free]
        if self.rotating.any():
            self._turn_ring(self.step_count + 1)
        self.compute_forces()
        d.v[free] += dtfm * d.force[free]
        d.omega[free] += dtirotate * d.torque[free]
        self.step_count += 1

    def _turn_ring(self, step):
        """``fix move rotate`` about the z axis through the origin, as LAMMPS does it."""
        arg = self.Omega * (step * self.dt)
        cosine, sine = np.cos(arg), np.sin(arg)
        a0, a1 = self.x0[:, 0], self.x0[:, 1]
        disp0, disp1 = a0 * cosine + -a1 * sine, a1 * cosine + a0 * sine
        self.d.x[self.rotating] = np.column_stack([disp0, disp1])
        self.d.v[self.rotating] = np.column_stack([self.Omega * -disp1, self.Omega * disp0])
        self.d.omega[self.rotating] = self.Omega
