"""Make a set of shipped sheared packings (granavg.sim.packings) for a preset.

Usage::

    python workflows/sheared_packings.py OUT NAME [--preset paper-hooke] [--seeds 4]
                                         [--age 250] [--from SET] [--set key=value ...]
                                         [--workers 2] [--ship]

Grows K independent packings (seeds ``seed + 7919 k``, as ``granavg simulate --seeds K``),
or starts from the shipped set ``--from SET`` (its packing of the same seed), with the
preset's contact law and shears each for ``--age`` s (dumps every 5 s, so that
the ageing can be seen), ``--workers`` runs at a time on a local dask cluster, into
``OUT/seed<N>/``; a seed whose complete run is already there (same scene) is not run
again. Each run is then averaged (20 rings) for its state over the last 100 s.
``--ship`` gzips every run's ``sheared.data`` into ``granavg/sim/packings/NAME/
seed<N>.data.gz`` and writes ``provenance.json`` there: the command, the law, the age
and each packing's end state (bulk coordination, rattler fraction, bulk pressure in Pa,
share of hexatically ordered bulk disks).
"""

from __future__ import annotations

import argparse
import gzip
import json
import logging
import shutil
import sys
from pathlib import Path

log = logging.getLogger("packings")
END_STATE = ["C_bulk", "rattler_fraction", "P_bulk_Pa", "psi6_bulk_ordered"]


def end_state(run: Path, age: float) -> dict:
    """Means over the last 100 s of the run's time series (SI units)."""
    from granavg.pipeline.runs import average_run

    t0 = max(0.0, age - 100.0)
    ts = average_run(run, bins=20, t_min=t0, quantities=["coordination", "sigma"]).timeseries
    ts = ts[ts.t_s >= t0]
    return {q: round(float(ts[q].mean()), 4) for q in END_STATE if q in ts}


def done(run: Path, scene) -> bool:
    """A complete run of this scene is in ``run`` (the same values, up to the averaging
    window's ``discard_rotations``, which does not change a run)."""
    manifest = run / "manifest.json"
    if not manifest.exists():
        return False
    from granavg.sim.scene import Scene

    m = json.loads(manifest.read_text())
    have = Scene.from_dict(m["scene"]).to_dict()      # keys added since: their defaults
    want = {k: v for k, v in scene.to_dict().items() if k != "discard_rotations"}
    return m.get("status") == "complete" and all(have.get(k) == v for k, v in want.items())


def simulate_missing(out: Path, scenes: dict, preset: str, workers: int = 2) -> None:
    from dask.distributed import Client, as_completed

    from granavg.dask_cluster import local_cluster
    from granavg.sim.simulate import simulate

    todo = {run: s for run, s in scenes.items() if not done(run, s)}
    if not todo:
        return
    with local_cluster(min(workers, len(todo))) as cluster, Client(cluster) as client:
        futures = {client.submit(simulate, s, str(r), progress=False, preset=preset,
                                 pure=False): r for r, s in todo.items()}
        for fut in as_completed(list(futures)):
            fut.result()
            log.info("%s complete", futures[fut])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path, help="directory of the runs (created, or reused)")
    ap.add_argument("name", help="name of the packing set")
    ap.add_argument("--preset", default="paper-hooke")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--age", type=float, default=250.0, help="seconds of shear")
    ap.add_argument("--from", dest="start", default="",
                    help="start from this shipped packing set instead of growing")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    ap.add_argument("--workers", type=int, default=2, help="runs at a time")
    ap.add_argument("--ship", action="store_true", help="copy into granavg/sim/packings/NAME")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")

    import dataclasses

    from granavg.sim import packings
    from granavg.sim.realisations import seeds_for
    from granavg.sim.run_layout import SHEARED
    from granavg.sim.scene import preset

    if args.start:
        packings.seeds(args.start)                      # refuses an unknown set up front
    scene = preset(args.preset).with_overrides(
        [f"packing={args.start}", f"t_end={args.age}", "dump_dt=5", "restart_dt=50",
         *args.overrides])
    args.out.mkdir(parents=True, exist_ok=True)
    scenes = {args.out / f"seed{s}": dataclasses.replace(scene, seed=s)
              for s in seeds_for(scene, args.seeds)}
    simulate_missing(args.out, scenes, args.preset, args.workers)
    record = {
        "made_by": "python workflows/sheared_packings.py "
                   + " ".join(sys.argv[1:] if argv is None else argv),
        "preset": args.preset, "overrides": args.overrides,
        "aged_s": args.age + (packings.provenance(args.start)["aged_s"] if args.start else 0.0),
        **({"started_from": args.start} if args.start else {}),
        "law": scene.derive().coeffs.pair_style + f" (mu {scene.law.mu}, mu_wall "
               f"{scene.law.mu_wall}, mu_roll {scene.law.mu_roll})"
               + (f"; base-plate friction mu_base {scene.mu_base}, v_base {scene.v_base} m/s"
                  if scene.mu_base else ""),
        "units": "SI (Pa)",
        "end_state_last_100_s": {r.name: end_state(r, args.age) for r in scenes},
    }
    print(json.dumps(record, indent=1))
    if args.ship:
        target = packings.HERE / args.name
        target.mkdir(exist_ok=True)
        for r in scenes:
            with open(r / SHEARED, "rb") as src, \
                    gzip.open(target / f"{r.name}.data.gz", "wb") as dst:
                shutil.copyfileobj(src, dst)
        (target / "provenance.json").write_text(json.dumps(record, indent=1) + "\n")
        log.info("shipped %d packings into %s", len(scenes), target)
    return 0


if __name__ == "__main__":
    sys.exit(main())
