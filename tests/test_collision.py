"""Two-body collisions in real LAMMPS against the analytic linear spring-dashpot.

The pair style gets its coefficients from granavg.sim.contact_law.to_lammps, so this checks
the conversion and LAMMPS' contact law together: restitution exp(-gamma_n t_c/2) and
contact duration pi/omega_d, for two disks and for a disk against a frozen wall disk
(which must act as an infinite mass: m_eff = m_disk).
"""

import numpy as np
import pytest

from granavg.sim.contact_law import (ContactLaw, contact_duration, disk_mass, effective_mass,
                                     restitution, to_lammps)
from granavg.sim.collision import D, lammps_trajectory

M = disk_mass(D, 1060, 0.006)


def collide(law, partner_frozen, steps_per_tc=400, v0=0.01):
    """Head-on collision along x in LAMMPS; returns (contact time s, restitution, dt)."""
    c = to_lammps(law, effective_mass(M, M))
    dt = c.t_c / steps_per_tc
    v1, v2 = (v0, 0.0) if partner_frozen else (v0 / 2, -v0 / 2)
    start = [(-0.5 * D - 1e-4, 0, v1, 0, 0), (0.5 * D + 1e-4, 0, v2, 0, 0)]
    _, _, traj = lammps_trajectory(c, dt, start, partner_frozen, 5 * steps_per_tc)
    x1, x2, vx1, vx2 = traj[:, 0], traj[:, 2], traj[:, 4], traj[:, 6]
    touching = D - (x2 - x1) > 0
    first = int(np.argmax(touching))
    after = first + int(np.argmin(touching[first:]))
    assert touching.any() and not touching[after], "the disks never separated"
    return (after - first) * dt, (vx2[after] - vx1[after]) / (v1 - v2), dt


@pytest.mark.parametrize("e_n", [0.5, 0.9, 1.0])
def test_head_on_disks_match_the_analytic_restitution_and_duration(e_n):
    law = ContactLaw(k_n=10.0, e_n=e_n)
    t_contact, e, dt = collide(law, partner_frozen=False)
    c = to_lammps(law, effective_mass(M, M))
    assert t_contact == pytest.approx(c.t_c, abs=1.5 * dt)
    assert e == pytest.approx(e_n, rel=5e-3)


def test_frozen_wall_disk_acts_as_infinite_mass():
    law = ContactLaw(k_n=10.0, e_n=0.9)
    t_contact, e, dt = collide(law, partner_frozen=True)
    c = to_lammps(law, effective_mass(M, M))
    # one gamma_n for all pairs: against the wall m_eff = M, so e and t_c differ from 0.9
    assert e == pytest.approx(restitution(c.kn, c.gamma_n, M), rel=5e-3)
    assert t_contact == pytest.approx(contact_duration(c.kn, c.gamma_n, M), abs=1.5 * dt)
    assert e < 0.89


def test_the_deck_s_base_friction_slows_a_free_disk_as_coulomb_friction_does():
    """A disk sliding alone on the base plate: dv/dt = -mu_base g v / sqrt(v^2 + v_base^2)
    (the deck's lines, run by LAMMPS), against the ODE solved to 1e-10: it decelerates at
    mu_base g while v >> v_base, keeps its direction, and stops after v0 / (mu_base g)."""
    from scipy.integrate import solve_ivp

    mu_b, v_b, dt, v0 = 0.5, 0.001, 1e-4, (0.05, 0.02)
    c = to_lammps(ContactLaw(), effective_mass(disk_mass(D, 1060, 0.006),
                                               disk_mass(D, 1060, 0.006)))
    _, _, tr = lammps_trajectory(c, dt, [(0, 0, *v0, 0), (0.04, 0, 0, 0, 0)], True, 200,
                                 base=(mu_b, v_b))
    speed = np.hypot(tr[:, 4], tr[:, 5])
    t = dt * np.arange(1, 201)
    ode = solve_ivp(lambda _, v: -mu_b * 9.81 * v / np.sqrt(v * v + v_b * v_b),
                    (0, t[-1]), [np.hypot(*v0)], t_eval=t, rtol=1e-10, atol=1e-13).y[0]
    assert np.max(np.abs(speed - ode)) < 0.5 * mu_b * 9.81 * dt      # half a step's change
    sliding = speed > 10 * v_b
    assert np.allclose(np.diff(speed[sliding]) / dt, -mu_b * 9.81, rtol=0.01)
    assert np.allclose(tr[sliding, 5] / tr[sliding, 4], v0[1] / v0[0], rtol=1e-9)
    assert speed[-1] < 1e-6 and np.hypot(*v0) / (mu_b * 9.81) < t[-1]
    # without it the disk keeps its speed
    _, _, free = lammps_trajectory(c, dt, [(0, 0, *v0, 0), (0.04, 0, 0, 0, 0)], True, 20)
    assert np.allclose(free[:, 4:6], v0, rtol=1e-12)
