"""Body forces on the disks, as the atoms' ``bx by`` columns the engine averages into a
body force density (N/m^3 in SI): gravity, and the base-plate friction of granavg's
Couette scene (the deck's own law, so that it equals what LAMMPS applied).

Each term is a function ``term(atoms, h, rho_p) -> (fx, fy)``, shapes (P,); masses are
the atoms' ``mass`` column where there is one, else rho_p pi h a^2.
"""

from __future__ import annotations

import numpy as np

from granavg.errors import ParameterError

#: The deck's gravitational acceleration for the base plate's normal load, m/s^2.
G_BASE = 9.81


def masses(atoms, h: float, rho_p: float | None) -> np.ndarray:
    """Each disk's mass: the ``mass`` column, else rho_p pi h a^2 (shape (P,))."""
    if "mass" in atoms:
        return atoms["mass"]
    if rho_p is None:
        raise ParameterError("rho_p", "body forces need masses: give the material density "
                             "({param}) or a mass column")
    return rho_p * np.pi * h * atoms["radius"] ** 2


def gravity(gx: float, gy: float):
    """The term m g (g in the frames' units of acceleration)."""
    def term(atoms, h, rho_p):
        m = masses(atoms, h, rho_p)
        return m * gx, m * gy
    term.describe = {"gravity": [gx, gy]}
    return term


def base_plate(mu: float, v_base: float, g: float = G_BASE):
    """The deck's friction with the base plate: F = -mu m g v / sqrt(v^2 + v_base^2)
    (Coulomb's mu m g against the motion, linear below v_base; SI units)."""
    def term(atoms, h, rho_p):
        m = masses(atoms, h, rho_p)
        vx, vy = atoms["vx"], atoms["vy"]
        scale = -mu * g * m / np.sqrt(vx * vx + vy * vy + v_base * v_base)
        return scale * vx, scale * vy
    term.describe = {"base_plate": {"mu_base": mu, "v_base_m_per_s": v_base, "g_m_per_s2": g}}
    return term


def add_body_forces(atoms: dict, terms, h: float, rho_p: float | None) -> dict:
    """``atoms`` with ``bx by`` the sum of the terms (added to any ``bx by`` the atoms
    already carry, e.g. a force column of the dump)."""
    bx = np.array(atoms["bx"], float) if "bx" in atoms else np.zeros(len(atoms["x"]))
    by = np.array(atoms["by"], float) if "by" in atoms else np.zeros(len(atoms["x"]))
    for term in terms:
        fx, fy = term(atoms, h, rho_p)
        bx, by = bx + fx, by + fy
    return {**atoms, "bx": bx, "by": by}
