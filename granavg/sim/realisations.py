"""Ensembles: independent realisations of one scene, run on dask, one run directory each.

Realisation k shears its own random packing (seed ``scene.seed + SEED_STRIDE * k``; the
deck uses ``seed`` and ``seed + 1`` for the two disk sizes, so the stride keeps every
random stream distinct), or, for a scene with a shipped ``packing`` set, the sheared
packing grown from that seed. The runs are independent tasks on a dask cluster (a local one
of single-threaded processes by default, or ``scheduler``): there is no scheduler of
granavg's own. ``OUT/ensemble.json`` lists the runs and their status.
:func:`granavg.engine.combine.combine_runs` turns the profiles of the realisations
into ensemble profiles with between-run errors (``granavg average RUN [RUN ...]``).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from pathlib import Path


from granavg.dask_cluster import refusal_safe
from granavg.errors import ParameterError, UserError
from granavg.io.run_directory import claim_new
from granavg.sim import packings, trade
from granavg.sim.scene import Scene

log = logging.getLogger(__name__)

SEED_STRIDE = 7919
ENSEMBLE = "ensemble.json"


def seeds_for(scene: Scene, k: int) -> list:
    """The seeds of ``k`` realisations of ``scene``."""
    if k < 1:
        raise ParameterError("seeds", f"{{param}} {k}: need at least one realisation")
    return [scene.seed + SEED_STRIDE * i for i in range(k)]


@refusal_safe
def _one(scene_dict: dict, out: str, preset) -> str:
    """One dask task: simulate one realisation (single-threaded LAMMPS, no progress bar)."""
    from granavg.sim.simulate import simulate

    simulate(Scene.from_dict(scene_dict), out, progress=False, preset=preset)
    return out


def simulate_ensemble(scene: Scene, out, k: int, execution,
                      preset: str | None = None) -> list:
    """Simulate ``k`` independent realisations of ``scene`` into ``out/seed<N>/``.

    Parameters
    ----------
    scene : Scene
        The scene (SI units); only its ``seed`` differs between realisations.
    out : path
        A new directory; it receives one run directory per seed and ``ensemble.json``.
    k : int
        Number of realisations.
    execution : Execution
        Where the realisations run (:class:`granavg.pipeline.spec.Execution`): its
        ``workers``, the processes of the local dask cluster (one LAMMPS each; None: 2),
        or its ``scheduler``, the address of a dask scheduler whose workers see ``out``.
    preset : str, optional
        The preset's name, recorded.

    Returns
    -------
    list of Path
        The run directories, in seed order. A realisation that fails is reported after
        the others finished; the ones that completed are kept.
    """
    from granavg.dask_cluster import Refused, cluster_client

    seeds = seeds_for(scene, k)
    for s in seeds:
        dataclasses.replace(scene, seed=s).derive()      # refuse before any work
        if scene.packing:
            packings.check(scene.packing, s)
    workers, scheduler = execution.workers or 2, execution.scheduler
    if scheduler is None and workers < 1:
        raise ParameterError("workers", f"{{param}} {workers}: need at least one")
    out = claim_new(Path(out))
    forecast = trade.expectation(scene.derive(), prepared=bool(scene.packing))
    if "wall_time_s" in forecast:
        rounds = math.ceil(k / workers) if scheduler is None else None
        log.info("each realisation: %s%s", trade.describe(forecast), "" if rounds is None else
                 f"; {k} on {workers} workers: about {rounds * forecast['wall_time_s'] / 60:.1f} min")
    runs = [out / f"seed{s}" for s in seeds]
    record = {"scene": scene.to_dict(), "preset": preset, "seeds": seeds,
              "runs": {r.name: "running" for r in runs}}
    _write(out, record)
    failed = []
    with cluster_client(min(workers, k), scheduler) as dask_jobs:
        futures = {dask_jobs.client.submit(_one, dataclasses.replace(scene, seed=s).to_dict(),
                                           str(r), preset, pure=False): r
                   for s, r in zip(seeds, runs)}
        for fut in dask_jobs.completed(list(futures)):
            run = futures[fut]
            try:
                result = fut.result()
                if isinstance(result, Refused):
                    raise UserError(result.message)
                record["runs"][run.name] = "complete"
                log.info("realisation %s complete", run.name)
            except Exception as exc:                 # noqa: BLE001 - reported below
                record["runs"][run.name] = f"failed: {exc}"
                failed.append(f"{run.name}: {exc}")
            _write(out, record)
    if failed:
        raise UserError(f"{len(failed)} of {k} realisations failed ({failed[0]}); the "
                        f"others are complete in {out}")
    return runs


def _write(out: Path, record: dict) -> None:
    tmp = out / (ENSEMBLE + ".tmp")
    tmp.write_text(json.dumps(record, indent=2) + "\n")
    os.replace(tmp, out / ENSEMBLE)
