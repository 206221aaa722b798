"""The reference DEM against LAMMPS, step by step, on two-body collisions.

Both engines get the same coefficients (granavg.sim.contact_law.to_lammps), the same masses
and radii (read back from LAMMPS) and the same start; positions, velocities, spins and
contact forces must agree to round-off over the whole contact. Each case is also held to
the analytic linear spring-dashpot first, so a disagreement says which engine is wrong.
"""

import math

import numpy as np
import pytest

from granavg.sim.contact_law import ContactLaw, effective_mass, restitution, to_lammps
from granavg.sim.lammps_session import lammps_session
from granavg.sim.refdem import Disks, ReferenceDEM

from granavg.sim.collision import D, RHO_AREA, lammps_trajectory, reference_trajectory


CASES = {  # name: (law, start of disk 1 and 2: x, y, vx, vy, omega; frozen partner)
    "head-on": (ContactLaw(k_n=10.0, e_n=0.9),
                [(-0.5 * D - 1e-4, 0, 0.005, 0, 0), (0.5 * D + 1e-4, 0, -0.005, 0, 0)], False),
    "oblique-sticking": (ContactLaw(k_n=10.0, e_n=0.8, mu=0.8),
                         [(-0.5 * D - 1e-4, -0.002, 0.01, 0.003, 0), (0.5 * D, 0.002, -0.01, 0, 0)],
                         False),
    "oblique-sliding": (ContactLaw(k_n=10.0, e_n=0.8, mu=0.05),
                        [(-0.5 * D - 1e-4, -0.002, 0.01, 0.004, 2.0), (0.5 * D, 0.002, -0.01, 0, -1.0)],
                        False),
    "wall": (ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_wall=0.5),
             [(-D - 1e-4, 0.001, 0.01, 0.002, 1.0), (0.0, 0.0, 0.0, 0.0, 0.0)], True),
}


@pytest.mark.parametrize("name", list(CASES))
def test_reference_dem_follows_lammps_step_by_step(name):
    law, start, frozen2 = CASES[name]
    mass_guess = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(mass_guess, mass_guess))
    dt, steps = c.t_c / 50, 150
    mass, radius, lmp = lammps_trajectory(c, dt, start, frozen2, steps)
    ref = reference_trajectory(c, dt, start, frozen2, mass, radius, steps)
    scale = np.abs(lmp).max(axis=0) + 1e-300
    err = np.abs(ref - lmp) / scale
    assert err.max() < 1e-10, (name, err.max(), np.unravel_index(err.argmax(), err.shape))
    # and both against the analytic normal restitution (head-on) / no energy gain
    if name == "head-on":
        e = (lmp[-1, 6] - lmp[-1, 4]) / (start[0][2] - start[1][2])
        assert e == pytest.approx(restitution(c.kn, c.gamma_n, effective_mass(*mass)), rel=2e-3)


def loose_packing(n=110, seed=4):
    """110 disks at random (no overlap; area fraction 0.48) inside a ring of frozen wall
    disks, with random velocities and spins."""
    rng = np.random.default_rng(seed)
    R, wall_d = 0.06, D
    k = int(np.ceil(2 * np.pi * (R + wall_d / 2) / (0.9 * wall_d)))
    ang = 2 * np.pi * np.arange(k) / k
    walls = np.column_stack([(R + wall_d / 2) * np.cos(ang), (R + wall_d / 2) * np.sin(ang)])
    disks = []
    while len(disks) < n:
        p = rng.uniform(-R + D / 2, R - D / 2, 2)
        if np.hypot(*p) < R - D / 2 and all(np.hypot(*(p - q)) > D for q in disks):
            disks.append(p)
    x = np.vstack([np.array(disks), walls])
    v = np.vstack([rng.normal(0, 0.05, (n, 2)), np.zeros((k, 2))])
    w = np.concatenate([rng.normal(0, 5.0, n), np.zeros(k)])
    return x, v, w, np.arange(len(x)) >= n


def lammps_packing_run(c, dt, x, v, w, frozen, steps):
    cmds = ["units si", "dimension 2", "boundary f f p", "atom_style sphere 1",
            "atom_modify map array sort 0 0", "comm_modify vel yes",
            "region box block -0.1 0.1 -0.1 0.1 -0.005 0.005", "create_box 4 box"]
    cmds += [f"create_atoms {4 if f else 1} single {p[0]:.17g} {p[1]:.17g} 0"
             for p, f in zip(x, frozen)]
    cmds += ["set type * diameter %r" % D, "set type * density/disc %r" % RHO_AREA]
    cmds += [f"set atom {k + 1} vx {vk[0]:.17g} vy {vk[1]:.17g} omega 0 0 {wk:.17g}"
             for k, (vk, wk) in enumerate(zip(v, w))]
    cmds += ["group mobile type 1", "group walls type 4",
             f"pair_style gran/hooke/history {c.kn!r} {c.kt!r} {c.gamma_n!r} {c.gamma_t!r} {c.mu!r} 1",
             "pair_coeff * *", "neighbor 0.002 bin",
             "neigh_modify delay 0 every 1 check yes exclude type 4 4",
             "fix integrate mobile nve/sphere disc", "fix frozen walls freeze",
             "fix flat all enforce2d", f"timestep {dt!r}", "run 0"]
    out = []
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string("\n".join(cmds))
        mass = np.array(lmp.numpy.extract_atom("rmass")[:len(x)])
        radius = np.array(lmp.numpy.extract_atom("radius")[:len(x)])
        for _ in range(steps):
            lmp.command("run 1 pre no post no")
            out.append(np.array(lmp.numpy.extract_atom("x")[:len(x), :2]))
    return mass, radius, np.array(out)


