"""Blocking analysis and replicates against series whose errors are known exactly."""

import numpy as np
import pytest

from granavg.engine.channels import Layout
from granavg.engine.profiles import standard_errors
from granavg.engine.uncertainty.blocking import (MIN_BLOCKS, Replicates, blocking_errors,
                                        jackknife_sums, merge_levels, spread_error)

LAYOUT = Layout(("r", "phi"))
CHANNELS, INDEX = LAYOUT.names, LAYOUT.index


def ar1(n, phi, rng):
    """x_t = phi x_{t-1} + e_t, unit innovations, started in its stationary state."""
    e = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = e[0] / np.sqrt(1 - phi**2)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return x


def true_sem(n, phi):
    """Standard error of the mean of n AR(1) values: sqrt(var (1+phi)/(1-phi) / n)."""
    return np.sqrt((1 + phi) / (1 - phi) / n / (1 - phi**2))


def series_error(x):
    sem, lower = blocking_errors(np.ones(len(x)), x[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
    return sem["x"][0], lower["x"][0]


@pytest.mark.parametrize("phi, lo, hi", [(0.0, 0.97, 1.03), (0.5, 0.92, 1.05),
                                         (0.9, 0.85, 1.08)])
def test_blocking_recovers_the_error_of_correlated_series(phi, lo, hi):
    """AR(1) with integrated correlation times 0.5, 1.5 and 9.5 frames, 4096 frames:
    the mean ratio to the exact error over 60 series (measured 1.00, 0.98, 0.95)."""
    rng = np.random.default_rng(7)
    ratios, flagged = [], []
    for _ in range(60):
        e, lb = series_error(ar1(4096, phi, rng))
        ratios.append(e / true_sem(4096, phi))
        flagged.append(lb)
    assert lo < np.mean(ratios) < hi
    assert np.mean(flagged) < 0.05


def test_the_naive_error_of_correlated_frames_is_far_too_small():
    """What the blocking analysis corrects: frames taken as independent."""
    x = ar1(4096, 0.9, np.random.default_rng(3))
    naive = spread_error(x[:, None])[0]
    assert naive < 0.4 * true_sem(4096, 0.9) < series_error(x)[0]


def test_a_correlation_time_near_the_run_length_is_flagged_a_lower_bound():
    rng = np.random.default_rng(5)
    flags = [series_error(ar1(512, 0.995, rng))[1] for _ in range(20)]   # tau ~ 200 frames
    assert np.mean(flags) > 0.8


def test_nan_blocks_are_left_out_and_not_counted():
    x = np.arange(12.0)
    with_nan = np.r_[x, np.nan, np.nan, np.nan, np.nan]
    assert spread_error(with_nan[:, None])[0] == pytest.approx(np.std(x, ddof=1) / np.sqrt(12))
    assert np.isnan(spread_error(np.array([[1.0], [np.nan]]))[0])


def test_levels_merge_pairs_and_drop_an_odd_last_block():
    levels = merge_levels(np.ones(9), np.arange(9.0))
    assert [len(c) for c, _ in levels] == [9, 4, 2]
    assert np.array_equal(levels[1][1], [1.0, 5.0, 9.0, 13.0])


def test_the_jackknife_of_a_mean_is_the_standard_error_of_the_block_means():
    rng = np.random.default_rng(1)
    x = rng.standard_normal(64)
    reps = jackknife_sums(np.ones(64), x[:, None, None])[:, 0, 0]
    assert len(reps) >= MIN_BLOCKS
    blocks = x.reshape(len(reps), -1).mean(axis=1)
    jk = Replicates("jackknife", {"x": reps[:, None]}).error(reps)
    assert jk == pytest.approx(np.std(blocks, ddof=1) / np.sqrt(len(blocks)), rel=1e-12)


def test_runs_give_the_between_run_standard_error():
    x = np.array([1.0, 2.0, 4.0, np.nan])
    assert Replicates("runs", {}).error(x) == pytest.approx(np.std(x[:3], ddof=1) / np.sqrt(3))


def test_profile_errors_with_a_ring_empty_in_some_blocks():
    """Ring 1 is empty in 8 of 40 blocks: its v_phi error uses the 32 others only."""
    rng = np.random.default_rng(4)
    n = 40
    sums = np.zeros((n, 2, len(CHANNELS)))
    vol = np.ones((n, 2))
    vol[::5, 1] = 0.0
    v = rng.standard_normal((n, 2))
    sums[:, :, INDEX["vol"]] = vol
    sums[:, :, INDEX["mass"]] = 2.0 * vol
    sums[:, :, INDEX["mom_phi"]] = 2.0 * vol * v
    sem, lower, reps = standard_errors(np.ones(n), sums, np.ones(2), 1000.0, ["v"], LAYOUT)
    finite = v[vol[:, 1] > 0, 1]
    naive = np.std(finite, ddof=1) / np.sqrt(len(finite))
    assert sem["v_phi"][1] == pytest.approx(naive, rel=0.5)     # white noise: ~ naive
    assert reps.kind == "jackknife" and reps.n >= MIN_BLOCKS
    assert np.all(np.isfinite(reps.values["v_phi"]))


def test_fewer_than_two_blocks_give_no_error():
    sums = np.ones((1, 3, len(CHANNELS)))
    sem, lower, reps = standard_errors(np.ones(1), sums, np.ones(3), 1000.0, ["nu"], LAYOUT)
    assert np.all(np.isnan(sem["nu"])) and np.all(lower["nu"]) and reps is None
