"""The linear spring-dashpot contact law in physical terms (SI units).

LAMMPS' ``pair gran/hooke/history`` computes, for a pair in contact with overlap
``delta`` and effective mass ``m_eff = m_i m_j / (m_i + m_j)``,

    F_n = k_n delta n - m_eff gamma_n v_n
    F_t = -(k_t xi + m_eff gamma_t v_t),   |F_t| <= mu |F_n|

with ``xi`` the tangential spring (history). The normal part is a damped harmonic
oscillator in the overlap with angular frequency ``omega0 = sqrt(k_n / m_eff)``. Solving
it gives the contact duration ``t_c = pi / sqrt(omega0^2 - (gamma_n/2)^2)`` and the
normal restitution ``e_n = exp(-gamma_n t_c / 2)``.

Users give ``k_n`` (N/m), ``e_n``, ``k_t/k_n``, ``mu`` and ``mu_wall``. Because LAMMPS
has one ``gamma_n`` (1/s) for every pair, it is fixed by the restitution of the
reference pair, two small disks; other pairs (large disks, disk-wall) then have a
slightly different restitution, reported by :func:`restitution`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from granavg.errors import ParameterError, literal


@dataclass(frozen=True)
class ContactLaw:
    """Contact constants in SI units.

    Attributes
    ----------
    k_n : float
        Normal spring stiffness, N/m.
    e_n : float
        Normal restitution coefficient of a small-small collision, 0 < e_n <= 1.
    kt_over_kn : float
        Tangential to normal stiffness ratio k_t/k_n.
    gt_over_gn : float
        Tangential to normal damping ratio gamma_t/gamma_n (LAMMPS' default is 0.5).
    mu : float
        Coulomb friction coefficient between disks.
    mu_wall : float
        Coulomb friction coefficient between a disk and a wall disk.
    mu_roll : float
        Rolling-resistance coefficient (0: none, LAMMPS ``pair gran/hooke/history``;
        > 0: ``pair granular`` hooke + linear_history + ``rolling sds``, the same normal
        and tangential law plus a rolling spring k_roll = k_t, damping gamma_t m_eff,
        capped at mu_roll |F_n|).
    """

    k_n: float = 10.0
    e_n: float = 0.9
    kt_over_kn: float = 2.0 / 7.0
    gt_over_gn: float = 0.5
    mu: float = 0.8
    mu_wall: float = 0.8
    mu_roll: float = 0.0

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not math.isfinite(value):
                raise ParameterError("overrides", f"contact law: {name} = {value}: must be a "
                                     "finite number; fix the {param} value")
        checks = [
            (self.k_n > 0, "k_n must be > 0 N/m"),
            (0 < self.e_n <= 1, "e_n must be in (0, 1]"),
            (self.kt_over_kn >= 0, "kt_over_kn must be >= 0"),
            (self.gt_over_gn >= 0, "gt_over_gn must be >= 0"),
            (self.mu >= 0 and self.mu_wall >= 0 and self.mu_roll >= 0,
             "friction coefficients must be >= 0"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ParameterError("overrides", f"contact law: {msg} (got "
                                     f"{literal(asdict(self))}); fix the {{param}} value")


def disk_mass(diameter, rho_p, height):
    """Mass of a disk of diameter ``d`` (m), density ``rho_p`` (kg/m^3), height h (m): kg."""
    return rho_p * height * math.pi * (0.5 * diameter) ** 2


def effective_mass(m_i, m_j=math.inf):
    """Reduced mass m_i m_j/(m_i+m_j) in kg; ``m_j = inf`` for a wall (frozen) partner."""
    return m_i if math.isinf(m_j) else m_i * m_j / (m_i + m_j)


def damping_for_restitution(k_n, e_n, m_eff):
    """gamma_n (1/s) that gives restitution ``e_n`` for a pair of reduced mass m_eff (kg).

    From ``e_n = exp(-gamma_n t_c / 2)`` and ``t_c = pi / sqrt(k_n/m_eff - gamma_n^2/4)``:
    ``gamma_n = 2 sqrt(k_n/m_eff) * (-ln e_n) / sqrt(pi^2 + ln^2 e_n)``.
    """
    ln_e = math.log(e_n)
    return 2.0 * math.sqrt(k_n / m_eff) * (-ln_e) / math.sqrt(math.pi**2 + ln_e**2)


def contact_duration(k_n, gamma_n, m_eff):
    """Duration (s) of a collision of the linear spring-dashpot: pi / omega_damped.

    Returns ``inf`` when the pair is over-damped (no rebound).
    """
    w2 = k_n / m_eff - 0.25 * gamma_n**2
    return math.pi / math.sqrt(w2) if w2 > 0 else math.inf


def restitution(k_n, gamma_n, m_eff):
    """Normal restitution exp(-gamma_n t_c / 2) of a pair of reduced mass m_eff (kg)."""
    t_c = contact_duration(k_n, gamma_n, m_eff)
    return 0.0 if math.isinf(t_c) else math.exp(-0.5 * gamma_n * t_c)


@dataclass(frozen=True)
class LammpsCoefficients:
    """Arguments of ``pair_style gran/hooke/history Kn Kt gamma_n gamma_t xmu 1``.

    Attributes
    ----------
    kn, kt : float
        Normal and tangential stiffness, N/m.
    gamma_n, gamma_t : float
        Normal and tangential damping rates, 1/s.
    mu, mu_wall : float
        Friction coefficients (disk-disk, disk-wall).
    t_c : float
        Contact duration of a small-small pair, s.
    m_eff_ref : float
        Reduced mass of that reference pair, kg.
    mu_roll : float
        Rolling-resistance coefficient (0: plain gran/hooke/history).
    k_roll : float
        Rolling spring, N/m (= k_t).
    gamma_roll : float
        Rolling damping, kg/s (= gamma_t m_eff_ref; ``rolling sds`` takes it absolute).
    """

    kn: float
    kt: float
    gamma_n: float
    gamma_t: float
    mu: float
    mu_wall: float
    t_c: float
    m_eff_ref: float
    mu_roll: float = 0.0
    k_roll: float = 0.0
    gamma_roll: float = 0.0

    @property
    def pair_style(self) -> str:
        """What LAMMPS runs: the plain linear law, or the same with rolling resistance."""
        if self.mu_roll > 0:
            return ("pair granular: hooke (mass_velocity damping) + tangential "
                    "linear_history + rolling sds (the gran/hooke/history law plus rolling "
                    "resistance)")
        return "pair gran/hooke/history"


def to_lammps(law: ContactLaw, m_eff_ref: float) -> LammpsCoefficients:
    """Convert a physical contact law into LAMMPS ``gran/hooke/history`` coefficients.

    Parameters
    ----------
    law : ContactLaw
        Constants in physical terms (SI).
    m_eff_ref : float
        Reduced mass (kg) of the reference pair whose restitution is ``law.e_n``
        (two small disks in granavg's scenes).

    Returns
    -------
    LammpsCoefficients
        ``gamma_n`` from the restitution, ``gamma_t = gt_over_gn * gamma_n``,
        ``k_t = kt_over_kn * k_n``, the reference contact duration ``t_c`` and, with
        rolling resistance, ``k_roll = k_t`` and ``gamma_roll = gamma_t m_eff_ref``.
    """
    gamma_n = damping_for_restitution(law.k_n, law.e_n, m_eff_ref)
    kt, gamma_t = law.kt_over_kn * law.k_n, law.gt_over_gn * gamma_n
    return LammpsCoefficients(
        kn=law.k_n,
        kt=kt,
        gamma_n=gamma_n,
        gamma_t=gamma_t,
        mu=law.mu,
        mu_wall=law.mu_wall,
        t_c=contact_duration(law.k_n, gamma_n, m_eff_ref),
        m_eff_ref=m_eff_ref,
        mu_roll=law.mu_roll,
        k_roll=kt if law.mu_roll > 0 else 0.0,
        gamma_roll=gamma_t * m_eff_ref if law.mu_roll > 0 else 0.0,
    )


def max_stable_timestep(coeffs: LammpsCoefficients, m_eff_min: float) -> float:
    """Largest time step (s) for which velocity Verlet stays stable on every contact mode.

    The stiffest modes are the normal oscillation ``sqrt(k_n/m_eff)`` and the tangential
    one of two discs, whose spins add inertia so the tangential spring and dashpot see a
    reduced mass m_eff/3 (I = m r^2/2): ``sqrt(3 k_t / m_eff)`` with damping rate
    ``3 gamma_t``. Verlet is stable for ``omega dt < 2``; damping at rate ``g`` lowers
    the bound to ``2/omega (sqrt(1+z^2) - z)`` with ``z = g/(2 omega)``.
    """
    bound = math.inf
    for k, gamma, m in ((coeffs.kn, coeffs.gamma_n, m_eff_min),
                        (3.0 * coeffs.kt, 3.0 * coeffs.gamma_t, m_eff_min)):
        if k <= 0:
            continue
        omega = math.sqrt(k / m)
        z = 0.5 * gamma / omega
        bound = min(bound, 2.0 / omega * (math.sqrt(1 + z * z) - z))
    return bound
