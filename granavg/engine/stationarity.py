"""Whether an averaging window is steady, from the per-frame state a scene records (the
Couette cell's: :mod:`granavg.sim.couette_state`).

:func:`stationarity` judges each recorded quantity over the averaging window: a
quantity drifts when the means of the window's two halves, or the change of a straight
line fitted over it, differ from steady by more than :data:`DRIFT_Z` errors; the errors
come from the fluctuations about that line, by blocking analysis
(:mod:`granavg.engine.uncertainty.blocking`), so that neither correlation nor the trend
itself is mistaken for noise. :func:`steady_from` finds the earliest start from which a
quantity does not drift. :func:`ensemble_stationarity` judges the window of an ensemble
from its runs' verdicts, with errors from the spread between independent realisations,
which stay honest where one run's fluctuations are as slow as its window.
"""

from __future__ import annotations

import warnings

import numpy as np

from granavg.engine.uncertainty.blocking import blocking_errors

#: Half-window means further apart than this many combined errors flag a drift. With
#: honest errors a steady quantity is flagged in ~0.3% of tests.
DRIFT_Z = 3.0
#: An ensemble verdict needs at least this many independent realisations.
MIN_RUNS = 3


def window_mean(series, column: str, start: float) -> dict:
    """Mean of a per-frame quantity over t >= start with its standard error: between
    realisations for an ensemble's series (a ``run`` column), else by blocking analysis
    of the frames (``lower_bound`` where no plateau was reached); None if absent.
    ``series``: a table (DataFrame, or a mapping of columns)."""
    if series is None or column not in series:
        return None
    inside = np.asarray(series["t_s"], float) >= start
    x = np.asarray(series[column], float)[inside]
    if "run" in series:
        runs = np.asarray(series["run"])[inside]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)      # a run with no value: NaN
            means = np.array([np.nanmean(x[runs == r]) for r in np.unique(runs)])
        err = float(np.std(means, ddof=1) / np.sqrt(len(means))) if len(means) > 1 else np.nan
        return {"mean": float(np.mean(means)), "err": err, "n_runs": int(len(means)),
                "error": "between realisations"}
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return {"mean": float(np.mean(x)) if len(x) else np.nan, "err": np.nan}
    sem, lower = blocking_errors(np.ones(len(x)), x[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
    return {"mean": float(np.mean(x)), "err": float(sem["x"][0]),
            "lower_bound": bool(lower["x"][0]), "error": "blocking over frames"}


def _fluctuation_error(t, x):
    """Standard error of the mean of x from its fluctuations about a straight line
    (blocking analysis of the residuals: a trend is not read as correlation)."""
    resid = x - np.polyval(np.polyfit(t, x, 1), t)
    sem, lower = blocking_errors(np.ones(len(x)), resid[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
    return float(sem["x"][0]), bool(lower["x"][0])


def stationarity(series, start: float, judged=None, stop: float | None = None) -> dict:
    """Judge each quantity named in ``judged`` (default every column but ``step`` and
    ``t_s``) over the window start <= t <= stop of a table (DataFrame, or a mapping of
    columns with ``t_s``).

    Returns
    -------
    dict of quantity -> dict
        ``first_half``, ``second_half`` (means), their errors, ``trend_change`` (of the
        fitted line over the window), ``z`` (the larger departure from steady, in
        errors), ``drifts`` (z > DRIFT_Z with a reliable error), ``undetermined`` (z >
        DRIFT_Z, but the later half's error is only a lower bound: too few independent
        samples to tell a drift from slow fluctuations), ``error_lower_bound``,
        ``steady_from_s`` (earliest start that would be steady).
    """
    t = np.asarray(series["t_s"], float)
    upto = t <= (stop if stop is not None else np.inf)
    window = (t >= start) & upto
    out = {}
    for q in judged if judged is not None else [c for c in series if c not in ("step", "t_s")]:
        if q not in series:
            continue
        x = np.asarray(series[q], float)
        if np.sum(~np.isnan(x[window])) < 8:
            continue
        res = _judge(t[window], x[window])
        if res is None:
            continue
        res["steady_from_s"] = steady_from({"t_s": t[upto], q: x[upto]}, q, start)
        out[q] = res
    return out


def _judge(t, x):
    """Half means and a linear trend over the window, against the fluctuation error of
    the steadier half (under steadiness both halves fluctuate alike, so a transient
    cannot hide in its own inflated error); drifts if either departs from steady by
    more than DRIFT_Z errors."""
    ok = np.isfinite(x)
    t, x = t[ok], x[ok]
    if len(x) < 8:
        return None
    half = len(x) // 2
    (e1, l1), (e2, l2) = (_fluctuation_error(t[s], x[s]) for s in (slice(None, half),
                                                                     slice(half, None)))
    m1, m2 = float(x[:half].mean()), float(x[half:].mean())
    e_half = e2                  # the later half: the steady reference if a transient ends
    change = np.polyfit(t, x, 1)[0] * (t[-1] - t[0])   # the trend's change over the window
    z_halves = _ratio(abs(m2 - m1), np.sqrt(2) * e_half)
    z_trend = _ratio(abs(change), np.sqrt(12) * e_half / np.sqrt(2))
    z = float(max(z_halves, z_trend))
    return {"first_half": m1, "first_half_err": e1, "second_half": m2, "second_half_err": e2,
            "trend_change": float(change), "z": z, "drifts": bool(z > DRIFT_Z and not l2),
            "undetermined": bool(z > DRIFT_Z and l2), "error_lower_bound": l1 or l2}


def _ratio(a, b):
    return a / b if b > 0 else (0.0 if a == 0 else np.inf)


def steady_from(series, q: str, start: float, min_frames: int = 16):
    """Earliest start (s, t >= start) of a steady stretch of ``q``: the start that
    maximises the effective number of independent frames n / g, g the statistical
    inefficiency from blocking (Chodera, J. Chem. Theory Comput. 12, 1799, 2016), if
    the stretch from there does not drift; None otherwise (or with < min_frames)."""
    t = np.asarray(series["t_s"], float)
    x = np.asarray(series[q], float)
    keep = (t >= start) & np.isfinite(x)
    t, x = t[keep], x[keep]
    if len(x) < min_frames:
        return None
    best, best_neff = None, -1.0
    for start in np.linspace(t[0], t[-min_frames], 20):
        part = x[t >= start]
        naive = np.std(part, ddof=1) / np.sqrt(len(part))
        sem, _ = blocking_errors(np.ones(len(part)), part[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
        g = max((sem["x"][0] / naive) ** 2, 1.0) if naive > 0 else 1.0
        if len(part) / g > best_neff:
            best, best_neff = float(start), len(part) / g
    res = _judge(t[t >= best], x[t >= best])
    return best if res is not None and not (res["drifts"] or res["undetermined"]) else None


def ensemble_stationarity(judged: list) -> dict:
    """Judge an ensemble's averaging window from its runs' :func:`stationarity` results.

    Each run k gives the change between the means of its window's halves, d_k, and the
    change c_k of a line fitted over the window. Independent realisations of a steady
    window give changes that scatter about zero; a drift shared by the runs moves their
    mean. The error of the mean change is the between-run standard error
    std(d_k)/sqrt(n), never below the error from the runs' own errors (as in
    :func:`granavg.engine.combine.combine_runs`): unlike a single run's blocking error, it
    stays honest when fluctuations are as slow as the window. A quantity drifts when the
    mean change of either kind exceeds :data:`DRIFT_Z` errors; with n runs the error has
    n - 1 degrees of freedom, so one such test flags a steady window with probability
    ``false_alarm`` (Student's t; 5.8% for 4 runs, 2.0% for 8; both tests together,
    measured on synthetic ensembles of 44 frames with fluctuations as slow as the window:
    7-8% and 3%; docs/profiles.md).

    Parameters
    ----------
    judged : list of dict
        One :func:`stationarity` result per realisation (``None`` for a run without a
        time series), all over the same window.

    Returns
    -------
    dict of quantity -> dict
        For each quantity judged in at least :data:`MIN_RUNS` runs: ``n_runs``, the
        ensemble means ``first_half`` and ``second_half``, ``change`` (mean d_k) and
        ``change_err``, ``trend_change`` and ``trend_change_err`` (mean c_k), ``z`` (the
        larger departure, in errors), ``drifts``, ``undetermined`` (always False: the
        errors are not lower bounds), ``resolution`` (the smallest half-to-half change
        the test would call a drift, DRIFT_Z errors) and ``false_alarm``. Empty with
        fewer runs.
    """
    runs = [j for j in judged if j]
    out = {}
    for q in dict.fromkeys(q for j in runs for q in j):
        rows = [j[q] for j in runs if q in j]
        if len(rows) < MIN_RUNS:
            continue
        n = len(rows)
        m1, m2 = (np.array([r[k] for r in rows]) for k in ("first_half", "second_half"))
        own = np.array([np.sqrt(2) * r["second_half_err"] for r in rows])
        d = m2 - m1
        c = np.array([r["trend_change"] for r in rows])
        floor = np.sqrt(np.sum(own**2)) / n
        e_d = max(np.std(d, ddof=1) / np.sqrt(n), floor)
        e_c = max(np.std(c, ddof=1) / np.sqrt(n), np.sqrt(6) * floor)   # as in _judge
        z = float(max(_ratio(abs(d.mean()), e_d), _ratio(abs(c.mean()), e_c)))
        out[q] = {"n_runs": n, "first_half": float(m1.mean()), "second_half": float(m2.mean()),
                  "first_half_err": float(np.std(m1, ddof=1) / np.sqrt(n)),
                  "second_half_err": float(np.std(m2, ddof=1) / np.sqrt(n)),
                  "change": float(d.mean()), "change_err": float(e_d),
                  "trend_change": float(c.mean()), "trend_change_err": float(e_c),
                  "z": z, "drifts": bool(z > DRIFT_Z), "undetermined": False,
                  "error_lower_bound": False, "resolution": float(DRIFT_Z * e_d),
                  "false_alarm": float(2 * _t_tail(DRIFT_Z, n - 1)),
                  "steady_from_s": None}
    return out


def _t_tail(z, dof):
    """P(T > z) for Student's t (scipy.stats, imported only for an ensemble's verdict)."""
    from scipy import stats
    return stats.t.sf(z, dof)
