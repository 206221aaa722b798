"""The reference DEM against LAMMPS, step by step, on two-body collisions and a packing.

Both engines get the same coefficients (granavg.sim.contact_law.to_lammps), the same masses
and radii (read back from LAMMPS) and the same start; positions, velocities, spins and
contact forces must agree to round-off over the whole contact, for both contact laws
(gran/hooke/history, and pair granular with rolling resistance when mu_roll > 0). Each
case is also held to the analytic linear spring-dashpot first, so a disagreement says
which engine is wrong.
"""

import json
import math

import numpy as np
import pytest

from granavg.sim.contact_law import ContactLaw, effective_mass, restitution, to_lammps
from granavg.sim.lammps_session import lammps_session, load_lammps
from granavg.sim.refdem import Disks, ReferenceDEM

from granavg.sim.collision import (D, RHO_AREA, base_friction_commands, lammps_trajectory,
                                   pair_commands, pair_order_commands,
                                   reference_trajectory)

from .conftest import run_cli


CASES = {  # name: (law, start of disk 1 and 2: x, y, vx, vy, omega; frozen partner)
    "head-on": (ContactLaw(k_n=10.0, e_n=0.9),
                [(-0.5 * D - 1e-4, 0, 0.005, 0, 0), (0.5 * D + 1e-4, 0, -0.005, 0, 0)], False),
    "oblique-sticking": (ContactLaw(k_n=10.0, e_n=0.8, mu=0.8),
                         [(-0.0036, -0.001, 0.01, 0.003, 0), (0.0036, 0.001, -0.01, 0, 0)],
                         False),
    "oblique-sliding": (ContactLaw(k_n=10.0, e_n=0.8, mu=0.05),
                        [(-0.0036, -0.001, 0.01, 0.004, 20.0), (0.0036, 0.001, -0.01, 0, -10.0)],
                        False),
    "wall": (ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_wall=0.5),
             [(-D - 1e-4, 0.001, 0.01, 0.002, 1.0), (0.0, 0.0, 0.0, 0.0, 0.0)], True),
    # pair granular: the rolling spring loads for the first 3/4 of the contact and
    # slides as F_n vanishes; rolling and tangential springs slide throughout; a wall
    # disk with mu_wall != mu (the deck's second pair_coeff) and a loading rolling spring
    "rolling-spring": (ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_roll=0.1),
                       [(-0.5 * D - 1e-4, 0, 0.005, 0, 0.5), (0.5 * D + 1e-4, 0, -0.005, 0, 0)],
                       False),
    "rolling-sliding": (ContactLaw(k_n=10.0, e_n=0.8, mu=0.05, mu_roll=0.01),
                        [(-0.0036, -0.001, 0.01, 0.004, 30.0), (0.0036, 0.001, -0.01, 0, -20.0)],
                        False),
    "rolling-wall": (ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_wall=0.3, mu_roll=0.1),
                     [(-D - 1e-4, 0.001, 0.01, 0.002, 1.0), (0.0, 0.0, 0.0, 0.0, 0.0)], True),
}


@pytest.mark.parametrize("name", list(CASES))
def test_reference_dem_follows_lammps_step_by_step(name):
    law, start, frozen2 = CASES[name]
    mass_guess = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(mass_guess, mass_guess))
    dt, steps = c.t_c / 50, 150
    mass, radius, lmp, lmp_rows = lammps_trajectory(c, dt, start, frozen2, steps, contacts=True)
    ref, ref_rows = reference_trajectory(c, dt, start, frozen2, mass, radius, steps,
                                         contacts=True)
    assert np.sum(np.any(lmp_rows != 0, axis=1)) >= 40, "the disks must touch for a contact"
    for what, a, b in (("state", ref, lmp), ("contact forces", ref_rows, lmp_rows)):
        err = np.abs(a - b) / (np.abs(b).max(axis=0) + 1e-300)
        assert err.max() < 1e-10, (name, what, err.max(), np.unravel_index(err.argmax(), err.shape))
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


