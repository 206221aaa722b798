"""The physical -> LAMMPS conversion of the linear spring-dashpot (pure functions)."""

import math
import re
from pathlib import Path

import pytest

from granavg.sim.contact_law import (ContactLaw, contact_duration, damping_for_restitution,
                                     disk_mass, effective_mass, max_stable_timestep,
                                     restitution, to_lammps)
from granavg.errors import UserError
from granavg.sim.scene import PAPER_HOOKE


@pytest.mark.parametrize("e_n", [0.1, 0.5, 0.9, 0.99])
@pytest.mark.parametrize("k_n", [1.0, 10.0, 1e5])
def test_damping_gives_back_the_restitution(k_n, e_n):
    m = 1.3e-4
    gamma = damping_for_restitution(k_n, e_n, m)
    assert restitution(k_n, gamma, m) == pytest.approx(e_n, rel=1e-12)


def test_elastic_limit_is_half_period_of_the_spring():
    m, k = 2.0e-4, 50.0
    assert damping_for_restitution(k, 1.0, m) == 0.0
    assert contact_duration(k, 0.0, m) == pytest.approx(math.pi * math.sqrt(m / k))


def test_damped_oscillator_solution_matches_ode():
    """Integrate m x'' = -k x - m g x' finely: contact time and restitution as predicted."""
    law = ContactLaw(k_n=10.0, e_n=0.7)
    m = effective_mass(disk_mass(0.00742, 1060, 0.006), disk_mass(0.00742, 1060, 0.006))
    c = to_lammps(law, m)
    dt, x, v, t = c.t_c / 1e5, 0.0, 1.0, 0.0      # x: overlap, v: approach speed
    while True:
        a = -c.kn / m * x - c.gamma_n * v
        v += a * dt
        x += v * dt
        t += dt
        if x <= 0:
            break
    assert t == pytest.approx(c.t_c, rel=1e-4)
    assert -v == pytest.approx(0.7, rel=1e-3)


def test_to_lammps_follows_the_ratios():
    c = to_lammps(ContactLaw(k_n=100.0, e_n=0.8, kt_over_kn=0.4, gt_over_gn=0.25), 1e-4)
    assert c.kt == pytest.approx(40.0)
    assert c.gamma_t == pytest.approx(0.25 * c.gamma_n)


def test_stability_bound_of_an_undamped_spring_is_two_over_omega():
    c = to_lammps(ContactLaw(k_n=10.0, e_n=1.0, kt_over_kn=0.0), 1e-4)
    assert max_stable_timestep(c, 1e-4) == pytest.approx(2.0 / math.sqrt(10.0 / 1e-4))


@pytest.mark.parametrize("bad", [dict(k_n=-1), dict(e_n=0), dict(e_n=1.5), dict(mu=-0.1),
                                 dict(k_n=float("nan"))])
def test_unphysical_constants_are_refused(bad):
    with pytest.raises(UserError):
        ContactLaw(**bad)


def test_deck_defaults_are_the_paper_hooke_preset():
    """lammps_inputs/couette.lmp must run the paper-hooke scene (the plain law, grown
    from random positions) under plain `lmp -in`."""
    deck = (Path(__file__).parents[1] / "lammps_inputs" / "couette.lmp").read_text()
    defaults = dict(re.findall(r"^variable\s+(\w+)\s+index\s+(\S+)", deck, re.M))
    for key, value in PAPER_HOOKE.derive().lammps_variables().items():
        assert float(defaults[key]) == pytest.approx(float(value), rel=1e-9), key
