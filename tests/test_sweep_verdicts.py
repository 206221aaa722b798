"""The speed/accuracy study's verdicts (workflows/sweep.py): the stiff-limit extrapolation
and the 5%/10% classes, each shown to come out both ways."""

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflows"))
import sweep  # noqa: E402


def test_a_straight_line_in_kn_to_the_minus_half_extrapolates_to_its_intercept():
    kn = np.array([10.0, 100.0, 1000.0])
    x = kn ** -0.5
    a, err, b, _, red = sweep.extrapolate(x, 0.7 - 0.4 * x, [0.01, 0.01, 0.01])
    assert a == pytest.approx(0.7) and b == pytest.approx(-0.4) and red == pytest.approx(0.0, abs=1e-20)
    # the intercept's error of a weighted fit: sqrt of the (0,0) element of (A^T W A)^-1
    A = np.stack([np.ones(3), x], axis=1)
    assert err == pytest.approx(math.sqrt(np.linalg.inv(A.T @ A / 1e-4)[0, 0]))


def test_scatter_beyond_the_errors_widens_the_limit_s_error():
    x = np.array([10.0, 100.0, 1000.0]) ** -0.5
    _, quiet, _, _, _ = sweep.extrapolate(x, 0.7 - 0.4 * x, [0.01] * 3)
    _, noisy, _, _, red = sweep.extrapolate(x, 0.7 - 0.4 * x + [0.05, -0.1, 0.05], [0.01] * 3)
    assert red > 1 and noisy == pytest.approx(quiet * math.sqrt(red))


def _limit(value=1.0, err=0.0):
    return pd.DataFrame({"value": {k: value for k in sweep.HEADLINES},
                         "err": {k: err for k in sweep.HEADLINES}})


def _row(value, err, dyn=0.01):
    r = {k: value for k in sweep.HEADLINES}
    r.update({f"{k}_err": err for k in sweep.HEADLINES})
    r["eom_residual"], r["eom_residual_err"] = 0.02, 0.001
    r["dynamic_over_static"] = dyn
    return r


@pytest.mark.parametrize("value, err, within_10, within_5", [
    (1.03, 0.001, True, True),      # 3% off, well measured
    (1.07, 0.001, True, False),     # a 7% bias
    (1.20, 0.001, False, False),    # a 20% bias
    (1.20, 0.15, True, True),       # 20% off but within the noise: no bias shown
    (0.88, 0.05, False, False),     # 12% off, 2.4 combined errors
])
def test_a_difference_is_a_bias_only_beyond_twice_the_combined_error(value, err,
                                                                     within_10, within_5):
    v = sweep.compare(_row(value, err), _limit(err=0.0))
    assert (v["within_10"], v["within_5"]) == (within_10, within_5)
    assert v["resolution"] == pytest.approx(2 * err)      # what a pass can vouch for


def test_a_setting_outside_the_quasi_static_regime_fails_whatever_its_numbers():
    v = sweep.compare(_row(1.0, 0.001, dyn=0.2), _limit())
    assert not v["within_10"] and not v["quasi_static"]


@pytest.mark.parametrize("values, flagged", [
    ((0.76, 0.82, 0.80), True),     # one flagged alone, two not: together they are 21% off
    ((0.76, 1.10, 0.97), False),    # scattered around the limit: the pool is no bias
])
def test_settings_at_one_k_n_are_judged_together(monkeypatch, values, flagged):
    """A bias of the springs' softness is shared by every setting at that k_n, while which
    of them crosses 2 combined errors is a matter of each one's noise: their pool (mean
    value, mean error: not reduced, they start from the same packings) is judged like a
    setting (``ship`` then gives a setting its pool's class when that is worse)."""
    names = ["base", "n_per_tc=25", "n_per_tc=100"]
    monkeypatch.setattr(sweep, "OTHER_SCENE", ())
    monkeypatch.setattr(sweep, "SIMULATED", {n: sweep.SIMULATED[n] for n in names})
    rows = {n: {**_row(v, 0.1), **{c: 1.0 for c in sweep.COST_COLUMNS}}
            for n, v in zip(names, values)}
    singles = [sweep.compare(r, _limit(err=0.02))["within_10"] for r in rows.values()]
    assert singles == [False, True, True]                  # 0.76 alone is flagged
    (name, pool, members), = sweep.pooled(rows, _limit(err=0.02)).values()
    assert members == names and name == "k_n=10: 3 settings pooled"
    assert pool["within_10"] is (not flagged)
    assert pool["v0"] == pytest.approx(np.mean(values)) and pool["v0_err"] == pytest.approx(0.1)


def test_a_number_the_setting_could_not_measure_vouches_for_nothing():
    """Rings too coarse for the band's fit leave v0 and s undefined (NaN): such a setting
    is not in any class, whatever its other numbers."""
    row = _row(1.0, 0.001)
    row["v0"] = row["s"] = float("nan")
    v = sweep.compare(row, _limit())
    assert not v["within_10"] and not v["within_5"] and v["unjudged"] == "v0, s"
    assert sweep.compare(_row(1.0, 0.001), _limit())["within_5"]