def packing_commands(x, v, w, frozen):
    """LAMMPS commands that create a packing: disks type 1, frozen ones type 4 (walls)."""
    cmds = ["units si", "dimension 2", "boundary f f p", "atom_style sphere 1",
            "atom_modify map array sort 0 0", "comm_modify vel yes",
            "region box block -0.1 0.1 -0.1 0.1 -0.005 0.005", "create_box 4 box"]
    cmds += [f"create_atoms {4 if f else 1} single {p[0]:.17g} {p[1]:.17g} 0"
             for p, f in zip(x, frozen)]
    cmds += ["set type * diameter %r" % D, "set type * density/disc %r" % RHO_AREA]
    cmds += [f"set atom {k + 1} vx {vk[0]:.17g} vy {vk[1]:.17g} omega 0 0 {wk:.17g}"
             for k, (vk, wk) in enumerate(zip(v, w))]
    return cmds


def lammps_packing_run(c, dt, x, v, w, frozen, steps, settings=(), forces=()):
    """LAMMPS on a packing: masses, radii, positions after each step, shape (steps, N, 2),
    and the order in which its neighbour list holds each touching pair, at the start and
    after each step: ``{i * N + j: reversed}`` (i < j; ``reversed`` when LAMMPS has the
    pair as (j, i)). ``compute pair/local`` is evaluated every step, as a contact dump
    would (pair granular's ``single()`` rewrites sliding tangential springs). ``forces``:
    commands of further forces on the group ``mobile`` (the deck's base friction)."""
    n = len(x)
    cmds = [*packing_commands(x, v, w, frozen), *settings]
    cmds += ["group mobile type 1", "group walls type 4", *pair_commands(c),
             "neighbor 0.002 bin", "neigh_modify delay 0 every 1 check yes exclude type 4 4",
             "fix integrate mobile nve/sphere disc", "fix frozen walls freeze", *forces,
             "fix flat all enforce2d", f"timestep {dt!r}",
             "compute pair all pair/local fx fy p1 p2 cutoff radius",
             "compute order all property/local patom1 patom2 cutoff radius", "run 0"]
    lammps = load_lammps()
    local, array = lammps.LMP_STYLE_LOCAL, lammps.LMP_TYPE_ARRAY

    def pair_order(lmp):
        ids = lmp.numpy.extract_compute("order", local, array)
        ij = np.zeros((0, 2), int) if ids is None else np.array(ids).reshape(-1, 2).astype(int) - 1
        return dict(zip(ij.min(axis=1) * n + ij.max(axis=1), ij[:, 0] > ij[:, 1]))

    out = []
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string("\n".join(cmds))
        mass = np.array(lmp.numpy.extract_atom("rmass")[:n])
        radius = np.array(lmp.numpy.extract_atom("radius")[:n])
        orders = [pair_order(lmp)]
        for _ in range(steps):
            lmp.command("run 1 pre no post no")
            lmp.numpy.extract_compute("pair", local, array)
            out.append(np.array(lmp.numpy.extract_atom("x")[:n, :2]))
            orders.append(pair_order(lmp))
    return mass, radius, np.array(out), orders


def reverse_rolling_springs_of_swapped_pairs(dem, before, after):
    """Do to the reference's springs what LAMMPS does to a touching pair whose order a
    neighbour-list rebuild swaps: fix neigh/history hands the pair's history to its new
    first atom negated. Right for the tangential spring (the reference keeps i < j, so it
    needs nothing), wrong for pair granular's rolling spring, whose rolling velocity
    R_eff (omega_i - omega_j) z x n keeps its sign when i and j swap: LAMMPS reverses the
    spring (a LAMMPS defect). Returns how many pairs were swapped."""
    swapped = [key for key, rev in after.items() if key in before and before[key] != rev]
    if swapped and dem.granular:
        keys, springs = dem.history
        springs[np.isin(keys, swapped), 2:] *= -1
    return len(swapped)


@pytest.mark.slow
@pytest.mark.parametrize("mu_roll,deck,base", [(0.0, True, None), (0.1, True, None),
                                               (0.1, False, None), (0.1, True, (0.03, 0.002)),
                                               (0.1, True, (0.03, 0.002, 7))],
                         ids=["gran-hooke-history", "granular-rolling-deck",
                              "granular-rolling-lammps-defaults", "base-friction",
                              "base-friction-every-7-steps"])
