"""Two-disk collisions in LAMMPS and in the reference DEM, step by step (SI units).

Used by the collision and reference-DEM tests and by the time-step study
(``workflows/timestep_stability.py``). A start is ``[(x, y, vx, vy, omega), (...)]`` for
the two disks; the second may be a frozen wall disk.
"""

from __future__ import annotations

import math

import numpy as np

from granavg.sim.contact_law import ContactLaw, effective_mass, to_lammps
from granavg.sim.lammps_session import lammps_session
from granavg.sim.refdem import Disks, ReferenceDEM

#: the paper's small disk: diameter (m) and areal density rho_p h (kg/m^2)
D, RHO_AREA = 0.00742, 1060 * 0.006


def lammps_trajectory(c, dt, start, frozen2, steps, wall_diameter=D):
    """LAMMPS: masses (2,), radii (2,) and, after each step, x1 y1 x2 y2 vx1 vy1 vx2 vy2
    w1 w2, shape (steps, 10) (a frozen second disk has diameter ``wall_diameter``)."""
    (x1, y1, vx1, vy1, w1), (x2, y2, vx2, vy2, w2) = start
    L = max(0.05, 1.5 * (D + wall_diameter))
    out = []
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string(f"""
            units si
            dimension 2
            boundary f f p
            atom_style sphere 1
            atom_modify map array sort 0 0
            comm_modify vel yes
            region box block -{L} {L} -{L} {L} -0.005 0.005
            create_box 4 box
            create_atoms 1 single {x1!r} {y1!r} 0
            create_atoms {4 if frozen2 else 1} single {x2!r} {y2!r} 0
            set type * diameter {D}
            set type 4 diameter {wall_diameter!r}
            set type * density/disc {RHO_AREA}
            set atom 1 vx {vx1!r} vy {vy1!r} omega 0 0 {w1!r}
            set atom 2 vx {vx2!r} vy {vy2!r} omega 0 0 {w2!r}
            group mobile type 1
            group walls type 4
            pair_style gran/hooke/history {c.kn!r} {c.kt!r} {c.gamma_n!r} {c.gamma_t!r} {c.mu!r} 1
            pair_coeff * *
            neighbor 0.002 bin
            fix integrate {"mobile" if frozen2 else "all"} nve/sphere disc
            fix frozen walls freeze
            fix flat all enforce2d
            timestep {dt!r}
            run 0""")
        mass = np.array(lmp.numpy.extract_atom("rmass")[:2])
        radius = np.array(lmp.numpy.extract_atom("radius")[:2])
        for _ in range(steps):
            lmp.command("run 1 pre no post no")
            out.append(np.concatenate([np.array(lmp.numpy.extract_atom(k)[:2, :2]).ravel()
                                       for k in ("x", "v")]
                                      + [np.array(lmp.numpy.extract_atom("omega")[:2, 2])]))
    return mass, radius, np.array(out)


def reference_trajectory(c, dt, start, frozen2, mass, radius, steps):
    """The same as :func:`lammps_trajectory` from the reference DEM, given the masses and
    radii (e.g. those LAMMPS used)."""
    s = np.array(start, float)
    disks = Disks(x=s[:, :2].copy(), v=s[:, 2:4].copy(), omega=s[:, 4].copy(),
                  radius=np.array(radius, float), mass=np.array(mass, float),
                  frozen=np.array([False, frozen2]))
    dem = ReferenceDEM(disks, c, dt)
    out = []
    for _ in range(steps):
        dem.step()
        out.append(np.concatenate([disks.x.ravel(), disks.v.ravel(), disks.omega]))
    return np.array(out)


def elastic_head_on(n: float, engine: str, phase: float = 0.25, v0: float = 0.01) -> dict:
    """An elastic (e_n = 1), frictionless head-on collision of two small disks at
    relative speed ``v0`` (m/s) with dt = t_c / n, in ``engine`` ("lammps" or
    "reference"); the contact starts ``phase`` of a step into the run. Returns the
    kinetic energy after over before (1 for the model), the largest overlap over the
    analytic v0/omega_n, and whether the disks separated."""
    m = RHO_AREA * math.pi * (D / 2) ** 2
    c = to_lammps(ContactLaw(k_n=10.0, e_n=1.0, mu=0.0, mu_wall=0.0), effective_mass(m, m))
    dt = c.t_c / n
    gap = phase * v0 * dt            # the contact starts this far into the first step
    start = [(-0.5 * D - gap, 0, v0 / 2, 0, 0), (0.5 * D + gap, 0, -v0 / 2, 0, 0)]
    steps = int(3 * n) + 10
    if engine == "lammps":
        mass, radius, traj = lammps_trajectory(c, dt, start, False, steps)
    else:
        mass, radius = np.full(2, m), np.full(2, D / 2)
        traj = reference_trajectory(c, dt, start, False, mass, radius, steps)
    ke = 0.5 * (mass[0] * traj[:, 4] ** 2 + mass[1] * traj[:, 6] ** 2)
    ke0 = 0.5 * (mass[0] + mass[1]) * (v0 / 2) ** 2
    overlap = (radius[0] + radius[1]) - (traj[:, 2] - traj[:, 0])
    omega_n = math.sqrt(c.kn / effective_mass(*mass))
    separated = overlap[-1] < 0
    return {"n": n, "engine": engine, "phase": phase, "dt_s": dt,
            "energy_ratio": ke[-1] / ke0 if separated else math.nan,
            "max_overlap_over_analytic": overlap.max() / (v0 / omega_n),
            "separated": bool(separated and traj[-1, 4] < 0)}
