"""The engine pass on 1 thread against N threads: the same frames, in memory, CPU-bound.

    python benchmarks/engine_threads.py DUMP [--grid 20 20 6] [--frames 2] [-n 5]
                                             [--threads 1 2]

DUMP: a 3D LAMMPS dump (``benchmarks/big_3d.py make DIR`` writes DIR/big.dump, about a
million spheres a frame). Its first ``--frames`` frames are read once; then the engine's
per-frame sums (:func:`granavg.engine.frame_sums.frame_sums`, every quantity the dump
allows, over a box grid) run over them on each thread count in turn, ``-n`` rounds.
Prints the median (min - max) seconds per frame of each count and the median of the
rounds' ratios (1 thread / N threads), with the sums' largest difference between the
counts (0: bit-identical).
"""

import argparse
import logging
import statistics
import time
from pathlib import Path

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dump", type=Path)
    ap.add_argument("--grid", type=int, nargs=3, default=(20, 20, 6))
    ap.add_argument("--frames", type=int, default=2)
    ap.add_argument("-n", type=int, default=5)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    from granavg.engine import threads
    from granavg.engine.frame_sums import frame_sums
    from granavg.pipeline.dumps import dump_averager
    from granavg.pipeline.spec import Spec

    avg, source = dump_averager(Spec.of(args.dump, cells={"grid": list(args.grid)}, dt=1.0))
    frames = []
    for frame in source:
        frames.append(frame)
        if len(frames) == args.frames:
            break
    n_particles = len(frames[0].atoms["radius"])

    def one_pass(k):
        threads.set_count(k)
        t0 = time.perf_counter()
        sums = [frame_sums(f, avg.cells, avg.rho_p, avg.channels, avg.averaging.reach, avg.k_fine)
                for f in frames]
        return (time.perf_counter() - t0) / len(frames), sums

    reference = {k: one_pass(k)[1] for k in args.threads}               # warm
    times = {k: [] for k in args.threads}
    for _ in range(args.n):
        for k in args.threads:
            times[k].append(one_pass(k)[0])
    base = args.threads[0]
    print(f"{n_particles} particles a frame, {len(frames)} frames, grid "
          f"{' x '.join(map(str, args.grid))}, {avg.layout.n} channels, "
          f"{threads.cores()} cores")
    print(f"| threads | s per frame | {base} thread / N |\n|---|---|---|")
    for k, t in times.items():
        ratio = [a / b for a, b in zip(times[base], t)]
        diff = max(float(np.max(np.abs(a - b))) for a, b in zip(reference[base], reference[k]))
        print(f"| {k} | {statistics.median(t):.3f} ({min(t):.3f}-{max(t):.3f}) | "
              f"{statistics.median(ratio):.2f} ({min(ratio):.2f}-{max(ratio):.2f}); sums "
              f"differ by {diff:g} |")


if __name__ == "__main__":
    main()
