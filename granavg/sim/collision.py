"""Two-disk collisions in LAMMPS and in the reference DEM, step by step (SI units).

Used by the collision and reference-DEM tests and by the time-step study
(``workflows/timestep_stability.py``). A start is ``[(x, y, vx, vy, omega), (...)]`` for
the two disks; the second may be a frozen wall disk. The contact law is the deck's:
``pair gran/hooke/history``, or ``pair granular`` with rolling resistance when
``mu_roll > 0`` (:func:`pair_commands`).
"""

from __future__ import annotations

import math
import re

import numpy as np

from granavg.sim.contact_law import ContactLaw, effective_mass, to_lammps
from granavg.sim.lammps_session import lammps_session, load_lammps
from granavg.sim.refdem import Disks, ReferenceDEM
from granavg.sim.run_layout import DECK

#: the paper's small disk: diameter (m) and areal density rho_p h (kg/m^2)
D, RHO_AREA = 0.00742, 1060 * 0.006


def pair_commands(c) -> list[str]:
    """The deck's contact-law commands for coefficients ``c`` (types 1-2 disks, 3-4 wall
    disks, mu_wall for disk-wall pairs): ``pair gran/hooke/history`` (a hybrid of two
    when mu_wall != mu), or with ``c.mu_roll > 0`` ``pair granular`` hooke +
    linear_history + rolling sds."""
    if c.mu_roll == 0:
        def hooke(mu):
            return f"gran/hooke/history {c.kn!r} {c.kt!r} {c.gamma_n!r} {c.gamma_t!r} {mu!r} 1"
        if c.mu_wall == c.mu:
            return [f"pair_style {hooke(c.mu)}", "pair_coeff * *"]
        return [f"pair_style hybrid {hooke(c.mu)} {hooke(c.mu_wall)}",
                "pair_coeff * * gran/hooke/history 1", "pair_coeff 1*2 3*4 gran/hooke/history 2"]
    x_gamma_t = c.gamma_t / c.gamma_n if c.gamma_n else 0.0

    def law(mu):
        return (f"hooke {c.kn!r} {c.gamma_n!r} tangential linear_history {c.kt!r} "
                f"{x_gamma_t!r} {mu!r} damping mass_velocity rolling sds {c.k_roll!r} "
                f"{c.gamma_roll!r} {c.mu_roll!r}")
    return ["pair_style granular", f"pair_coeff * * {law(c.mu)}",
            f"pair_coeff 1*2 3*4 {law(c.mu_wall)}"]


def pair_order_commands(c) -> list[str]:
    """The commands with which the deck keeps every pair's order in the neighbour list
    under rolling resistance (read from its ``if "${mu_roll} > 0" then "newton ...`` line; LAMMPS
    reverses the rolling spring of a swapped pair), or none without it."""
    if c.mu_roll == 0:
        return []
    line = next(ln for ln in DECK.read_text().splitlines()
                if ln.startswith('if "${mu_roll} > 0" then "newton'))
    return re.findall(r'"([^"]+)"', line)[1:]


def base_friction_commands(mu_base: float, v_base: float, every: int = 0) -> list[str]:
    """The deck's base-plate friction commands (read from its ``if "${mu_base} > 0 &&
    ${base_every} ..."`` line for ``every`` 0 or > 0), preceded by the variables they
    use; none for ``mu_base == 0``."""
    if mu_base == 0:
        return []
    mode = "== 0" if every == 0 else "> 0"
    line = next(ln for ln in DECK.read_text().splitlines()
                if ln.startswith(f'if "${{mu_base}} > 0 && ${{base_every}} {mode}" then'))
    return [f"variable mu_base index {mu_base!r}", f"variable v_base index {v_base!r}",
            f"variable base_every index {int(every)}",
            *re.findall(r'"([^"]+)"', line)[1:]]


def lammps_trajectory(c, dt, start, frozen2, steps, wall_diameter=D, contacts=False,
                      base=(0.0, 0.001)):
    """LAMMPS: masses (2,), radii (2,) and, after each step, x1 y1 x2 y2 vx1 vy1 vx2 vy2
    w1 w2, shape (steps, 10) (a frozen second disk has diameter ``wall_diameter``).
    ``base`` = (mu_base, v_base) adds the deck's friction with the base plate.

    With ``contacts``, also the contact's normal and tangential force on disk 1 after
    each step as ``compute pair/local fx fy p1 p2`` reports it (N; zeros while the disks
    do not touch), shape (steps, 4), as a fourth item. Evaluating it every step is part
    of the run: pair granular's ``single()`` rewrites a sliding contact's spring."""
    (x1, y1, vx1, vy1, w1), (x2, y2, vx2, vy2, w2) = start
    L = max(0.05, 1.5 * (D + wall_diameter))
    out, rows = [], []
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
            {chr(10).join(pair_commands(c))}
            neighbor 0.002 bin
            fix integrate {"mobile" if frozen2 else "all"} nve/sphere disc
            fix frozen walls freeze
            {chr(10).join(base_friction_commands(*base))}
            fix flat all enforce2d
            timestep {dt!r}
            compute pair all pair/local fx fy p1 p2 cutoff radius
            run 0""")
        mass = np.array(lmp.numpy.extract_atom("rmass")[:2])
        radius = np.array(lmp.numpy.extract_atom("radius")[:2])
        for _ in range(steps):
            lmp.command("run 1 pre no post no")
            out.append(np.concatenate([np.array(lmp.numpy.extract_atom(k)[:2, :2]).ravel()
                                       for k in ("x", "v")]
                                      + [np.array(lmp.numpy.extract_atom("omega")[:2, 2])]))
            if contacts:
                rows.append(_pair_local_row(lmp))
    return (mass, radius, np.array(out)) + ((np.array(rows),) if contacts else ())


def _pair_local_row(lmp):
    """The one contact's ``compute pair/local fx fy p1 p2`` row, zeros if none."""
    lammps = load_lammps()
    row = lmp.numpy.extract_compute("pair", lammps.LMP_STYLE_LOCAL, lammps.LMP_TYPE_ARRAY)
    row = np.zeros((0, 4)) if row is None else np.array(row, float).reshape(-1, 4)
    return row[0] if len(row) else np.zeros(4)


def reference_trajectory(c, dt, start, frozen2, mass, radius, steps, contacts=False):
    """The same as :func:`lammps_trajectory` from the reference DEM, given the masses and
    radii (e.g. those LAMMPS used); with ``contacts`` a tuple (trajectory, contact rows)."""
    s = np.array(start, float)
    disks = Disks(x=s[:, :2].copy(), v=s[:, 2:4].copy(), omega=s[:, 4].copy(),
                  radius=np.array(radius, float), mass=np.array(mass, float),
                  frozen=np.array([False, frozen2]))
    dem = ReferenceDEM(disks, c, dt)
    out, rows = [], []
    for _ in range(steps):
        dem.step()
        out.append(np.concatenate([disks.x.ravel(), disks.v.ravel(), disks.omega]))
        if contacts:
            found = dem.contact_rows()[2]
            rows.append(found[0, 3:7] if len(found) else np.zeros(4))
    return (np.array(out), np.array(rows)) if contacts else np.array(out)


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
