"""The per-frame state and the steadiness test: synthetic series with and without a
trend, geometry with known answers, and a real run's time series."""

import numpy as np
import pandas as pd
import pytest

from granavg.engine.stationarity import (DRIFT_Z, ensemble_stationarity, stationarity,
                                         steady_from)
from granavg.sim.couette_state import frame_state
from granavg.io.profiles_io import read_profiles, write_profiles

R_I, R_O, H, RHO = 0.1, 0.2, 0.006, 1000.0


def ar1(n, phi, rng):
    x = np.empty(n)
    x[0] = rng.standard_normal() / np.sqrt(1 - phi**2)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + rng.standard_normal()
    return x


def series(x, dt=2.0):
    return pd.DataFrame({"t_s": dt * np.arange(len(x)), "C_bulk": x})


@pytest.mark.parametrize("phi", [0.0, 0.8])
def test_a_steady_correlated_series_is_not_flagged(phi):
    rng = np.random.default_rng(11)
    flagged = [stationarity(series(3 + 0.1 * ar1(400, phi, rng)), 0.0)["C_bulk"]["drifts"]
               for _ in range(40)]
    assert np.mean(flagged) <= 0.05                  # DRIFT_Z = 3: ~0.3% if errors are honest


def test_a_trend_is_flagged_and_the_steady_start_found():
    """A relaxation 3.5 -> 3.0 over the first 150 s, then steady with correlated noise."""
    rng = np.random.default_rng(12)
    t = 2.0 * np.arange(300)
    x = 3.0 + 0.5 * np.clip(1 - t / 150, 0, None) + 0.02 * ar1(300, 0.8, rng)
    judged = stationarity(pd.DataFrame({"t_s": t, "C_bulk": x}), 60.0)["C_bulk"]
    assert judged["drifts"] and judged["z"] > DRIFT_Z
    start = judged["steady_from_s"]
    assert start is not None and 120 <= start <= 250
    assert not stationarity(pd.DataFrame({"t_s": t, "C_bulk": x}), start)["C_bulk"]["drifts"]


def test_a_series_that_never_settles_has_no_steady_start():
    t = 2.0 * np.arange(200)
    x = 3.0 - 0.004 * t + 0.001 * np.random.default_rng(1).standard_normal(200)
    assert steady_from(pd.DataFrame({"t_s": t, "C_bulk": x}), "C_bulk", 0.0) is None


def hexagon_frame(n_side=14, d=0.004, squeeze=0.01):
    """Disks on a triangular lattice in the bulk zone, touching neighbours with overlap
    squeeze * d; every lattice pair is a contact with normal force k * overlap."""
    pts = []
    for i in range(-n_side, n_side + 1):
        for j in range(-n_side, n_side + 1):
            pts.append((0.15 + (i + 0.5 * j) * d * (1 - squeeze), (j * np.sqrt(3) / 2) * d
                        * (1 - squeeze)))
    x, y = np.array(pts).T
    keep = np.hypot(x, y) > 0
    x, y = x[keep], y[keep]
    r = np.hypot(x, y)
    inside = (r > R_I + 0.3 * (R_O - R_I)) & (r < R_I + 0.8 * (R_O - R_I))
    x, y = x[inside], y[inside]
    ids = np.arange(1, len(x) + 1)
    atoms = {"x": x, "y": y, "radius": np.full(len(x), d / 2), "id": ids,
             "vx": np.zeros(len(x)), "vy": np.zeros(len(x)), "omegaz": np.zeros(len(x))}
    i, j = np.triu_indices(len(x), 1)
    dist = np.hypot(x[i] - x[j], y[i] - y[j])
    touch = dist < d * 0.999
    i, j, dist = i[touch], j[touch], dist[touch]
    nx, ny = (x[j] - x[i]) / dist, (y[j] - y[i]) / dist
    ov = d - dist
    k = 10.0
    contacts = {"id1": ids[i], "id2": ids[j], "wall": np.zeros(len(i)),
                "fnx": -k * ov * nx, "fny": -k * ov * ny, "ftx": 0 * nx, "fty": 0 * ny,
                "nx": nx, "ny": ny, "overlap": ov}
    return atoms, contacts, k


