"""Fields in time on the transient decks of lammps_inputs/ (workflows/collapse.py,
workflows/silo.py): the balance laws in time on a real column collapse, with the deck's
own contact law and dumps as a user writes them, and the silo's mass flow rate two ways."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

WORKFLOWS = Path(__file__).resolve().parents[1] / "workflows"
sys.path.insert(0, str(WORKFLOWS))
import collapse  # noqa: E402
import dump_interval  # noqa: E402
import silo  # noqa: E402

import granavg  # noqa: E402
from granavg.analysis.time_balance import continuity, interval_forecast, momentum  # noqa: E402

from .helpers import run_cli  # noqa: E402

pytestmark = pytest.mark.slow

#: dt = t_c/200, so that the dumped dashpot forces lie within 1% of the ones that moved
#: the disks (docs/time.md); frames every 2 steps (5.2e-6 s) over 0.0605-0.0695 s.
STEPS_PER_TC, STEP = 200, 2
GRID = {"grid": (24, 10), "x_range": (0.0, 0.12), "y_range": (0.0, 0.05), "thickness": 0.002}


@pytest.fixture(scope="module")
def collapse_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("collapse") / "run"
    return collapse.run_deck(out, STEPS_PER_TC, duration=0.07, step=STEP)


def _fields(atoms, contacts, gravity=(0.0, -9.81), **extra):
    common = dict(collapse.COMMON, gravity=gravity, **extra)
    return granavg.average(atoms, contacts=contacts, cells=GRID, kernel="lucy", width=0.006,
                           t_min=collapse.DENSE[0], t_max=collapse.DENSE[1],
                           time_kernel="gauss", time_width=0.001,
                           times=collapse.BALANCE_TIMES, **common)


@pytest.fixture(scope="module")
def balance_fields(collapse_run):
    return _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump")


def test_continuity_closes_within_1_percent_at_every_node_and_time(balance_fields):
    c = continuity(balance_fields)
    assert c["claim"]["verdict"] == "holds", c["claim"]["evidence"]
    assert c["ratio"] < 0.01


def test_momentum_closes_within_2_percent_of_rho_g_at_bulk_nodes(balance_fields):
    m = momentum(balance_fields)
    assert m["claim"]["verdict"] == "holds", m["claim"]["evidence"]
    assert m["ratio"] < 0.02
    assert set(m["terms"]) == {"dmomentum_dt", "divsigma", "divdsigma", "body", "boundary"}
    for name in m["terms"]:
        assert name in m["claim"]["evidence"]
    assert m["bulk_nodes"] > 100


def test_without_gravity_the_momentum_claim_fails(collapse_run):
    f = _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump", gravity=None)
    m = momentum(f)
    assert m["claim"]["verdict"] == "violated", m["claim"]["evidence"]


def test_the_velocities_residual_falls_with_the_frame_interval_and_the_flux_holds(
        collapse_run, tmp_path):
    """Frames every 2, 8 and 32 steps of the same run (every 1st, 4th, 16th frame): with
    the dumped velocities, the Gaussian's trapezoid rule is of order 2 on smooth motion
    (tests/test_time.py), a collision's kinks leave less; with the displacements' flux
    the continuity equation holds to round-off (1e-10 of the largest |d rho/dt|) at
    every interval."""
    ratios, flux = [], []
    for every in (1, 4, 16):
        atoms = collapse.thin(collapse_run / "atoms.dump", tmp_path / f"a{every}", every)
        contacts = collapse.thin(collapse_run / "contacts.dump", tmp_path / f"c{every}", every)
        f = _fields(atoms, contacts, quantities=["nu", "rho", "drho_dt", "continuity",
                                                 "continuity_v"])
        ratios.append(continuity(f, "continuity_v")["ratio"])
        flux.append(continuity(f)["ratio"])
    orders = np.log(np.array(ratios[1:]) / ratios[:-1]) / np.log(4)
    assert ratios[0] < ratios[1] < ratios[2], ratios
    assert orders.min() > 1.2, (ratios, orders)
    assert max(flux) < 1e-10, flux


@pytest.fixture(scope="module")
def user_dumps(tmp_path_factory):
    """The collapse at the deck's own timestep (t_c/50), dumped every 100 steps (2 contact
    durations, as a user dumps) from 0.05 to 0.35 s."""
    out = tmp_path_factory.mktemp("collapse100") / "run"
    return collapse.run_deck(out, 50, dense=(0.05, 0.35), duration=0.35, step=100)


def test_continuity_holds_at_every_node_and_time_dumped_every_two_contact_durations(
        user_dumps):
    """A Gaussian time kernel of 5 frame intervals, a Lucy kernel of 2 mean diameters:
    with the dumped velocities d rho/dt + div(rho v) misses by several percent of the
    largest |d rho/dt| (the frames alias the collisions); with the displacements' flux
    it is below 1% at every node and time (measured 1.7e-14: round-off)."""
    interval = 100 * collapse.deck_numbers(user_dumps)["dt"]
    f = granavg.average(user_dumps / "atoms.dump", contacts=user_dumps / "contacts.dump",
                        cells={"grid": (30, 8), "x_range": (0.0, 0.15),
                               "y_range": (0.0, 0.04), "thickness": 0.002},
                        kernel="lucy", width=0.004, t_min=0.05, t_max=0.35,
                        time_kernel="gauss", time_width=5 * interval,
                        times=(0.08, 0.32, 0.02), **collapse.COMMON,
                        quantities=["nu", "rho", "v", "drho_dt", "continuity",
                                    "continuity_v", "mass_flux"])
    c, v = continuity(f), continuity(f, "continuity_v")
    assert c["claim"]["verdict"] == "holds" and c["ratio"] < 0.01, c["claim"]["evidence"]
    assert v["claim"]["verdict"] == "violated" and v["ratio"] > 0.02, v["claim"]["evidence"]


def test_the_cli_says_the_interval_the_api_forecasts(user_dumps, tmp_path):
    """granavg average on the collapse every 2 contact durations: the log line and the
    sidecar's forecast for --time-accuracy 0.02 are the API's, to the digit."""
    dt = collapse.deck_numbers(user_dumps)["dt"]
    opts = dict(cells={"grid": (30, 8), "x_range": (0.0, 0.15), "y_range": (0.0, 0.04),
                       "thickness": 0.002},
                kernel="lucy", width=0.004, t_min=0.05, t_max=0.35, time_kernel="gauss",
                time_width=500 * dt, times=(0.08, 0.32, 0.02))
    f = granavg.average(user_dumps / "atoms.dump", contacts=user_dumps / "contacts.dump",
                        **collapse.COMMON, **opts)
    api = interval_forecast(f, 0.02)
    out = tmp_path / "f.csv"
    cmap = ",".join(f"{k}={v}" for k, v in collapse.MAP.items())
    proc = run_cli("average", "--atoms", user_dumps / "atoms.dump", "--contacts",
                   user_dumps / "contacts.dump", "--contact-columns", cmap, "--wall-types", 2,
                   "--gravity", 0, -9.81, "--thickness", 0.002, "--grid", 30, 8,
                   "--x-range", 0, 0.15, "--y-range", 0, 0.04, "--kernel", "lucy",
                   "--width", 0.004, "--t-min", 0.05, "--t-max", 0.35, "--time-kernel",
                   "gauss", "--time-width", repr(500 * dt), "--times", 0.08, 0.32, 0.02,
                   "--time-accuracy", 0.02, "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    cli = json.loads(out.with_name("f.csv.json").read_text())["time"]["forecast"]
    assert cli["target"] == 0.02 and api["forecast_interval"] > 0
    for key in ("forecast_interval", "residual_median", "quadrature_median", "floor"):
        assert cli[key] == pytest.approx(api[key], rel=1e-12), key
    line = next(ln for ln in proc.stderr.splitlines() if "dump every" in ln)
    assert f"{api['forecast_interval']:.3g} s or less" in line


def test_thinning_keeps_every_kth_whole_frame_of_both_dumps(collapse_run, tmp_path):
    whole = granavg.average(collapse_run / "atoms.dump", cells=GRID, quantities=["nu"],
                            wall_types=[2])
    atoms = collapse.thin(collapse_run / "atoms.dump", tmp_path / "a", 10)
    contacts = collapse.thin(collapse_run / "contacts.dump", tmp_path / "c", 10)
    f = granavg.average(atoms, contacts=contacts, cells=GRID, **collapse.COMMON)
    assert f.n_frames == -(-whole.n_frames // 10)


def test_the_mean_forces_close_the_momentum_between_frames_dumped_every_2_contact_durations(
        tmp_path):
    """The deck's fix ave/atom of fx fy fz over each interval of 100 steps (2 contact
    durations), read as the atoms' forces: d(rho v)/dt + div j_p against them is within
    2% of rho g at every bulk node and time (measured 1.5%, median 0.03%), while the
    momentum balance with the frames' contact stress misses by tens of percent there
    (median 24%: the frames alias the collisions)."""
    run = collapse.run_deck(tmp_path / "run", 50, dense=None, duration=0.35, every=100,
                            mean_forces=True)
    dt = collapse.deck_numbers(run)["dt"]
    f = granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                        **collapse.COMMON, atom_map={"fx": "f_fmean[1]", "fy": "f_fmean[2]",
                                                     "fz": "f_fmean[3]"},
                        cells={"grid": (30, 8), "x_range": (0.0, 0.15),
                               "y_range": (0.0, 0.04), "thickness": 0.002},
                        kernel="lucy", width=0.004, t_min=0.05, t_max=0.35,
                        time_kernel="gauss", time_width=500 * dt, times=(0.10, 0.30, 0.02),
                        quantities=["nu", "rho", "v", "dmomentum_dt", "divsigma",
                                    "divdsigma", "body", "boundary", "momentum_balance",
                                    "impulse_balance"])
    between, stress = momentum(f, "impulse_balance"), momentum(f)
    assert between["claim"]["verdict"] == "holds", between["claim"]["evidence"]
    assert between["median"] < 1e-3
    assert stress["claim"]["verdict"] == "violated" and stress["median"] > 0.1


@pytest.fixture(scope="module")
def every_step(tmp_path_factory):
    """The collapse dumped every step over 84-136 ms, thinned to every k steps
    (workflows/dump_interval.py)."""
    return dump_interval.Thinned(tmp_path_factory.mktemp("collapse1"))


def test_the_quadrature_estimate_is_within_a_factor_2_of_the_residuals_change(every_step):
    """At frames every 10 and 100 steps (0.2 and 2 contact durations) the estimated
    time-quadrature error of the momentum balance, from the data at that interval alone,
    lies within a factor 2 of how far the residual moved from the one of frames every
    step (rms over the bulk node-times; measured 0.72 and 1.39). At every step the
    estimate is under half the residual: what remains there is not the quadrature's
    (the dumped dashpot forces, docs/time.md)."""
    rms, residual = dump_interval.bulk_rms, dump_interval.residual
    ref = every_step.fields(1)
    assert rms(ref, ref.values["momentum_quadrature"]) < \
        0.5 * rms(ref, np.linalg.norm(residual(ref), axis=0))
    for k in (10, 100):
        r = dump_interval.row(every_step, k)
        assert 0.5 < r["estimate_over_change"] < 2.0, r


@pytest.mark.parametrize("k", [10, 100])
def test_the_forecast_interval_gives_the_target_and_four_times_it_more(every_step, k):
    """From frames every k steps the forecast names the interval for a median momentum
    residual of 1% of rho g; dumped at it (whole steps, rounded down) the residual is at
    most 1%, at 4 times that interval more."""
    r = dump_interval.row(every_step, k)
    assert r["dumped_at"] >= 1 and r["median_at"] <= 0.01 < r["median_at_4x"], r


@pytest.fixture(scope="module")
def silo_run(tmp_path_factory):
    return silo.run_deck(tmp_path_factory.mktemp("silo") / "run", duration=0.25)


def test_the_silo_rate_from_the_fields_equals_the_particle_count_within_errors(silo_run):
    area = silo.box_area(silo_run)
    assert area == pytest.approx(0.028 ** 2, rel=1e-9)
    t, mass = silo.mass_above(silo_run, sum(silo.SLAB) / 2)
    counted, counted_err = silo.count_rate(t, mass, 0.1, 0.25)
    fields, fields_err, rates = silo.field_rate(silo_run, area, 0.1, 0.25)
    assert len(rates) == 6
    assert abs(fields - counted) <= 2 * np.hypot(fields_err, counted_err), \
        (fields, fields_err, counted, counted_err)
    assert 0 < fields_err < 0.1 * fields and 0 < counted_err < 0.1 * counted
    # the start-up is no steady discharge: its rate is told apart by the same errors
    start, _, _ = silo.field_rate(silo_run, area, 0.0, 0.05)
    assert abs(start - counted) > 2 * np.hypot(fields_err, counted_err), (start, counted)


def test_each_size_class_balances_in_time_with_the_force_between_them(collapse_run):
    """The collapse split at radius 1 mm (its diameters 1.6-2.4 mm): each size class obeys
    the continuity equation on its own (within 1% of its largest |d rho_s/dt|: measured
    1.8e-7), and its momentum balance in time, with the force between the classes, to
    the whole's accuracy: within 2% of the whole's rho g at the class' bulk nodes
    (measured 1.4% and 0.65%; of the class' own rho_s g: 2.5% and 1.0%, the dumped
    dashpot's share being larger against a smaller weight). Without that force the
    classes miss by 33 and 9 times their weight."""
    f = _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump",
                species="radius:0.001")
    assert f.species == ("all", "r<0.001", "r>=0.001")
    whole = f.of("all")
    g = np.hypot(whole.values["body_x"], whole.values["body_y"])
    for s in f.species[1:]:
        p = f.of(s)
        c = continuity(p)
        assert c["claim"]["verdict"] == "holds", (s, c["claim"]["evidence"])
        res = np.hypot(p.values["momentum_balance_x"], p.values["momentum_balance_y"])
        nu = p.values["nu"]
        bulk = nu >= 0.5 * np.nanmax(nu, axis=1, keepdims=True)
        assert bulk.sum() > 50
        assert np.nanmax(res[bulk] / g[bulk]) < 0.02, (s, np.nanmax(res[bulk] / g[bulk]))
        without = np.hypot(p.values["momentum_balance_x"] + p.values["f_inter_x"],
                           p.values["momentum_balance_y"] + p.values["f_inter_y"])
        body = np.hypot(p.values["body_x"], p.values["body_y"])
        assert np.nanmedian(without[bulk] / body[bulk]) > 1.0, s
