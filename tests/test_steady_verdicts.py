"""The steady-state search's verdicts (workflows/steady_state.py, issue 28): a steady
window by a physical tolerance (the bulk pressure's trend within 3% per rotation by 2
errors), and the band's comparisons with their systematic errors, each shown to come
out every way. The rows are the measured ones of docs/steady-state.md."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflows"))
import steady_state  # noqa: E402


def row(p, p_err, c=0.0, c_err=0.01, nu=0.0, nu_err=0.001, drifts=()):
    return {"P_bulk_Pa_trend_per_rotation_rel": p, "P_bulk_Pa_trend_per_rotation_rel_err": p_err,
            "C_bulk_trend_per_rotation": c, "C_bulk_trend_per_rotation_err": c_err,
            "nu_bulk_trend_per_rotation": nu, "nu_bulk_trend_per_rotation_err": nu_err,
            "ensemble_z": {"P_bulk_Pa": 1.0}, "ensemble_drifts": list(drifts)}


def test_a_trend_shown_within_three_percent_per_rotation_is_steady():
    assert steady_state._steady(row(0.008, 0.006)) is True          # 4 x 150 s ageing runs


def test_a_trend_shown_beyond_three_percent_is_not():
    assert steady_state._steady(row(-0.052, 0.010)) is False        # mu_roll 0.1, 2 x 150 s
    assert steady_state._steady(row(0.0, 0.009, c=0.05, c_err=0.01)) is False   # C trends
    assert steady_state._steady(row(0.0, 0.009, drifts=["P_bulk_Pa"])) is False


def test_a_window_too_short_for_the_tolerance_cannot_tell():
    assert steady_state._steady(row(-0.033, 0.034)) is None         # the preset's 4 x 50 s


def test_the_band_comparison_counts_the_estimators_systematic_error():
    near = {"s": 0.0121, "s_err": 0.0002, "s_sys": 0.0002}
    assert steady_state._within(near, "s", 0.0127, 0.15)
    assert not steady_state._within({**near, "s_sys": 0.002}, "s", 0.0127, 0.15)
    assert not steady_state._within({"s": 0.0079, "s_err": 0.00056, "s_sys": 0.0002},
                                    "s", 0.0127, 0.15)
