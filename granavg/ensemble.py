"""Ensembles: independent realisations of one scene, run on dask, one run directory each.

Realisation k shears its own random packing (seed ``scene.seed + SEED_STRIDE * k``; the
deck uses ``seed`` and ``seed + 1`` for the two disk sizes, so the stride keeps every
random stream distinct). The runs are independent tasks on a dask cluster (a local one
of single-threaded processes by default, or ``scheduler``): there is no scheduler of
granavg's own. ``OUT/ensemble.json`` lists the runs and their status.
:func:`combine_runs` turns the profiles of the realisations into ensemble profiles with
between-run errors (``granavg average RUN [RUN ...]``).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import UserError
from .rundir import claim_new
from .scene import Scene

log = logging.getLogger(__name__)

SEED_STRIDE = 7919
ENSEMBLE = "ensemble.json"


def seeds_for(scene: Scene, k: int) -> list:
    """The seeds of ``k`` realisations of ``scene``."""
    if k < 1:
        raise UserError(f"--seeds {k}: need at least one realisation")
    return [scene.seed + SEED_STRIDE * i for i in range(k)]


def _one(scene_dict: dict, out: str, preset, quantities) -> str:
    """One dask task: simulate one realisation (single-threaded LAMMPS, no progress bar)."""
    from .simulate import simulate

    simulate(Scene.from_dict(scene_dict), out, progress=False, preset=preset,
             quantities=quantities)
    return out


def simulate_ensemble(scene: Scene, out, k: int, *, workers: int = 2,
                      scheduler: str | None = None, preset: str | None = None,
                      quantities=None) -> list:
    """Simulate ``k`` independent realisations of ``scene`` into ``out/seed<N>/``.

    Parameters
    ----------
    scene : Scene
        The scene (SI units); only its ``seed`` differs between realisations.
    out : path
        A new directory; it receives one run directory per seed and ``ensemble.json``.
    k : int
        Number of realisations.
    workers : int
        Processes of the local dask cluster (one LAMMPS each); ignored with ``scheduler``.
    scheduler : str, optional
        Address of a dask scheduler whose workers see ``out``.

    Returns
    -------
    list of Path
        The run directories, in seed order. A realisation that fails is reported after
        the others finished; the ones that completed are kept.
    """
    from dask.distributed import Client, as_completed

    from .parallel import local_cluster

    seeds = seeds_for(scene, k)
    for s in seeds:
        dataclasses.replace(scene, seed=s).derive()      # refuse before any work
    if scheduler is None and workers < 1:
        raise UserError(f"--workers {workers}: need at least one")
    out = claim_new(Path(out))
    runs = [out / f"seed{s}" for s in seeds]
    record = {"scene": scene.to_dict(), "preset": preset, "seeds": seeds,
              "runs": {r.name: "running" for r in runs}}
    _write(out, record)
    cluster = None if scheduler else local_cluster(min(workers, k))
    failed = []
    try:
        with Client(scheduler or cluster) as client:
            futures = {client.submit(_one, dataclasses.replace(scene, seed=s).to_dict(),
                                     str(r), preset, quantities, pure=False): r
                       for s, r in zip(seeds, runs)}
            for fut in as_completed(list(futures)):
                run = futures[fut]
                try:
                    fut.result()
                    record["runs"][run.name] = "complete"
                    log.info("realisation %s complete", run.name)
                except Exception as exc:                 # noqa: BLE001 - reported below
                    record["runs"][run.name] = f"failed: {exc}"
                    failed.append(f"{run.name}: {exc}")
                _write(out, record)
    finally:
        if cluster is not None:
            cluster.close()
    if failed:
        raise UserError(f"{len(failed)} of {k} realisations failed ({failed[0]}); the "
                        f"others are complete in {out}")
    return runs


def _write(out: Path, record: dict) -> None:
    tmp = out / (ENSEMBLE + ".tmp")
    tmp.write_text(json.dumps(record, indent=2) + "\n")
    os.replace(tmp, out / ENSEMBLE)


def combine_runs(profiles: list, names: list) -> "RingProfiles":
    """Ensemble profiles from the profiles of independent realisations.

    Each value is the mean over the runs with a finite value in that ring, its ``_sem``
    the between-run standard error std/sqrt(n); ``n_runs`` counts the runs with a disk
    in the ring. The replicates are the runs' own profiles, so derived numbers get
    between-run errors too.

    Parameters
    ----------
    profiles : list of RingProfiles
        One per realisation, over the same rings and quantities.
    names : list of str
        The runs (for the sidecar).
    """
    from .average import RingProfiles
    from .uncertainty import Replicates

    first = profiles[0]
    for p, name in zip(profiles[1:], names[1:]):
        if not np.array_equal(p.rings.edges, first.rings.edges) or p.rings.h != first.rings.h:
            raise UserError(f"{name}: its rings differ from {names[0]}'s; an ensemble needs "
                            "runs of the same scene averaged over the same rings")
        if set(p.values) != set(first.values):
            raise UserError(f"{name}: its quantities differ from {names[0]}'s; average every "
                            "run with the same --quantities")
    stacked = {k: np.stack([p.values[k] for p in profiles]) for k in first.values}
    reps = Replicates("runs", stacked)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN rings stay NaN
        values = {k: np.nanmean(v, axis=0) for k, v in stacked.items()}
    sem = reps.profile_errors()
    n_runs = np.sum(np.isfinite(stacked["nu"]) & (stacked["nu"] > 0), axis=0) \
        if "nu" in stacked else np.full(first.rings.n, len(profiles))
    flags = np.array([";".join(sorted({f for p in profiles for f in str(p.flags[k]).split(";")
                                       if f and f != "sem_lower_bound"}))
                      for k in range(first.rings.n)], dtype=object)
    meta = dict(first.meta)
    meta["runs"] = [{"run": name, "frames": p.meta.get("frames"), "seed":
                     (p.meta.get("run_manifest") or {}).get("scene", {}).get("seed"),
                     "stationarity": p.meta.get("stationarity")}
                    for name, p in zip(names, profiles)]
    meta.pop("stationarity", None)
    series = [p.timeseries.assign(run=name) for name, p in zip(names, profiles)
              if p.timeseries is not None]
    meta["errors"] = {"method": f"between-run standard error over {len(profiles)} independent "
                                "realisations (values are the mean over the runs)",
                      "lower_bound": {}}
    meta["frames"] = {**first.meta.get("frames", {}),
                      "n": int(sum(p.n_frames for p in profiles))}
    return RingProfiles(first.rings, values, sem, flags, int(sum(p.n_frames for p in profiles)),
                        meta, reps, n_runs, pd.concat(series, ignore_index=True) if series
                        else None)


def average_runs(run_dirs, average, **options):
    """Average several runs with ``average(run_dir, **options)`` and combine them
    (:func:`combine_runs`); one run gives its own profiles unchanged."""
    profiles = [average(d, **options) for d in run_dirs]
    if len(profiles) == 1:
        return profiles[0]
    seeds = [(p.meta.get("run_manifest") or {}).get("scene", {}).get("seed") for p in profiles]
    if len(set(seeds)) < len(seeds):
        log.warning("some runs share a seed (%s): they are not independent realisations "
                    "unless their packings differ otherwise", seeds)
    return combine_runs(profiles, [str(d) for d in run_dirs])
