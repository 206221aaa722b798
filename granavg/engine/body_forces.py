"""Body forces on the particles, as the atoms' ``bx by [bz]`` columns the engine
averages into a body force density (N/m^3 in SI): gravity (2D or 3D), and the
base-plate friction of granavg's Couette scene (the deck's own law, so that it equals
what LAMMPS applied).

Each term is a function ``term(atoms, volume, rho_p) -> (fx, fy[, fz])``, shapes (P,),
with ``volume(radius)`` the particles' volumes (the cells' ``particle_volume``: pi h a^2
for disks, 4/3 pi a^3 for spheres); masses are the atoms' ``mass`` column where there is
one, else rho_p times the volume.
"""

from __future__ import annotations

import numpy as np

from granavg.errors import ParameterError

#: The deck's gravitational acceleration for the base plate's normal load, m/s^2.
G_BASE = 9.81


def masses(atoms, volume, rho_p: float | None) -> np.ndarray:
    """Each particle's mass: the ``mass`` column, else rho_p volume(radius), shape (P,)."""
    if "mass" in atoms:
        return atoms["mass"]
    if rho_p is None:
        raise ParameterError("density", "body forces need masses: give the material density "
                             "({param}) or a mass column")
    return rho_p * volume(atoms["radius"])


def gravity(*g: float):
    """The term m g (g: 2 or 3 components, in the frames' units of acceleration)."""
    def term(atoms, volume, rho_p):
        m = masses(atoms, volume, rho_p)
        return tuple(m * gi for gi in g)
    term.describe = {"gravity": list(g)}
    return term


def base_plate(mu: float, v_base: float, g: float = G_BASE):
    """The deck's friction with the base plate: F = -mu m g v / sqrt(v^2 + v_base^2)
    (Coulomb's mu m g against the motion, linear below v_base; SI units)."""
    def term(atoms, volume, rho_p):
        m = masses(atoms, volume, rho_p)
        vx, vy = atoms["vx"], atoms["vy"]
        scale = -mu * g * m / np.sqrt(vx * vx + vy * vy + v_base * v_base)
        return scale * vx, scale * vy
    term.describe = {"base_plate": {"mu_base": mu, "v_base_m_per_s": v_base, "g_m_per_s2": g}}
    return term


def add_body_forces(atoms: dict, terms, volume, rho_p: float | None) -> dict:
    """``atoms`` with ``bx by [bz]`` the sum of the terms (added to any such columns the
    atoms already carry, e.g. a force column of the dump)."""
    out = dict(atoms)
    for term in terms:
        for name, f in zip(("bx", "by", "bz"), term(atoms, volume, rho_p)):
            out[name] = (np.array(out[name], float) if name in out else
                         np.zeros(len(atoms["x"]))) + f
    return out
