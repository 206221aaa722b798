"""The new parts of the paper scene at their extremes (issue 40, docs/stability.md): real
short LAMMPS runs on both sides of each measured bound, with granavg's refusal lifted for
the side beyond it, and the refusal itself through the real CLI."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import granavg.sim.scene as scene_mod
from granavg.sim.scene import G, preset
from granavg.sim.simulate import simulate

from .conftest import SMALL_CELL, SMALL_PRESET, dump_positions, run_cli

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflows"))
from plate_extremes import thermo  # noqa: E402

#: the small cell at rest on a strongly frictional plate, every step dumped at the end
AT_REST = [*SMALL_CELL, "Omega=1e-5", "t_end=0.3", "t_dump_start=0.29", "dump_every=1",
           "mu_base=0.5", "contacts=0"]


def plate_scene(lambda_dt, *extra):
    """The small cell at rest whose plate damps ``lambda_dt`` = mu_base g dt / v_base a
    step."""
    sc = preset(SMALL_PRESET).with_overrides([*AT_REST, *extra])
    return sc.with_overrides([f"v_base={sc.mu_base * G * sc.derive().dt / lambda_dt!r}"])


def step_jitter(run) -> float:
    """RMS (m) of the part of the disks' step-to-step displacement that flips sign every
    step (half the difference of two successive displacements)."""
    d = np.diff(dump_positions(run), axis=0)
    return float(np.sqrt(np.mean((0.5 * (d[1:] - d[:-1])) ** 2)))


@pytest.mark.parametrize("base_every", [0, 10])
def test_the_plate_law_is_sound_below_its_bound_and_jitters_above(tmp_path, monkeypatch,
                                                                 base_every):
    """Below lambda dt = 2 the explicit step of the plate's linear part decays; above it
    the half-step velocity flips sign each step. With the law in full each step the cap
    holds the flip at v* = v_base sqrt((lambda dt / 2)^2 - 1) (a 2-cycle of
    v -> v - dt mu g v / sqrt(v^2 + v_base^2)); with the coefficient renewed every 10 steps
    nothing caps it for 10 steps."""
    monkeypatch.setattr(scene_mod, "MAX_BASE_DAMPING", math.inf)
    jitter = {}
    for lam in (1.8, 2.2):
        sc = plate_scene(lam, f"base_every={base_every}")
        simulate(sc, tmp_path / f"l{lam}", progress=False)
        jitter[lam] = step_jitter(tmp_path / f"l{lam}")
    sc = plate_scene(2.2)
    v_star = sc.v_base * math.sqrt((2.2 / 2) ** 2 - 1)
    assert jitter[1.8] < 1e-3 * sc.derive().dt * v_star          # measured 2e-4 of it
    low = 0.3 if base_every == 0 else 3.0                         # measured 0.5 and 11
    assert jitter[2.2] > low * sc.derive().dt * v_star
    if base_every == 0:
        assert jitter[2.2] < 2 * sc.derive().dt * v_star


def test_the_plate_law_beyond_its_bound_is_refused_in_one_line(tmp_path):
    sc = plate_scene(2.2, "base_every=10")
    sets = [a for s in (*AT_REST, f"v_base={sc.v_base!r}", "base_every=10")
            for a in ("--set", s)]
    proc = run_cli("simulate", "--preset", SMALL_PRESET, "--out", tmp_path / "r",
                   "--no-progress", *sets)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and "2.2 per step" in line and "set v_base >" in line
    bound = float(line.split("set v_base > ")[1].split()[0])
    assert bound == pytest.approx(sc.v_base * 2.2 / 2, rel=1e-2)
    assert not (tmp_path / "r" / "log.lammps").exists()


def _thermo_ke(run) -> np.ndarray:
    """The disks' kinetic energy (J) of every thermo line of a run's log."""
    return thermo(run / "log.lammps")[:, 1]


def _lift_dt_bounds(monkeypatch):
    monkeypatch.setattr(scene_mod, "MIN_STEPS_PER_CONTACT", 1e-9)
    monkeypatch.setattr(scene_mod, "max_stable_timestep", lambda *_: math.inf)
    monkeypatch.setattr(scene_mod, "MAX_DASHPOT_DAMPING", math.inf)


def _sheared(*extra):
    return preset(SMALL_PRESET).with_overrides([*SMALL_CELL, "t_end=1", "t_dump_start=0.5",
                                                "dump_dt=0.5", "contacts=0", *extra])


def test_the_dashpot_is_sound_below_its_bound_and_heats_the_packing_above(tmp_path,
                                                                          monkeypatch):
    """gamma_n dt = -2 ln(e_n) / n: at 0.45 per step the sheared small cell is calmer than
    with e_n = 0.9 (measured 0.45 of its kinetic energy), at 0.65 its energy grows (36
    times; measured besides: at 1.1 it blows up): a disk damped by several contacts at
    once."""
    _lift_dt_bounds(monkeypatch)
    ke = {}
    for g in (None, 0.45, 0.65):
        e_n = 0.9 if g is None else math.exp(-g * 50 / 2)
        sc = _sheared(f"e_n={e_n!r}", "n_per_tc=50")
        simulate(sc, tmp_path / str(g), progress=False)
        ke[g] = np.median(_thermo_ke(tmp_path / str(g))[-20:])
    assert ke[0.45] < ke[None] < ke[0.65] / 10, ke


def test_a_dashpot_beyond_its_bound_is_refused_in_one_line(tmp_path):
    e_n = math.exp(-0.55 * 50 / 2)                                # 0.55 per step
    proc = run_cli("simulate", "--preset", "paper", "--out", tmp_path / "r", "--no-progress",
                   "--set", f"e_n={e_n!r}")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and "gamma_n dt = 0.55 per step" in line
    assert float(line.split("set n_per_tc > ")[1].split()[0]) == pytest.approx(
        -4 * math.log(e_n), rel=1e-2)                            # -2 ln(e_n) / n < 0.5
    ok = preset("paper").with_overrides([f"e_n={e_n!r}", f"n_per_tc={-4 * math.log(e_n) + 1}"])
    assert ok.derive().coeffs.gamma_n * ok.derive().dt < scene_mod.MAX_DASHPOT_DAMPING


@pytest.mark.parametrize("mu_roll", [0, 3])
def test_rolling_resistance_breaks_at_the_same_step_as_the_plain_law(tmp_path, monkeypatch,
                                                                    mu_roll):
    """The rolling spring (k_roll = k_t, on the relative rolling of two disks) is softer
    than the tangential mode the time-step bound already covers: with or without a large
    mu_roll the sheared small cell is sound at n = 5 (half the launcher's bound) and
    blows up at n = 2.5 (the paper packing, at n = 3; docs/stability.md)."""
    _lift_dt_bounds(monkeypatch)
    from granavg.errors import UserError
    sc = _sheared(f"mu_roll={mu_roll}", "n_per_tc=5")
    simulate(sc, tmp_path / "n5", progress=False)
    ke5 = _thermo_ke(tmp_path / "n5")
    assert ke5.max() < 100 * np.median(ke5)
    with pytest.raises(UserError, match="blew up"):
        simulate(_sheared(f"mu_roll={mu_roll}", "n_per_tc=2.5"), tmp_path / "n2.5",
                 progress=False)


def test_a_renewal_rarer_than_a_contact_time_is_refused_in_one_line(tmp_path):
    """The plate's coefficient renewed every base_every steps: measured sound up to one
    contact time (docs/sweep: base_every = 50 = n_per_tc), refused beyond with the bound;
    at the bound the run goes."""
    sets = [a for s in (*SMALL_CELL, "mu_base=0.005", "v_base=1e-4", "n_per_tc=20",
                        "contacts=0") for a in ("--set", s)]
    proc = run_cli("simulate", "--preset", SMALL_PRESET, "--out", tmp_path / "r",
                   "--no-progress", *sets, "--set", "base_every=21")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and "1.05 contact times" in line and "base_every <= 20" in line
    proc = run_cli("simulate", "--preset", SMALL_PRESET, "--out", tmp_path / "ok",
                   "--no-progress", *sets, "--set", "base_every=20", "--set", "t_end=0.2",
                   "--set", "t_dump_start=0.1")
    assert proc.returncode == 0, proc.stderr