def test_a_hexagonal_packing_is_ordered_and_its_pressure_is_the_virial():
    atoms, contacts, k = hexagon_frame()
    s = frame_state(atoms, contacts, R_I, R_O, H, RHO, 0.004)
    interior = s["C_bulk"]
    assert 5.0 < interior <= 6.0                      # six neighbours inside, fewer at edges
    assert s["psi6_bulk"] > 0.85 and s["psi6_bulk_ordered"] > 0.8
    # -tr sigma / 2 of the zone: sum over contacts of (a1 + a2) k overlap / (2 V)
    lo, hi = R_I + 0.3 * (R_O - R_I), R_I + 0.8 * (R_O - R_I)
    V = np.pi * (hi**2 - lo**2) * H
    expected = np.sum(0.004 * k * contacts["overlap"]) / (2 * V)
    assert s["P_bulk_Pa"] == pytest.approx(expected, rel=1e-12)
    assert s["overlap_max_over_d"] == pytest.approx(0.01, rel=1e-6)
    assert s["ke_J"] == 0.0 and s["rattler_fraction"] < 0.1


def test_random_disks_have_no_hexatic_order():
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(3)
    r = np.sqrt(rng.uniform(R_I**2, R_O**2, 3000))
    phi = rng.uniform(0, 2 * np.pi, 3000)
    a = np.full(3000, 0.0025)
    atoms = {"x": r * np.cos(phi), "y": r * np.sin(phi), "radius": a,
             "id": np.arange(1, 3001)}
    pairs = cKDTree(np.column_stack([atoms["x"], atoms["y"]])).query_pairs(0.009,
                                                                          output_type="ndarray")
    i, j = pairs.T
    contacts = {"id1": i + 1, "id2": j + 1, "wall": np.zeros(len(i))}
    s = frame_state(atoms, contacts, R_I, R_O, H, RHO, 0.005)
    # ~4.6 bonds per disk at random: |psi_6| ~ sqrt(pi / (4 n)) = 0.41; hexagons: > 0.85
    assert s["psi6_bulk"] < 0.5 and s["psi6_bulk_ordered"] < 0.1
    s = frame_state(atoms, None, R_I, R_O, H, RHO, 0.002)
    assert "C" not in s and "psi6_bulk" not in s       # no contacts: no network


def test_a_real_run_writes_its_time_series(small_run, tmp_path):
    from granavg.pipeline.runs import average_run

    p = average_run(small_run, bins=6, t_min=1.5, progress=False)
    write_profiles(p, tmp_path / "p.csv")
    back = read_profiles(tmp_path / "p.csv")
    ts = back.timeseries
    assert ts.t_s.iloc[0] < 1.5 <= ts.t_s.iloc[-1]    # all frames, the window marked later
    assert np.all(np.diff(ts.step) > 0) and np.all(ts.C > 2)
    assert np.all(ts.P_bulk_Pa > 0) and np.all(ts.overlap_max_over_d < 0.2)
    assert set(p.meta["stationarity"]) <= {"C", "C_bulk", "P_bulk_Pa", "rattler_fraction",
                                           "nu_bulk", "psi6_bulk"}


def ensemble(n_runs, rng, drift=0.0, phi=0.97, frames=44):
    """Per-run verdicts of n_runs independent realisations: fluctuations as slow as the
    window (AR(1), phi 0.97: a correlation time of ~30 frames) plus a shared linear drift
    of ``drift`` over the window."""
    t = np.arange(frames, dtype=float)
    return [stationarity(pd.DataFrame({"t_s": t, "C_bulk": 3 + 0.01 * ar1(frames, phi, rng)
                                       + drift * t / t[-1]}), 0.0)
            for _ in range(n_runs)]


@pytest.mark.slow
def test_an_ensemble_of_steady_runs_is_steady_where_single_runs_cannot_tell():
    rng = np.random.default_rng(21)
    runs = [ensemble(4, rng) for _ in range(120)]
    # one run's blocking error is a lower bound here: it cannot decide
    assert np.mean([r["C_bulk"]["error_lower_bound"] for rs in runs for r in rs]) > 0.5
    judged = [ensemble_stationarity(rs)["C_bulk"] for rs in runs]
    assert judged[0]["n_runs"] == 4 and not judged[0]["undetermined"]
    assert judged[0]["false_alarm"] == pytest.approx(0.058, abs=0.001)   # t, 3 dof, 3 errors
    # honest between-run errors: false alarms near the stated rate (two tests: below 2x)
    assert np.mean([j["drifts"] for j in judged]) <= 2 * judged[0]["false_alarm"]


def test_a_drift_shared_by_the_runs_is_flagged_by_the_ensemble():
    rng = np.random.default_rng(22)
    judged = [ensemble_stationarity(ensemble(4, rng, drift=-0.2))["C_bulk"] for _ in range(30)]
    assert np.mean([j["drifts"] for j in judged]) >= 0.9
    assert all(j["change"] < 0 for j in judged)
    assert all(j["resolution"] == pytest.approx(DRIFT_Z * j["change_err"]) for j in judged)