def test_same_packing_same_trajectories_up_to_the_chaos_horizon():
    """Both engines from one start: positions agree to round-off at first; round-off
    differences (the order in which a disk's contact forces are summed) then grow
    chaotically. The horizon is where they reach 1e-6 of a diameter."""
    x, v, w, frozen = loose_packing()
    law = ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_wall=0.5)   # LAMMPS side: one mu
    m0 = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(m0, m0))
    dt, steps = c.t_c / 50, 6000
    mass, radius, lmp = lammps_packing_run(c, dt, x, v, w, frozen, steps)
    disks = Disks(x=x.copy(), v=v.copy(), omega=w.copy(), radius=radius, mass=mass, frozen=frozen)
    dem = ReferenceDEM(disks, c, dt)
    dev, contacts = [], 0
    for k in range(steps):
        dem.step()
        contacts = max(contacts, len(dem.contacts[0]))
        dev.append(np.abs(disks.x - lmp[k]).max() / D)
    dev = np.array(dev)
    horizon = int(np.argmax(dev > 1e-6)) if np.any(dev > 1e-6) else steps
    print(f"horizon {'not reached in ' if horizon == steps else ''}{horizon} steps "
          f"({horizon / 50:.0f} contact times); "
          f"deviation at 100 steps {dev[99]:.1e} d; up to {contacts} contacts at once")
    assert contacts > 20                               # a real many-body packing
    assert dev[99] < 1e-12 and horizon >= 500


def tangential_slip(traj, radius):
    """Tangential velocity of the contact point of disk 1 relative to disk 2 (m/s),
    g = (v1 - v2) . t - (r1 w1 + r2 w2), t = z x n, n from disk 2 to disk 1."""
    x, v, w = traj[:, :4].reshape(-1, 2, 2), traj[:, 4:8].reshape(-1, 2, 2), traj[:, 8:]
    n = (x[:, 0] - x[:, 1]) / np.linalg.norm(x[:, 0] - x[:, 1], axis=1)[:, None]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    return np.sum((v[:, 0] - v[:, 1]) * t, axis=1) - (radius[0] * w[:, 0] + radius[1] * w[:, 1])


def analytic_slip_after(c, m, g0, v_n):
    """Slip velocity after a disk-wall collision of the linear model (wall frozen,
    m_eff = m, I = m r^2/2, so the contact point responds to F_t with 3/m).

    Normal overlap delta(t) = v_n/w_n exp(-gamma_n t/2) sin(w_n t), contact ends at
    t_c = pi / w_n. Sticking (mu -> inf): the tangential spring and dashpot make a damped
    oscillator xi'' + 3 gamma_t xi' + 3 k_t/m xi = 0 with xi'(0) = g0. Gross sliding
    (mu small): F_t = -mu |F_n| sign(g) throughout, so g changes by 3 mu/m int |F_n| dt.
    """
    w_n = math.sqrt(c.kn / m - 0.25 * c.gamma_n ** 2)
    t_c = math.pi / w_n
    z = 1.5 * c.gamma_t
    w_t = math.sqrt(3 * c.kt / m - z * z)
    stick = g0 * math.exp(-z * t_c) * (math.cos(w_t * t_c) - z / w_t * math.sin(w_t * t_c))
    t = np.linspace(0.0, t_c, 200001)
    e = np.exp(-0.5 * c.gamma_n * t)
    delta = v_n / w_n * e * np.sin(w_n * t)
    ddelta = v_n * e * (np.cos(w_n * t) - 0.5 * c.gamma_n / w_n * np.sin(w_n * t))
    impulse = np.trapezoid(np.abs(c.kn * delta + m * c.gamma_n * ddelta), t)
    slide = g0 - np.sign(g0) * 3.0 * c.mu / m * impulse
    return stick, slide


@pytest.mark.parametrize("regime,mu,spin", [("sticking", 20.0, 1.0), ("sliding", 0.1, 40.0)])
def test_oblique_wall_collision_regimes_match_the_linear_model(regime, mu, spin):
    """A spinning disk hits a frozen wall disk head-on (no tangential velocity of its
    centre, so the contact point slips at g0 = -r w0): both engines must give the
    analytic slip after the contact, small spin -> sticking (tangential oscillator),
    large spin -> gross sliding (Coulomb impulse). Each engine is held to the analytic
    result on its own, so a disagreement names the engine that is wrong.

    The analytic model is one-dimensional (a flat wall). The wall disk has radius 10 d:
    against an equal disk the curvature turns the normal while the disk moves and shifts
    the sticking result by 0.7% of g0 (measured; 0.06% at 10 d, 0.03% at 50 d)."""
    law = ContactLaw(k_n=10.0, e_n=0.9, mu=mu, mu_wall=mu)
    m0 = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(m0, m0))
    v_n = 0.01
    wall_d = 20 * D
    start = [(-0.5 * (D + wall_d) - 1e-5, 0.0, v_n, 0.0, spin), (0.0, 0.0, 0.0, 0.0, 0.0)]
    dt = c.t_c / 400
    steps = int(1.6 * 400)
    mass, radius, lmp = lammps_trajectory(c, dt, start, True, steps, wall_diameter=wall_d)
    ref = reference_trajectory(c, dt, start, True, mass, radius, steps)
    g0 = -radius[0] * spin
    stick, slide = analytic_slip_after(c, mass[0], g0, v_n)
    want = stick if regime == "sticking" else slide
    for name, traj in (("LAMMPS", lmp), ("reference", ref)):
        g = tangential_slip(traj, radius)
        assert traj[-1, 4] < 0, f"{name}: the disk did not rebound"
        assert g[-1] == pytest.approx(want, abs=5e-3 * abs(g0)), (name, regime, g[-1] / g0)
    print(f"{regime}: g/g0 after = {g[-1] / g0:.4f}, analytic {want / g0:.4f}")
