"""Continuum analysis (Eqs. 8-15) on profiles whose answers are known."""

import numpy as np
import pytest

from granavg.analysis.continuum import (deformation_rate_and_spin,
                                        deformation_rate_and_spin_fit, equations_of_motion,
                                        momentum_flux_total, orientation, power_law, stiffness)
from granavg.analysis.shear_band import fit_band

R_I, R_O, OMEGA = 0.1032, 0.2524, 0.1


def rings(n):
    edges = np.linspace(R_I, R_O, n + 1)
    return 0.5 * (edges[1:] + edges[:-1])


def test_stress_exponents_zero_and_minus_two():
    r = rings(20)
    n, err = power_law(r, 3e-3 / r**2)
    assert n == pytest.approx(-2, abs=1e-12) and err < 1e-9
    assert power_law(r, np.full_like(r, -9.4))[0] == pytest.approx(0, abs=1e-12)


def equilibrium(n):
    r = rings(n)
    c = 3e-3
    return r, (np.full(n, -9.0), c / r**2, c / r**2, np.full(n, -9.0))


def test_an_equilibrium_field_has_zero_residuals_converging_at_second_order():
    errors = []
    for n in (20, 40, 80, 160):
        r, sigma = equilibrium(n)
        radial, tangential = equations_of_motion(r, sigma)
        assert np.allclose(radial, 0, atol=1e-12)       # constant diagonal: exact
        errors.append(np.abs(tangential).max())
    order = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.diff(order) > 0) and order[-1] > 1.85   # tends to 2 (measured 1.93)


def steady_rotating_flow(n, omega=0.1, rho=850.0, T0=2e-3, P0=9.0, A=3e-3):
    """A steady rigid rotation v_phi = omega r with an isotropic fluctuation stress
    rho T(r), T = T0 r (m^2/s^2), and a static stress chosen so that div(sigma - dsigma)
    vanishes: sigma - dsigma = -P0 on the diagonal and A/r^2 off it (Pa)."""
    r = rings(n)
    v = omega * r
    T = T0 * r
    dsigma = (rho * T, 0 * r, 0 * r, rho * v**2 + rho * T)        # rho <v v>, Eq. 6
    total = (-P0 + 0 * r, A / r**2, A / r**2, -P0 + 0 * r)
    sigma = tuple(t + d for t, d in zip(total, dsigma))
    return r, rho, v, T, sigma, dsigma


def test_the_momentum_balance_is_div_of_sigma_minus_dsigma():
    r, rho, v, T, sigma, dsigma = steady_rotating_flow(400)
    radial, tangential = equations_of_motion(r, momentum_flux_total(sigma, dsigma))
    # second-order finite differences on 400 rings: residual/terms ~ (dr/r)^2 ~ 1e-5
    assert np.abs(radial).max() < 1e-9 and np.abs(tangential).max() < 2e-4 * 3e-3 / r[0] ** 2
    # the old combination, sigma + dsigma plus a separate rho v_phi^2, does not vanish:
    # it leaves 2 rho T0 r - rho v^2 (the inertia cancelled, the fluctuations' sign flipped)
    old, _ = equations_of_motion(r, tuple(s + d for s, d in zip(sigma, dsigma)))
    old = old + rho * v**2
    assert np.allclose(old, 2 * rho * 2e-3 * r - rho * v**2, rtol=1e-6)
    assert np.abs(old).min() > 1e3 * np.abs(radial).max()


def test_the_tangential_balance_takes_the_divergence_on_the_second_index():
    """sigma_ij = f_i l_j: (div T)_phi = dT_phir/dr + (T_rphi + T_phir)/r. A torque-free,
    non-symmetric field: T_phir = A/r, T_rphi = 0."""
    r = rings(400)
    A = 1e-3
    T = (np.zeros_like(r), np.zeros_like(r), A / r, np.zeros_like(r))
    _, tangential = equations_of_motion(r, T)
    assert np.abs(tangential).max() < 1e-4 * A / r[0]     # finite differences, (dr/r)^2
    transposed = (T[0], T[2], T[1], T[3])              # the paper's printed index order
    _, wrong = equations_of_motion(r, transposed)
    assert np.allclose(wrong, A / r, rtol=1e-4)


def test_rigid_rotation_has_no_deformation_rate_and_spin_omega():
    r = rings(20)
    D, W = deformation_rate_and_spin(r, OMEGA * r)
    assert np.allclose(D, 0, atol=1e-15) and np.allclose(W, OMEGA, rtol=1e-12)


def test_fit_and_profile_deformation_rates_agree_for_an_exponential():
    r = rings(200)
    v0, s = 0.0066, 0.0127
    band = fit_band(r, v0 * np.exp(-(r - R_I) / s), np.full(200, 1e-9), R_I, 0.0076, OMEGA)
    D, W = deformation_rate_and_spin(r, v0 * np.exp(-(r - R_I) / s))
    Df, Wf = deformation_rate_and_spin_fit(r, band, R_I)
    # finite differences of h = 0.75 mm against s = 12.7 mm: O((h/s)^2) ~ 3e-3 at the edge
    assert np.allclose(D[:100], Df[:100], rtol=3e-3) and np.allclose(W[:100], Wf[:100], rtol=3e-3)
    assert np.allclose(D[1:100], Df[1:100], rtol=1e-3) and np.allclose(W[1:100], Wf[1:100], rtol=1e-3)


@pytest.mark.parametrize("theta", [0.0, 0.3, -0.7, 1.2])
def test_orientation_of_a_rotated_tensor(theta):
    c, s = np.cos(theta), np.sin(theta)
    Q = np.array([[c, -s], [s, c]])
    for eig in ([2.0, 0.5], [-3.0, -1.0]):              # fabric-like, compressive stress
        T = Q @ np.diag(eig) @ Q.T
        got = orientation((T[0, 0], T[0, 1], T[1, 0], T[1, 1]))
        assert np.isclose((got - theta + np.pi / 2) % np.pi - np.pi / 2, 0, atol=1e-12)


def test_crystal_stiffness_is_linear_in_the_fabric():
    """For the compressed hexagonal crystal, tr sigma / tr eps / k_n = tr F / (2 pi h)."""
    from tests.helpers import HEX_H as H, hex_crystal, ring_average as average
    from granavg.engine.cells.rings import Rings

    p = average([hex_crystal(k=10.0)], Rings.count(6, 0.03, 0.09, H))
    comps = ("rr", "rphi", "phir", "phiphi")
    bulk, _ = stiffness([p.values[f"sigma_{c}"] for c in comps],
                        [p.values[f"eps_{c}"] for c in comps], 10.0)
    trF = p.values["F_rr"] + p.values["F_phiphi"]
    assert np.allclose(bulk, trF / (2 * np.pi * H), rtol=1e-10)
