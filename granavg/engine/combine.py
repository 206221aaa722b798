"""Ensemble profiles: the profiles of independent realisations combined, with
between-run errors and the runs as replicates (SI units)."""

from __future__ import annotations

import warnings

import numpy as np

from granavg.engine.fields import Fields, columns_of
from granavg.engine.uncertainty.blocking import Replicates
from granavg.errors import UserError


def combine_runs(profiles: list, names: list) -> Fields:
    """Ensemble profiles from the profiles of independent realisations.

    Each value is the mean over the runs with a finite value in that ring, its ``_sem``
    the between-run standard error std/sqrt(n), but never below the error of that mean
    from the runs' own (within-run) errors, sqrt(sum sem_i^2)/n: with few runs the
    between-run estimate has n - 1 degrees of freedom and can come out far too small by
    chance (two runs that happen to agree in a ring), which would let that ring dominate
    every weighted fit. ``n_runs`` counts the runs with a disk in the ring. The
    replicates are the runs' own profiles, so derived numbers get between-run errors too.

    Parameters
    ----------
    profiles : list of Fields
        One per realisation, over the same rings and quantities.
    names : list of str
        The runs (for the sidecar).
    """
    import pandas as pd

    first = profiles[0]
    if first.species is not None:
        return _combine_species(profiles, names)
    if first.in_time:
        return _combine_in_time(profiles, names)
    for p, name in zip(profiles[1:], names[1:]):
        if p.cells.describe() != first.cells.describe():
            raise UserError(f"{name}: its rings differ from {names[0]}'s; an ensemble needs "
                            "runs of the same scene averaged over the same rings")
        if set(p.values) != set(first.values):
            raise UserError(f"{name}: its quantities differ from {names[0]}'s; average every "
                            "run with the same quantities")
    stacked = {k: np.stack([p.values[k] for p in profiles]) for k in first.values}
    reps = Replicates("runs", stacked)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN rings stay NaN
        values = {k: np.nanmean(v, axis=0) for k, v in stacked.items()}
    sem = {k: np.fmax(v, _within_run_error([p.sem[k] for p in profiles], stacked[k]))
           for k, v in reps.profile_errors().items()}
    n_runs = np.sum(np.isfinite(stacked["nu"]) & (stacked["nu"] > 0), axis=0) \
        if "nu" in stacked else np.full(first.cells.n, len(profiles))
    flags = np.array([";".join(sorted({f for p in profiles for f in str(p.flags[k]).split(";")
                                       if f and f not in ("sem_lower_bound", "few_replicas")}))
                      for k in range(first.cells.n)], dtype=object)
    meta = dict(first.meta)
    meta["runs"] = [{"run": name, "frames": p.meta.get("frames"), "seed":
                     (p.meta.get("run_manifest") or {}).get("scene", {}).get("seed"),
                     "stationarity": p.meta.get("stationarity")}
                    for name, p in zip(names, profiles)]
    meta.pop("stationarity", None)
    series = [p.timeseries.assign(run=name) for name, p in zip(names, profiles)
              if p.timeseries is not None]
    meta["errors"] = {"method": f"between-run standard error over {len(profiles)} independent "
                                "realisations (values are the mean over the runs), at least the "
                                "mean's error from the runs' own errors",
                      "lower_bound": {}}
    meta["frames"] = {**first.meta.get("frames", {}),
                      "n": int(sum(p.n_frames for p in profiles))}
    return Fields(first.cells, values, sem, flags, int(sum(p.n_frames for p in profiles)),
                    meta, reps, n_runs, columns_of(pd.concat(series, ignore_index=True))
                    if series else None)


def _combine_species(profiles: list, names: list) -> Fields:
    """Ensemble fields of a mixture: :func:`combine_runs` of each species (the runs'
    species the same), their concentrations and fluxes averaged over the runs with
    between-run errors."""
    first = profiles[0]
    for p, name in zip(profiles[1:], names[1:]):
        if p.species != first.species:
            raise UserError(f"{name}: its species ({', '.join(p.species or ())}) differ from "
                            f"{names[0]}'s ({', '.join(first.species)}); average every run "
                            "with the same species")
    parts = {s: combine_runs([p.of(s) for p in profiles], names) for s in first.species}
    meta = dict(parts[first.species[0]].meta)
    meta["species"] = {**first.meta.get("species", {}), "derived": "c and seg_<i> per run, "
                       "averaged over the runs with between-run errors"}
    return Fields.of_species(parts, meta)


def _combine_in_time(profiles: list, names: list) -> Fields:
    """Ensemble fields in time: :func:`combine_runs` at each time (the runs' fields at
    the same times: the same windows or kernel times)."""
    first = profiles[0]
    for p, name in zip(profiles[1:], names[1:]):
        if not p.in_time or len(p.times) != len(first.times) or \
                not np.allclose(p.times, first.times, rtol=0, atol=1e-9 * np.ptp(first.times)):
            raise UserError(f"{name}: its fields are not at {names[0]}'s times; an ensemble "
                            "in time needs every run averaged with the same windows or "
                            "times (the same t_min, windows or times)")
    each = [combine_runs([p.at(j) for p in profiles], names) for j in range(len(first.times))]
    meta = {**each[0].meta, "time": first.meta.get("time", {}),
            "frames": {**first.meta.get("frames", {}),
                       "n": int(sum(p.meta.get("frames", {}).get("n", 0) for p in profiles))}}
    return Fields.stack(each, first.times, first.time_edges, meta)


def _within_run_error(sems, values) -> np.ndarray:
    """Standard error of the mean over runs from each run's own errors, shape (n_rings,):
    sqrt(sum_i sem_i^2) / n over the runs with a finite value (NaN where none)."""
    sems = np.where(np.isfinite(values), np.stack(sems), np.nan)
    n = np.sum(np.isfinite(sems), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.nansum(sems**2, axis=0)) / np.where(n > 0, n, np.nan)