def test_same_packing_same_trajectories_up_to_the_chaos_horizon(mu_roll, deck, base):
    """Both engines from one start: positions agree to round-off at first; round-off
    differences (the order in which a disk's contact forces are summed) then grow
    chaotically. The horizon is where they reach 1e-6 of a diameter. Both evaluate the
    contact rows every step (with pair granular that changes the run), and the
    reference is told where LAMMPS' neighbour list swapped a pair (with pair granular
    LAMMPS then reverses its rolling spring). With the deck's settings no pair is ever
    swapped (the rolling springs stay right); with LAMMPS' defaults (newton on) pairs
    are swapped and the agreement needs the reversal. With the deck's base friction
    (mu_base 0.03, v_base 2 mm/s; the law each step, or its coefficient renewed every 7
    steps) the reference adds the same force; without it, it departs from LAMMPS at
    once."""
    x, v, w, frozen = loose_packing()
    law = ContactLaw(k_n=10.0, e_n=0.9, mu=0.5, mu_wall=0.3, mu_roll=mu_roll)
    m0 = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(m0, m0))
    dt, steps = c.t_c / 50, 6000
    settings = pair_order_commands(c) if deck else ()
    forces = base_friction_commands(*base) if base else ()
    mass, radius, lmp, orders = lammps_packing_run(c, dt, x, v, w, frozen, steps, settings,
                                                   forces)
    if base:                                           # the friction changes the run
        plain = Disks(x=x.copy(), v=v.copy(), omega=w.copy(), radius=radius, mass=mass,
                      frozen=frozen)
        without = ReferenceDEM(plain, c, dt)
        for _ in range(100):
            without.step()
        assert np.abs(plain.x - lmp[99]).max() / D > 1e-6
    disks = Disks(x=x.copy(), v=v.copy(), omega=w.copy(), radius=radius, mass=mass, frozen=frozen)
    dem = ReferenceDEM(disks, c, dt, base=base)
    dev, contacts, swaps = [], 0, 0
    for k in range(steps):
        swaps += reverse_rolling_springs_of_swapped_pairs(dem, orders[k], orders[k + 1])
        dem.step()
        dem.contact_rows()
        contacts = max(contacts, len(dem.contacts[0]))
        dev.append(np.abs(disks.x - lmp[k]).max() / D)
    dev = np.array(dev)
    horizon = int(np.argmax(dev > 1e-6)) if np.any(dev > 1e-6) else steps
    print(f"horizon {'not reached in ' if horizon == steps else ''}{horizon} steps "
          f"({horizon / 50:.0f} contact times); "
          f"deviation at 100 steps {dev[99]:.1e} d; up to {contacts} contacts at once; "
          f"{swaps} touching pairs swapped by LAMMPS' neighbour list")
    assert contacts > 20                               # a real many-body packing
    if mu_roll > 0:
        assert (swaps == 0) if deck else (swaps > 0)   # the deck keeps every pair's order
    assert dev[99] < 1e-12 and horizon >= 500


def tangential_slip(traj, radius):
    """Tangential velocity of the contact point of disk 1 relative to disk 2 (m/s),
    g = (v1 - v2) . t - (r1 w1 + r2 w2), t = z x n, n from disk 2 to disk 1."""
    x, v, w = traj[:, :4].reshape(-1, 2, 2), traj[:, 4:8].reshape(-1, 2, 2), traj[:, 8:]
    n = (x[:, 0] - x[:, 1]) / np.linalg.norm(x[:, 0] - x[:, 1], axis=1)[:, None]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    return np.sum((v[:, 0] - v[:, 1]) * t, axis=1) - (radius[0] * w[:, 0] + radius[1] * w[:, 1])