def test_changes_that_go_both_ways_between_runs_are_no_drift():
    """Each run moves by at least 5 of its own errors, half of them up, half down."""
    rng = np.random.default_rng(23)
    runs = ensemble(4, rng, phi=0.0)
    step = 5 * np.sqrt(2) * max(r["C_bulk"]["second_half_err"] for r in runs)
    for k, r in enumerate(runs):
        j = r["C_bulk"]
        j["second_half"] = j["first_half"] + (-1) ** k * step
        j["trend_change"] = 1.5 * (j["second_half"] - j["first_half"])
    judged = ensemble_stationarity(runs)["C_bulk"]
    assert abs(judged["change"]) < 1e-12 and not judged["drifts"]


def test_an_ensemble_verdict_needs_three_runs():
    rng = np.random.default_rng(24)
    assert ensemble_stationarity(ensemble(2, rng, drift=-1.0) + [None]) == {}
    assert "C_bulk" in ensemble_stationarity(ensemble(3, rng, drift=-1.0))


def test_the_ageing_of_four_250_s_runs_is_a_drift_of_the_ensemble():
    """Real data: the 4 x 250 s rolling-resistance ensemble (docs/paper-rolling), whose
    bulk pressure falls 6.5% over the window in every run; each run's own test could
    only call it undetermined (lower-bound errors)."""
    import json
    from pathlib import Path
    meta = json.loads((Path(__file__).parents[1] / "docs/paper-rolling/profiles20.csv.json")
                      .read_text())
    per_run = [r["stationarity"] for r in meta["runs"]]
    assert not any(r["P_bulk_Pa"]["drifts"] for r in per_run)
    judged = ensemble_stationarity(per_run)["P_bulk_Pa"]
    assert judged["drifts"] and judged["change"] < 0


def test_the_paper_presets_window_is_steady_in_its_ensemble():
    """Real data: the `paper` preset's 4 x 50 s ensemble (docs/paper, base-plate friction
    on): judged from its realisations, C_bulk, P_bulk and nu_bulk do not drift over the
    window (issue 12's done-when) - the same test that flags docs/paper-rolling above."""
    import json
    from pathlib import Path
    meta = json.loads((Path(__file__).parents[1] / "docs/paper/profiles20.csv.json")
                      .read_text())
    assert meta["run_manifest"]["scene"]["mu_base"] > 0
    judged = ensemble_stationarity([r["stationarity"] for r in meta["runs"]])
    for q in ("C_bulk", "P_bulk_Pa", "nu_bulk"):
        assert not judged[q]["drifts"], (q, judged[q])


def test_one_runs_undetermined_verdict_is_information_and_a_drift_a_warning(caplog):
    """A single run whose errors are lower bounds cannot tell a drift from slow
    fluctuations: its "undetermined" is logged as information, a drift as a warning."""
    import logging

    from granavg.engine.cell_average import warn_if_drifting
    rng = np.random.default_rng(25)
    steady = ensemble(40, rng)
    unsure = next(r for r in steady if r["C_bulk"]["undetermined"])
    with caplog.at_level(logging.INFO, logger="granavg"):
        assert warn_if_drifting(unsure, 0.0) == []
    assert [r.levelno for r in caplog.records] == [logging.INFO]
    assert "cannot tell a drift" in caplog.text
    caplog.clear()
    rng, t = np.random.default_rng(12), 2.0 * np.arange(300)   # the test above
    x = 3.0 + 0.5 * np.clip(1 - t / 150, 0, None) + 0.02 * ar1(300, 0.8, rng)
    drifting = stationarity(pd.DataFrame({"t_s": t, "C_bulk": x}), 60.0)
    with caplog.at_level(logging.INFO, logger="granavg"):
        assert warn_if_drifting(drifting, 60.0) == ["C_bulk"]
    assert logging.WARNING in [r.levelno for r in caplog.records]


def test_a_verdict_said_twice_in_one_command_is_printed_once():
    """The demo judges the same window for 20 and for 60 rings: the command's log says
    the verdict once, and a different line still gets through."""
    import subprocess
    import sys
    code = ("import logging; from granavg.pipeline.session import configure_logging; "
            "configure_logging(False); log = logging.getLogger('granavg.x'); "
            "[log.info('the window t >= 6.3 s: cannot tell a drift') for _ in range(2)]; "
            "log.warning('the window t >= 6.3 s: cannot tell a drift'); log.info('another')")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stderr.splitlines()
    assert err == ["granavg: the window t >= 6.3 s: cannot tell a drift",
                   "granavg: the window t >= 6.3 s: cannot tell a drift", "granavg: another"]
