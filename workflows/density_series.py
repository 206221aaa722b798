"""Fig. 5 as the paper made it: one scene at several area fractions, on one stiffness plot.

Usage::

    python workflows/density_series.py OUT [--fractions 0.80 0.8134 0.83] [--t-end 250]
                                           [--set KEY=VALUE ...] [--main 0.8134]

Same geometry, disk sizes and Omega; the disk counts are scaled (keeping the paper's
small:large ratio) so the disks cover each area fraction of the annulus. The runs go to
a dask cluster of two single-threaded workers (the paper's "different simulations"),
each is averaged over 20 and 60 rings from two rotations on, and ``granavg analyze``
reports the main fraction's run with the others as ``--density-series``: Fig. 5 shows
them all and the master-curve claim is decided on their collapse. Resumable.
"""

from __future__ import annotations

import argparse
import logging
import subprocess
import sys
from pathlib import Path

log = logging.getLogger("density")


def counts_for(fraction: float, base_fraction: float = 0.8134, n_small=2538, n_large=407):
    """Disk counts giving ``fraction`` with the paper's sizes and small:large ratio."""
    scale = fraction / base_fraction
    return int(round(n_small * scale)), int(round(n_large * scale))


def simulate_all(out: Path, fractions, t_end, sets):
    from dask.distributed import Client, as_completed

    from granavg.dask_cluster import local_cluster
    from granavg.sim.scene import area_fraction, preset
    from granavg.sim.simulate import simulate

    todo = {}
    for f in fractions:
        run = out / f"nu{f:.4f}"
        if (run / "manifest.json").exists():
            continue
        ns, nl = counts_for(f)
        scene = preset("paper-hooke").with_overrides([*sets, f"n_small={ns}", f"n_large={nl}",
                                                f"t_end={t_end}", "dump_dt=5",
                                                f"restart_dt={t_end}"])
        log.info("area fraction %.4f: %d + %d disks (%.4f)", f, ns, nl, area_fraction(scene))
        todo[run] = scene
    if not todo:
        return
    with local_cluster(2) as cluster, Client(cluster) as client:
        futures = {client.submit(simulate, s, str(r), progress=False, preset="paper-hooke",
                                 pure=False): r for r, s in todo.items()}
        for fut in as_completed(list(futures)):
            fut.result()
            log.info("%s complete", futures[fut])


def granavg(*args):
    proc = subprocess.run([sys.executable, "-m", "granavg", *map(str, args)])
    if proc.returncode:
        raise SystemExit(proc.returncode)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--fractions", type=float, nargs="+", default=[0.80, 0.8134, 0.83])
    ap.add_argument("--main", type=float, default=0.8134, help="the fraction reported in full")
    ap.add_argument("--t-end", type=float, default=250.0)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    simulate_all(args.out, args.fractions, args.t_end, args.sets)
    for f in args.fractions:
        for n in (20, 60):
            table = args.out / f"nu{f:.4f}" / f"profiles{n}.csv"
            if not table.exists():
                granavg("average", table.parent, "--bins", n, "--out", table, "--no-progress")
    main_run = args.out / f"nu{args.main:.4f}"
    others = [args.out / f"nu{f:.4f}" / "profiles20.csv" for f in args.fractions
              if f != args.main]
    report = args.out / "report"
    if not report.exists():
        granavg("analyze", main_run / "profiles20.csv", main_run / "profiles60.csv",
                "--out", report, "--density-series", *others)
    log.info("report: %s", report / "report.html")


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="density: %(message)s")
    main()