def normal_contact(c, m, v_n):
    """Duration t_c (s) and Coulomb impulse int |F_n| dt (N s) of a disk of mass m
    (kg) hitting a frozen partner (m_eff = m) at v_n (m/s), linear model.

    Normal overlap delta(t) = v_n/w_n exp(-gamma_n t/2) sin(w_n t), contact ends at
    t_c = pi / w_n; F_n = k_n delta + m gamma_n delta' pulls at the end (no
    limit_damping), which counts with its magnitude.
    """
    w_n = math.sqrt(c.kn / m - 0.25 * c.gamma_n ** 2)
    t_c = math.pi / w_n
    t = np.linspace(0.0, t_c, 200001)
    e = np.exp(-0.5 * c.gamma_n * t)
    delta = v_n / w_n * e * np.sin(w_n * t)
    ddelta = v_n * e * (np.cos(w_n * t) - 0.5 * c.gamma_n / w_n * np.sin(w_n * t))
    return t_c, np.trapezoid(np.abs(c.kn * delta + m * c.gamma_n * ddelta), t)


def damped_oscillator(x0, z, w0_sq, t):
    """Velocity at t of x'' + 2 z x' + w0_sq x = 0 started at x = 0 with velocity x0."""
    w = math.sqrt(w0_sq - z * z)
    return x0 * math.exp(-z * t) * (math.cos(w * t) - z / w * math.sin(w * t))


def analytic_slip_after(c, m, g0, v_n):
    """Slip velocity after a disk-wall collision of the linear model (wall frozen,
    m_eff = m, I = m r^2/2, so the contact point responds to F_t with 3/m).

    Sticking (mu -> inf): the tangential spring and dashpot make a damped oscillator
    xi'' + 3 gamma_t xi' + 3 k_t/m xi = 0 with xi'(0) = g0. Gross sliding (mu small):
    F_t = -mu |F_n| sign(g) throughout, so g changes by 3 mu/m int |F_n| dt.
    """
    t_c, impulse = normal_contact(c, m, v_n)
    stick = damped_oscillator(g0, 1.5 * c.gamma_t, 3 * c.kt / m, t_c)
    slide = g0 - np.sign(g0) * 3.0 * c.mu / m * impulse
    return stick, slide


def analytic_spin_after(c, m, r, r_eff, w0, v_n):
    """Spin (rad/s) after a frictionless (mu = 0) head-on collision with a frozen disk,
    rolling resistance only (pair granular's rolling sds; I = m r^2/2).

    The rolling velocity is R_eff w (w the disk's spin, R_eff = r R / (r + R)) and the
    rolling force F_r acts on the spin only, with torque R_eff |F_r|. Sticking (mu_roll
    -> inf): spring and dashpot on the rolled angle theta give
    I theta'' = -R_eff^2 (k_roll theta + gamma_roll theta'), theta'(0) = w0. Gross
    sliding (mu_roll small): |F_r| = mu_roll |F_n| throughout, so the spin changes by
    mu_roll R_eff int |F_n| dt / I.
    """
    t_c, impulse = normal_contact(c, m, v_n)
    inertia = 0.5 * m * r * r
    stick = damped_oscillator(w0, 0.5 * c.gamma_roll * r_eff ** 2 / inertia,
                              c.k_roll * r_eff ** 2 / inertia, t_c)
    slide = w0 - np.sign(w0) * c.mu_roll * r_eff * impulse / inertia
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
    c, v_n, mass, radius, lmp, ref = head_on_wall_impact(law, spin)
    g0 = -radius[0] * spin
    stick, slide = analytic_slip_after(c, mass[0], g0, v_n)
    want = stick if regime == "sticking" else slide
    for name, traj in (("LAMMPS", lmp), ("reference", ref)):
        g = tangential_slip(traj, radius)
        assert traj[-1, 4] < 0, f"{name}: the disk did not rebound"
        assert g[-1] == pytest.approx(want, abs=5e-3 * abs(g0)), (name, regime, g[-1] / g0)
    print(f"{regime}: g/g0 after = {g[-1] / g0:.4f}, analytic {want / g0:.4f}")


