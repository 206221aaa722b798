"""A small reference DEM in 2D with LAMMPS' contact laws and integrator (SI units).

It exists to check LAMMPS runs and granavg's averaging against an independent engine
with the same physics; it is not a production engine (numpy, no MPI; candidate pairs
come from a k-d tree). It follows, operation for operation, so that results agree to
round-off:

- ``pair gran/hooke/history`` (Kn Kt gamma_n gamma_t mu, dampflag 1), when
  ``mu_roll == 0``: for a pair in contact (r < r_i + r_j), with del = x_i - x_j, the
  normal force on i ``(kn (r_i + r_j - r) / r - m_eff gamma_n (v_r . del) / r^2) del``;
  the tangential spring (history) advanced by ``dt v_t`` (v_t the relative tangential
  velocity of the contact points), projected back onto the tangent plane, the
  tangential force ``-(kt shear + m_eff gamma_t v_t)`` capped at ``mu |F_n|`` with
  LAMMPS' rescaling of the history; torque ``-r_i (del x F_t)_z / r``. m_eff = m_i m_j /
  (m_i + m_j), or the free disk's mass when the other is frozen (a wall).
- ``pair granular`` with ``hooke kn gamma_n tangential linear_history kt x_gamma_t mu
  damping mass_velocity rolling sds k_roll gamma_roll mu_roll``, when ``mu_roll > 0``
  (the deck's rolling-resistance law): with n = del / r and overlap delta, the normal
  force ``F_n = kn delta - m_eff gamma_n v_r . n`` along n (no limit_damping: it pulls
  at the end of a contact, and the Coulomb limits use ``|F_n|``); the tangential spring
  first turned into the current tangent plane keeping its length, then advanced by
  ``dt v_t``, the force ``-(kt xi + x_gamma_t m_eff gamma_n v_t)`` capped at
  ``mu |F_n|``; a rolling spring the same way with the rolling velocity
  ``R_eff (omega_i - omega_j) z x n`` (R_eff = r_i r_j / (r_i + r_j)),
  ``-(k_roll xi_r + gamma_roll v_roll)`` capped at ``mu_roll |F_n|``. Torque on i:
  ``-(r_i - delta/2) (n x F_t)_z + R_eff (n x F_r)_z`` (the tangential force acts at
  the contact point; the rolling force turns i and j oppositely and moves neither).
  Not reproduced: when a neighbour-list rebuild swaps the order of a touching pair,
  LAMMPS' fix neigh/history negates all its history, the rolling spring included,
  although the rolling velocity does not change sign with the order; the reference
  keeps the spring (docs/refdem.md).
- the deck's friction with the base plate (``fix addforce`` of atom-style variables,
  when ``base`` is given): ``-mu_base 9.81 m v / sqrt(v . v + v_base^2)`` on every free
  disk, added after the contact forces with the half-step velocities, as LAMMPS'
  ``post_force`` does; or, with base_every N > 0, c v with the coefficient c =
  -mu_base 9.81 m / sqrt(v . v + v_base^2) of the velocities at setup and at the end of
  every N-th step (``fix store/state``).
- ``fix nve/sphere disc`` (velocity Verlet, moment of inertia m r^2 / 2) with
  ``fix enforce2d``: half kick, drift, forces, half kick.
- ``fix move rotate 0 0 0 0 0 1 T`` for a rotating wall ring: at step n its disks sit
  at their start positions turned by Omega n dt about the origin, move with
  v = Omega z x r and spin at Omega; like all wall disks they are frozen (infinite mass).
- ``compute pair/local`` for the contact dump: forces re-evaluated after the step from
  the stored (updated) springs and the end-of-step velocities, as the pair style's
  ``single()``; for ``pair granular`` that also re-caps, and so rewrites, the stored
  tangential spring of a contact sliding at that moment (not the rolling spring), as
  LAMMPS does: a run that writes contacts differs from one that does not.

The contact law's constants come from :func:`granavg.sim.contact_law.to_lammps`, the same
function the decks use.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from granavg.sim.contact_law import LammpsCoefficients
from granavg.sim.scene import G

#: LAMMPS' EPSILON of pair granular's history models: a spring whose normal component
#: times its stiffness is below EPSILON times the Coulomb limit is not turned.
EPSILON = 1e-10


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


@dataclass
class _Pairs:
    """What both contact laws start from, one entry per touching pair (SI units)."""

    i: np.ndarray            # (n,) first disk of each pair (i < j)
    j: np.ndarray            # (n,) second disk
    delx: np.ndarray         # (n,) x_i - x_j, m
    dely: np.ndarray         # (n,) y_i - y_j, m
    rsq: np.ndarray          # (n,) squared centre distance, m^2
    r: np.ndarray            # (n,) centre distance, m
    vr1: np.ndarray          # (n,) v_i - v_j, x, m/s
    vr2: np.ndarray          # (n,) v_i - v_j, y, m/s
    meff: np.ndarray         # (n,) effective mass, kg (the free disk's mass against a wall)
    mu: np.ndarray           # (n,) friction coefficient (mu_wall against a wall)
    springs: np.ndarray      # (n, 2 or 4) stored springs (tangential, then rolling), m


class ReferenceDEM:
    """Integrate :class:`Disks` with LAMMPS' granular contact laws and ``nve/sphere``.

    ``pair gran/hooke/history`` when ``coeffs.mu_roll == 0``, else ``pair granular``
    hooke + linear_history + rolling sds (see the module docstring).

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
    base : (float, float[, int]), optional
        (mu_base, v_base in m/s[, base_every]): the deck's Coulomb friction with the base
        plate (module docstring): the law each step (base_every 0, the default) or its
        coefficient renewed every base_every steps; None or mu_base = 0: none.
    """

    def __init__(self, disks: Disks, coeffs: LammpsCoefficients, dt: float,
                 rotating=None, Omega: float = 0.0, base=None):
        self.d, self.c, self.dt = disks, coeffs, dt
        self.base = (*base[:2], base[2] if len(base) > 2 else 0) \
            if base is not None and base[0] > 0 else None
        self.step_count = 0
        self.granular = coeffs.mu_roll > 0
        # sorted pair keys and springs: tangential (x, y), then rolling (x, y) with pair granular
        self.history = (np.empty(0, int), np.empty((0, 4 if self.granular else 2)))
        self._rolling = np.empty((0, 2))      # the last evaluation's rolling forces on i
        self.rotating = np.zeros(len(disks.radius), bool) if rotating is None \
            else np.asarray(rotating, bool)
        if np.any(self.rotating & ~disks.frozen):
            raise ValueError("rotating wall disks must be frozen")
        self.Omega, self.x0 = Omega, disks.x[self.rotating].copy()
        self.skin, self._neigh, self.rebuilds = 0.5 * disks.radius.min(), None, 0
        self.contacts = None
        if self.base is not None and self.base[2]:
            self._store_base_coefficient()
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
        i, j, fn, ft, tq_i, tq_j, _ = self._contact_forces(update_history)
        d, n = self.d, len(self.d.radius)
        fx, fy = fn[:, 0] + ft[:, 0], fn[:, 1] + ft[:, 1]
        d.force[:, 0] = np.bincount(i, fx, n) - np.bincount(j, fx, n)
        d.force[:, 1] = np.bincount(i, fy, n) - np.bincount(j, fy, n)
        d.torque[:] = np.bincount(i, tq_i, n) + np.bincount(j, tq_j, n)
        if self.base is not None:
            self._add_base_friction()
        self.contacts = (i, j, fn, ft)

    def _law_now(self):
        """The deck's base friction with ``base_every`` 0, operation for operation:
        ``-v_mu_base*9.81*mass*vx/v_vbase``, ``v_vbase = sqrt(vx*vx+vy*vy+v_v_base*
        v_v_base)`` of the half-step velocities."""
        (mu, vb, _), d, free = self.base, self.d, ~self.d.frozen
        vx, vy = d.v[free, 0], d.v[free, 1]
        speed = np.sqrt(vx * vx + vy * vy + vb * vb)
        d.force[free, 0] += -mu * G * d.mass[free] * vx / speed
        d.force[free, 1] += -mu * G * d.mass[free] * vy / speed

    def _store_base_coefficient(self):
        """The deck's ``fix cbase mobile store/state base_every v_cbase``, operation for
        operation: ``-v_mu_base*9.81*mass/sqrt(vx*vx+vy*vy+v_v_base*v_v_base)`` of the
        free disks' velocities now (LAMMPS stores it at setup and at the end of every
        step that is a multiple of base_every)."""
        (mu, vb, _), d, free = self.base, self.d, ~self.d.frozen
        vx, vy = d.v[free, 0], d.v[free, 1]
        self.base_c = -mu * G * d.mass[free] / np.sqrt(vx * vx + vy * vy + vb * vb)

    def _add_base_friction(self):
        """The deck's ``fix addforce v_fbx v_fby`` on the free disks: the law of the
        half-step velocities (``base_every`` 0), or ``f_cbase*vx``, ``f_cbase*vy`` with
        the stored coefficient."""
        if self.base[2] == 0:
            return self._law_now()
        d, free = self.d, ~self.d.frozen
        d.force[free, 0] += self.base_c * d.v[free, 0]
        d.force[free, 1] += self.base_c * d.v[free, 1]

    def contact_rows(self):
        """What LAMMPS' ``compute pair/local dx dy dist fx fy p1 p2`` reports now.

        Returns
        -------
        i, j : ndarray of int, shape (n,)
            Disk indices of each touching pair (i < j).
        rows : ndarray, shape (n, 7), or (n, 9) with pair granular
            dx dy dist (m; dx = x_i - x_j), normal force on i (``del * fforce`` of the
            pair style's ``single()``), tangential force on i (N), re-evaluated from the
            stored springs and the current velocities (with pair granular this rewrites
            the tangential springs of sliding contacts, as LAMMPS' ``single()`` does),
            and with pair granular the rolling force on i (``p5 p6``, N).
        """
        i, j, _, ft, _, _, fpair = self._contact_forces(update_history=False)
        dx = self.d.x[i] - self.d.x[j]
        cols = [dx, np.hypot(dx[:, 0], dx[:, 1]), dx * fpair[:, None], ft]
        if self.granular:
            cols.append(self._rolling)
        return i, j, np.column_stack(cols)

    def _contact_forces(self, update_history):
        """Per-contact forces and torques of the active contact law (vectorised over
        contacts), and the springs it leaves stored.

        Returns
        -------
        i, j : ndarray of int, shape (n,)
        fn, ft : ndarray, shape (n, 2)
            Normal and tangential force on i, N.
        tq_i, tq_j : ndarray, shape (n,)
            Torque on i and on j, N m.
        fpair : ndarray, shape (n,)
            ``fforce`` of the pair style's ``single()``: normal force over distance, N/m.
        """
        d = self.d
        i, j = self.pairs()
        delx, dely = d.x[i, 0] - d.x[j, 0], d.x[i, 1] - d.x[j, 1]
        rsq = delx * delx + dely * dely
        mi, mj = d.mass[i], d.mass[j]
        keys = i * len(d.radius) + j
        p = _Pairs(i=i, j=j, delx=delx, dely=dely, rsq=rsq, r=np.sqrt(rsq),
                   vr1=d.v[i, 0] - d.v[j, 0], vr2=d.v[i, 1] - d.v[j, 1],
                   meff=np.where(d.frozen[j], mi,
                                 np.where(d.frozen[i], mj, mi * mj / (mi + mj))),
                   mu=np.where(d.frozen[i] | d.frozen[j], self.c.mu_wall, self.c.mu),
                   springs=self._old_history(keys))
        law = self._granular if self.granular else self._hooke_history
        fn, ft, tq_i, tq_j, fpair, springs = law(p, update_history)
        if update_history or self.granular:     # pair granular's cap writes even then
            self.history = (keys, springs)
        return i, j, fn, ft, tq_i, tq_j, fpair

    def _hooke_history(self, p: _Pairs, update_history):
        """``pair gran/hooke/history`` (dampflag 1), each operation in LAMMPS' order.

        Returns normal and tangential force on i (N), torques on i and j (N m), single()'s
        normal force over distance (N/m) and the new tangential springs (m).
        """
        d, c, dt = self.d, self.c, self.dt
        i, j, delx, dely, meff = p.i, p.j, p.delx, p.dely, p.meff
        rinv, rsqinv = 1.0 / p.r, 1.0 / p.rsq
        vr1, vr2 = p.vr1, p.vr2
        vnnr = vr1 * delx + vr2 * dely
        vt1, vt2 = vr1 - delx * vnnr * rsqinv, vr2 - dely * vnnr * rsqinv
        wr3 = (d.radius[i] * d.omega[i] + d.radius[j] * d.omega[j]) * rinv
        ccel = c.kn * (d.radius[i] + d.radius[j] - p.r) * rinv - meff * c.gamma_n * vnnr * rsqinv
        vtr1, vtr2 = vt1 + dely * wr3, vt2 - delx * wr3
        s1, s2 = p.springs[:, 0], p.springs[:, 1]
        if update_history:
            s1, s2 = s1 + vtr1 * dt, s2 + vtr2 * dt
        shrmag = np.sqrt(s1 * s1 + s2 * s2)
        rsht = (s1 * delx + s2 * dely) * rsqinv
        if update_history:
            s1, s2 = s1 - rsht * delx, s2 - rsht * dely
        fs1 = -(c.kt * s1 + meff * c.gamma_t * vtr1)
        fs2 = -(c.kt * s2 + meff * c.gamma_t * vtr2)
        fs = np.sqrt(fs1 * fs1 + fs2 * fs2)
        fn = p.mu * np.abs(ccel * p.r)
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
        return (np.column_stack([delx * ccel, dely * ccel]), np.column_stack([fs1, fs2]),
                -d.radius[i] * tor3, -d.radius[j] * tor3, ccel, np.column_stack([s1, s2]))

    def _granular(self, p: _Pairs, update_history):
        """``pair granular`` hooke + mass_velocity damping + linear_history + rolling sds
        (``GranularModel::calculate_forces``), each operation in LAMMPS' order.

        Returns normal and tangential force on i (N), torques on i and j (N m), single()'s
        normal force over distance (N/m) and the new springs (m): tangential, then
        rolling (the stored one unless updating: LAMMPS' rolling model caps a copy).
        """
        d, c = self.d, self.c
        i, j = p.i, p.j
        ri, rj = d.radius[i], d.radius[j]
        reff = ri * rj / (ri + rj)
        rinv = 1.0 / p.r
        delta = (ri + rj) - p.r
        nx, ny = p.delx * rinv, p.dely * rinv
        vnnr = p.vr1 * nx + p.vr2 * ny
        vt1, vt2 = p.vr1 - vnnr * nx, p.vr2 - vnnr * ny
        wr = ri * d.omega[i] + rj * d.omega[j]
        vtr1, vtr2 = vt1 + wr * ny, vt2 - wr * nx                  # v_t - wr z x n
        fnormal = c.kn * delta
        damp_normal = c.gamma_n * p.meff                           # mass_velocity prefactor
        fntot = fnormal + -damp_normal * vnnr
        fncrit = np.abs(fntot)                                     # no limit_damping
        x_gamma_t = c.gamma_t / c.gamma_n if c.gamma_n else 0.0    # as the deck's variable
        fs1, fs2, xi1, xi2 = self._history_spring(
            p.springs[:, 0], p.springs[:, 1], vtr1, vtr2, nx, ny, c.kt,
            x_gamma_t * damp_normal, fncrit * p.mu, update_history)
        relrot = d.omega[i] - d.omega[j]
        vrl1, vrl2 = reff * -(relrot * ny), reff * (relrot * nx)  # R_eff (w_i - w_j) z x n
        fr1, fr2, rl1, rl2 = self._history_spring(
            p.springs[:, 2], p.springs[:, 3], vrl1, vrl2, nx, ny, c.k_roll,
            c.gamma_roll, c.mu_roll * fncrit, update_history)
        if not update_history:                 # the rolling model keeps its stored spring
            rl1, rl2 = p.springs[:, 2], p.springs[:, 3]
        self._rolling = np.column_stack([fr1, fr2])                # pair/local's p5 p6
        nxfs = -(nx * fs2 - ny * fs1)                              # -(n x F_t)_z
        torroll = reff * (nx * fr2 - ny * fr1)                     # R_eff (n x F_r)_z
        return (np.column_stack([fntot * nx, fntot * ny]), np.column_stack([fs1, fs2]),
                nxfs * (ri - 0.5 * delta) + torroll, nxfs * (rj - 0.5 * delta) - torroll,
                fntot * rinv, np.column_stack([xi1, xi2, rl1, rl2]))

    def _history_spring(self, h1, h2, v1, v2, nx, ny, k, damp, crit, update_history):
        """One history spring of pair granular (``linear_history`` or ``rolling sds``).

        When updating: a spring with a normal component (``|h . n| k > EPSILON crit``) is
        projected onto the tangent plane and rescaled to its old length, then advanced by
        ``dt v``. Force ``-k h - damp v``; above ``crit`` it is scaled down to ``crit``
        and the spring set to what gives that force (left unchanged, with zero force, if
        the spring is zero). LAMMPS' rolling model writes this last step with its
        factors grouped differently (the same up to rounding).

        Parameters
        ----------
        h1, h2 : ndarray
            Spring (history), m.
        v1, v2 : ndarray
            Relative velocity that loads it, m/s.
        nx, ny : ndarray
            Contact normal (unit, from j to i).
        k : float
            Stiffness, N/m.
        damp : float or ndarray
            Damping, kg/s.
        crit : ndarray
            Coulomb limit of the force, N.
        update_history : bool

        Returns
        -------
        f1, f2, h1, h2 : ndarray
            Force on i (N) and the spring after the step (m).
        """
        if update_history:
            rsht = h1 * nx + h2 * ny
            turn = np.abs(rsht) * k > EPSILON * crit
            shrmag = np.sqrt(h1 * h1 + h2 * h2)
            p1, p2 = h1 - rsht * nx, h2 - rsht * ny
            prjmag = np.sqrt(p1 * p1 + p2 * p2)
            with np.errstate(invalid="ignore", divide="ignore"):
                scale = np.where(prjmag > 0, shrmag / prjmag, 0.0)
            h1, h2 = np.where(turn, scale * p1, h1), np.where(turn, scale * p2, h2)
            h1, h2 = h1 + self.dt * v1, h2 + self.dt * v2
        fd1, fd2 = -damp * v1, -damp * v2
        f1, f2 = -k * h1 + fd1, -k * h2 + fd2
        mag = np.sqrt(f1 * f1 + f2 * f2)
        slide = mag > crit
        rescale = slide & (np.sqrt(h1 * h1 + h2 * h2) != 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            s1, s2 = (crit / mag) * f1, (crit / mag) * f2
            kinv = np.divide(-1.0, k)
        h1 = np.where(rescale, (s1 - fd1) * kinv, h1)
        h2 = np.where(rescale, (s2 - fd2) * kinv, h2)
        f1 = np.where(slide, np.where(rescale, s1, 0.0), f1)
        f2 = np.where(slide, np.where(rescale, s2, 0.0), f2)
        return f1, f2, h1, h2

    def _old_history(self, keys):
        """Springs of these contacts from the last step (0 for new ones), shape
        (len(keys), 2 or 4)."""
        old_keys, old = self.history
        springs = np.zeros((len(keys), old.shape[1]))
        if len(old_keys):
            pos = np.minimum(np.searchsorted(old_keys, keys), len(old_keys) - 1)
            found = old_keys[pos] == keys
            springs[found] = old[pos[found]]
        return springs

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
        if self.base is not None and self.base[2] and self.step_count % self.base[2] == 0:
            self._store_base_coefficient()

    def _turn_ring(self, step):
        """``fix move rotate`` about the z axis through the origin, as LAMMPS does it."""
        arg = self.Omega * (step * self.dt)
        cosine, sine = np.cos(arg), np.sin(arg)
        a0, a1 = self.x0[:, 0], self.x0[:, 1]
        disp0, disp1 = a0 * cosine + -a1 * sine, a1 * cosine + a0 * sine
        self.d.x[self.rotating] = np.column_stack([disp0, disp1])
        self.d.v[self.rotating] = np.column_stack([self.Omega * -disp1, self.Omega * disp0])
        self.d.omega[self.rotating] = self.Omega
