"""One smoothing-kernel average of a shipped example, by node kind, for timing the
compiled loops as a whole process (the kernel's share dominates):

    python benchmarks/smoothing_cases.py CASE [--save FILE] [--repeat N] [--workers N]

CASE: ``grid`` (3D pile, Lucy, 4 x 4 x 6 points), ``planes`` (3D pile, Gauss, 12 slab
planes), ``shells`` (3D pile, Lucy, 4 x 3 circles), ``rings`` (2D Couette cell, Lucy, 8
circles), ``polar`` (2D Couette cell, Lucy, a 4 x 8 polar lattice), ``species`` (the
rings, each disk type's partial fields: the contacts between species at their points);
fields in time of the rings: ``rings_times`` (Lucy in time, 5 times), ``rings_gauss``
(Gauss in space and time, 12 circles, 3 times), ``rings_windows`` (windows of 0.5 s);
every quantity the data allow, the branch segments' line integrals included. ``--save``: the fields'
values and errors as .npz, to
compare two builds (e.g. ``PYTHONPATH=OTHER python benchmarks/smoothing_cases.py ...``,
OTHER a worktree of another version). ``--repeat N``: the average N more times in the
same process, and the median of their seconds printed (the loops warm: what the kernels
take, without the start-up). ``--workers N``: on a local dask cluster of N workers
(with ``GRANAVG_COST_MODEL=off`` it always starts, two chunks per worker).
"""

import argparse
import logging
import statistics
import time

import numpy as np

import granavg

PILE = dict(contacts=granavg.examples.pile_3d.contacts,
            contact_map=granavg.examples.pile_3d.contact_map, gravity=(0, 0, -9.81))
CASES = {
    "grid": (granavg.examples.pile_3d.atoms, dict(
        PILE, cells={"grid": (4, 4, 6), "z_range": (0, 0.024)}, kernel="lucy", width=0.004)),
    "planes": (granavg.examples.pile_3d.atoms, dict(
        PILE, cells={"slabs": "z", "range": (0, 0.024), "bins": 12}, kernel="gauss",
        width=0.003)),
    "shells": (granavg.examples.pile_3d.atoms, dict(
        PILE, cells={"r_range": (0.001, 0.007), "bins": 4, "center": (0.008, 0.008),
                     "layers": 3, "z_range": (0, 0.012)}, kernel="lucy", width=0.003)),
    "rings": (granavg.examples.couette_2d.run, dict(cells={"bins": 8}, t_min=1.0,
                                                    kernel="lucy", width=0.008)),
    "polar": (granavg.examples.couette_2d.run, dict(cells={"polar_grid": (4, 8)}, t_min=1.0,
                                                    kernel="lucy", width=0.008)),
    "species": (granavg.examples.couette_2d.run, dict(cells={"bins": 8}, t_min=1.0,
                                                      kernel="lucy", width=0.008,
                                                      species="type")),
    "rings_times": (granavg.examples.couette_2d.run, dict(
        cells={"bins": 8}, t_min=0.0, kernel="lucy", width=0.004, time_kernel="lucy",
        time_width=0.5, times=(0.5, 2.5, 0.5))),
    "rings_gauss": (granavg.examples.couette_2d.run, dict(
        cells={"bins": 12}, t_min=0.0, kernel="gauss", width=0.006, time_kernel="gauss",
        time_width=0.3, times=(1.0, 2.0, 0.5))),
    "rings_windows": (granavg.examples.couette_2d.run, dict(
        cells={"bins": 8}, t_min=0.5, kernel="lucy", width=0.008, windows=0.5)),
}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", choices=sorted(CASES))
    ap.add_argument("--save")
    ap.add_argument("--repeat", type=int, default=0)
    ap.add_argument("--workers", type=int)
    args = ap.parse_args(argv)
    logging.disable(logging.WARNING)
    source, options = CASES[args.case]
    if args.workers:
        options = dict(options, workers=args.workers)
    fields = granavg.average(source, **options)
    took = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        granavg.average(source, **options)
        took.append(time.perf_counter() - t0)
    if took:
        print(f"{args.case}: {statistics.median(took):.4f} s per average (median of "
              f"{len(took)}, warm)")
    if args.save:
        np.savez(args.save, **{k: np.asarray(v, float) for k, v in fields.values.items()},
                 **{f"sem_{k}": np.asarray(v, float) for k, v in fields.sem.items()})


if __name__ == "__main__":
    main()