def head_on_wall_impact(law, spin, v_n=0.01):
    """A disk spinning at ``spin`` (rad/s) hits a frozen wall disk of radius 10 d head-on
    at v_n (m/s), dt = t_c/400, in both engines: coefficients, v_n, masses, radii and
    the two trajectories."""
    m0 = RHO_AREA * np.pi * (D / 2) ** 2
    c = to_lammps(law, effective_mass(m0, m0))
    wall_d = 20 * D
    start = [(-0.5 * (D + wall_d) - 1e-5, 0.0, v_n, 0.0, spin), (0.0, 0.0, 0.0, 0.0, 0.0)]
    dt, steps = c.t_c / 400, int(1.6 * 400)
    mass, radius, lmp = lammps_trajectory(c, dt, start, True, steps, wall_diameter=wall_d)
    ref = reference_trajectory(c, dt, start, True, mass, radius, steps)
    return c, v_n, mass, radius, lmp, ref


@pytest.mark.parametrize("regime,mu_roll,spin", [("sticking", 1000.0, 1.0), ("sliding", 0.1, 40.0)])
def test_rolling_resistance_regimes_match_the_linear_model(regime, mu_roll, spin):
    """A spinning disk hits a frozen wall disk (radius 10 d) head-on without friction
    (mu = 0): only the rolling resistance changes its spin. Both engines must give the
    analytic spin after the contact: small spin -> the rolling spring sticks (a damped
    rotational oscillator through k_roll R_eff^2 / I and gamma_roll R_eff^2 / I; the
    spin turns over), large spin -> it slides at mu_roll |F_n| (the rolling torque's
    bound, R_eff mu_roll |F_n|, integrated over the contact). Each engine is held to the
    analytic result on its own; with r instead of R_eff (5% larger) both cases fail.

    Sticking needs a huge mu_roll: without limit_damping F_n changes sign shortly before
    the disks part, so the Coulomb limit passes through zero and a moderate mu_roll (20)
    lets the spring slide there, which shifts the spin after by 4% of w0 (measured)."""
    law = ContactLaw(k_n=10.0, e_n=0.9, mu=0.0, mu_wall=0.0, mu_roll=mu_roll)
    c, v_n, mass, radius, lmp, ref = head_on_wall_impact(law, spin)
    r_eff = radius[0] * radius[1] / (radius[0] + radius[1])
    stick, slide = analytic_spin_after(c, mass[0], radius[0], r_eff, spin, v_n)
    want = stick if regime == "sticking" else slide
    for name, traj in (("LAMMPS", lmp), ("reference", ref)):
        assert traj[-1, 4] < 0, f"{name}: the disk did not rebound"
        assert traj[-1, 5] == 0.0, f"{name}: a tangential force acted"
        assert traj[-1, 8] - spin == pytest.approx(want - spin, rel=5e-3), (name, regime)
    print(f"{regime}: w/w0 after = {ref[-1, 8] / spin:.5f}, analytic {want / spin:.5f}")


def test_reference_engine_shears_with_rolling_resistance(tmp_path):
    """``granavg simulate --engine reference --start DATA --set mu_roll=0.1 --set
    mu_base=0.03`` runs (the reference engine used to refuse rolling resistance, and to
    ignore base friction) and writes its dumps."""
    x, v, w, frozen = loose_packing()
    data = tmp_path / "packing.data"
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string("\n".join(packing_commands(x, v, w, frozen)
                                      + [f"write_data {data} nocoeff"]))
    out = tmp_path / "run"
    sets = ["R_i=0.02", "R_o=0.06", "n_small=100", "n_large=10", "t_end=0.01",
            "t_dump_start=0", "dump_dt=0.005", "restart_dt=0.01", "mu_roll=0.1", "mu_base=0.03"]
    proc = run_cli("simulate", "--preset", "paper-hooke", "--out", out, "--no-progress",
                   "--start", data, "--engine", "reference",
                   *[a for s in sets for a in ("--set", s)])
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "complete" and manifest["contact_law"]["mu_roll"] == 0.1
    assert manifest["scene"]["mu_base"] == 0.03
    assert (out / "atoms.dump.gz").is_file() and (out / "contacts.dump.gz").is_file()
