"""A small reference DEM in 2D with LAMMPS' contact law and integrator (SI units).

It exists to check LAMMPS runs and granavg's averaging against an independent engine
with the same physics; it is not a production engine (no MPI, no neighbour skin; the
pair loop is plain Python for now, fine for collisions, not yet for a cell). It follows,
operation for operation, so that results agree to round-off:

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

The contact law's constants come from :func:`granavg.contact_law.to_lammps`, the same
function the decks use.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .contact_law import LammpsCoefficients


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
        From :func:`granavg.contact_law.to_lammps`.
    dt : float
        Time step, s.
    """

    def __init__(self, disks: Disks, coeffs: LammpsCoefficients, dt: float):
        self.d, self.c, self.dt = disks, coeffs, dt
        self.step_count = 0
        self.history = {}                  # (i, j) with i < j -> shear displacement (2,)
        self.contacts = None
        self.compute_forces(update_history=False)       # like LAMMPS' setup

    def pairs(self):
        """Candidate pairs (i < j) closer than the sum of their radii: brute force."""
        x, r = self.d.x, self.d.radius
        i, j = np.triu_indices(len(r), 1)
        both_frozen = self.d.frozen[i] & self.d.frozen[j]
        dist2 = np.sum((x[i] - x[j]) ** 2, axis=1)
        touch = (dist2 < (r[i] + r[j]) ** 2) & ~both_frozen
        return i[touch], j[touch]

    def compute_forces(self, update_history=True):
        """Forces and torques of the current positions and velocities."""
        d, c, dt = self.d, self.c, self.dt
        d.force[:] = 0.0
        d.torque[:] = 0.0
        i, j = self.pairs()
        new_history = {}
        rows = []
        for a, b in zip(i.tolist(), j.tolist()):
            delx, dely = d.x[a] - d.x[b]
            rsq = delx * delx + dely * dely
            r = np.sqrt(rsq)
            rinv, rsqinv = 1.0 / r, 1.0 / rsq
            vr1, vr2 = d.v[a] - d.v[b]
            vnnr = vr1 * delx + vr2 * dely
            vn1, vn2 = delx * vnnr * rsqinv, dely * vnnr * rsqinv
            vt1, vt2 = vr1 - vn1, vr2 - vn2
            wr3 = (d.radius[a] * d.omega[a] + d.radius[b] * d.omega[b]) * rinv
            mi, mj = d.mass[a], d.mass[b]
            meff = mi * mj / (mi + mj)
            if d.frozen[a]:
                meff = mj
            if d.frozen[b]:
                meff = mi
            damp = meff * c.gamma_n * vnnr * rsqinv
            ccel = c.kn * (d.radius[a] + d.radius[b] - r) * rinv - damp
            vtr1, vtr2 = vt1 + dely * wr3, vt2 - delx * wr3
            shear = self.history.get((a, b), np.zeros(2)).copy()
            if update_history:
                shear += np.array([vtr1 * dt, vtr2 * dt])
            shrmag = np.sqrt(shear[0] * shear[0] + shear[1] * shear[1])
            rsht = (shear[0] * delx + shear[1] * dely) * rsqinv
            if update_history:
                shear -= rsht * np.array([delx, dely])
            fs1 = -(c.kt * shear[0] + meff * c.gamma_t * vtr1)
            fs2 = -(c.kt * shear[1] + meff * c.gamma_t * vtr2)
            fs = np.sqrt(fs1 * fs1 + fs2 * fs2)
            mu = c.mu_wall if (d.frozen[a] or d.frozen[b]) else c.mu
            fn = mu * abs(ccel * r)
            if fs > fn:
                if shrmag != 0.0:
                    t1 = meff * c.gamma_t * vtr1 / c.kt
                    t2 = meff * c.gamma_t * vtr2 / c.kt
                    shear = np.array([(fn / fs) * (shear[0] + t1) - t1,
                                      (fn / fs) * (shear[1] + t2) - t2])
                    fs1 *= fn / fs
                    fs2 *= fn / fs
                else:
                    fs1 = fs2 = 0.0
            new_history[(a, b)] = shear
            fx, fy = delx * ccel + fs1, dely * ccel + fs2
            tor3 = rinv * (delx * fs2 - dely * fs1)
            d.force[a] += (fx, fy)
            d.force[b] -= (fx, fy)
            d.torque[a] -= d.radius[a] * tor3
            d.torque[b] -= d.radius[b] * tor3
            rows.append((a, b, delx * ccel, dely * ccel, fs1, fs2))
        if update_history:
            self.history = new_history
        self.contacts = np.array(rows).reshape(-1, 6)

    def step(self):
        """One velocity-Verlet step of ``fix nve/sphere disc`` + ``enforce2d``."""
        d, dt = self.d, self.dt
        free = ~d.frozen
        dtf = 0.5 * dt
        dtfm = (dtf / d.mass[free])[:, None]
        dtirotate = (dtf / 0.5) / (d.radius[free] * d.radius[free] * d.mass[free])
        d.v[free] += dtfm * d.force[free]
        d.x[free] += dt * d.v[free]
        d.omega[free] += dtirotate * d.torque[free]
        self.compute_forces()
        d.v[free] += dtfm * d.force[free]
        d.omega[free] += dtirotate * d.torque[free]
        self.step_count += 1
