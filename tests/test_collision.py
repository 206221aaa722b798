"""Two-body collisions in real LAMMPS against the analytic linear spring-dashpot.

The pair style gets its coefficients from granavg.contact_law.to_lammps, so this checks
the conversion and LAMMPS' contact law together: restitution exp(-gamma_n t_c/2) and
contact duration pi/omega_d, for two disks and for a disk against a frozen wall disk
(which must act as an infinite mass: m_eff = m_disk).
"""

import numpy as np
import pytest

from granavg.contact_law import (ContactLaw, contact_duration, disk_mass, effective_mass,
                                 restitution, to_lammps)
from granavg.lammps_session import lammps_session

D, RHO_AREA = 0.00742, 1060 * 0.006
M = disk_mass(D, 1060, 0.006)


def collide(law, partner_frozen, steps_per_tc=400, v0=0.01):
    """Head-on collision along x; returns (contact time s, restitution)."""
    c = to_lammps(law, effective_mass(M, M))
    dt = c.t_c / steps_per_tc
    v1, v2 = (v0, 0.0) if partner_frozen else (v0 / 2, -v0 / 2)
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string(f"""
            units si
            dimension 2
            boundary f f p
            atom_style sphere 1
            atom_modify map array
            comm_modify vel yes
            region box block -0.05 0.05 -0.05 0.05 -0.005 0.005
            create_box 4 box
            create_atoms 1 single {-0.5 * D - 1e-4} 0 0
            create_atoms {4 if partner_frozen else 1} single {0.5 * D + 1e-4} 0 0
            set type * diameter {D}
            set type * density/disc {RHO_AREA}
            set atom 1 vx {v1}
            set atom 2 vx {v2}
            group mobile type 1
            group walls type 4
            pair_style gran/hooke/history {c.kn} {c.kt} {c.gamma_n} {c.gamma_t} {c.mu} 1
            pair_coeff * *
            neighbor 0.001 bin
            fix integrate mobile nve/sphere disc
            fix frozen walls freeze
            fix flat all enforce2d
            timestep {dt}
            run 0""")
        in_contact, before = 0, None
        for _ in range(5 * steps_per_tc):
            x = lmp.numpy.extract_atom("x")[:2, 0].copy()
            v = lmp.numpy.extract_atom("v")[:2, 0].copy()
            idx = np.argsort(lmp.numpy.extract_atom("id")[:2])
            x, v = x[idx], v[idx]
            overlap = D - (x[1] - x[0])
            if before is None:
                before = v[0] - v[1]
            if overlap > 0:
                in_contact += 1
            elif in_contact:
                return in_contact * dt, (v[1] - v[0]) / before, dt
            lmp.command("run 1 pre no post no")
    raise AssertionError("the disks never separated")


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
