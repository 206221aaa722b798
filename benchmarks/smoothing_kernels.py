"""Each compiled loop of the smoothing kernels on its own, warm, on the same seeded
inputs: seconds per call (median of repeats), for comparing two builds in turn:

    python benchmarks/smoothing_kernels.py [--repeat 15]
    PYTHONPATH=OTHER python benchmarks/smoothing_kernels.py      # another version

The loops: ``point_pairs`` and ``point_segment_pairs`` (3D grid, Lucy), ``moments_at``
(circle moments with derivatives), ``ring_pairs`` and ``ring_segment_pairs`` (2D ring
tables), ``shell_pairs`` and ``shell_segment_pairs`` (3D shells), ``mixed`` (the turned
sums). Before the loops were compiled ahead of time they were numba functions of
``points``, ``circles`` and ``rotation``; this script finds them in either place.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from granavg.engine import smoothing
from granavg.engine.smoothing.circles import RingTables

try:
    from granavg.engine.smoothing import _kernels as K_
    LOOPS = {n: getattr(K_, n) for n in ("point_pairs", "point_segment_pairs", "moments_at",
                                         "ring_pairs", "ring_segment_pairs", "shell_pairs",
                                         "shell_segment_pairs", "mixed")}
except ImportError:                           # an earlier version: numba's functions
    from granavg.engine.smoothing import circles, points, rotation
    LOOPS = {"point_pairs": points.point_pairs,
             "point_segment_pairs": points.point_segment_pairs,
             "moments_at": circles.moments_at, "ring_pairs": circles.ring_pairs,
             "ring_segment_pairs": circles.ring_segment_pairs,
             "shell_pairs": circles.shell_pairs,
             "shell_segment_pairs": circles.shell_segment_pairs, "mixed": rotation.mixed}


def inputs(n=20000, pairs=200000, seed=1):
    """Seeded particles, segments, nodes and pairs of each loop's size."""
    rng = np.random.default_rng(seed)
    kern = smoothing.get("lucy")
    c = 0.004
    x = rng.uniform(0, 0.016, (n, 3))
    l = rng.normal(0, 0.0005, (n, 3))
    grid = np.stack(np.meshgrid(*(np.linspace(0, 0.016, 8),) * 3, indexing="ij"),
                    -1).reshape(-1, 3)
    basis = np.ascontiguousarray(np.broadcast_to(np.eye(3), (len(grid), 3, 3)))
    item = rng.integers(0, n, pairs).astype(np.int64)
    node = rng.integers(0, len(grid), pairs).astype(np.int64)
    radii = np.linspace(0.002, 0.007, 6)
    heights = np.linspace(0.0, 0.012, 4)
    tables = RingTables(kern, c, radii).arrays()
    ring_node = rng.integers(0, len(radii), pairs).astype(np.int64)
    shell_node = rng.integers(0, len(radii) * len(heights), pairs).astype(np.int64)
    return dict(kern=kern, c=c, x=x, l=l, grid=grid, basis=basis, item=item, node=node,
                radii=radii, heights=heights, tables=tables, ring_node=ring_node,
                shell_node=shell_node, rng=rng)


def calls(d):
    """Each loop's call on the inputs (fresh outputs each time)."""
    K, c, x, l, item = d["kern"].packed, d["c"], d["x"], d["l"], d["item"]
    s3, s2 = d["kern"].norms[3] / c ** 3, d["kern"].norms[2] / c ** 2
    P = len(item)
    cx = cy = 0.008
    xs, ys, zs = (np.ascontiguousarray(x[:, j]) for j in range(3))
    ls = [np.ascontiguousarray(l[:, j]) for j in range(3)]
    few = slice(0, P // 20)                      # the segments' loops are the slow ones
    rng = np.random.default_rng(2)
    q = rng.normal(size=(len(x), 30))
    W5 = rng.normal(size=(P, 5))
    t_out = rng.integers(0, 30, 60).astype(np.int64)
    t_in = rng.integers(0, 30, 60).astype(np.int64)
    t_m = rng.integers(0, 5, 60).astype(np.int64)
    t_f = rng.normal(size=60)
    sector = rng.integers(0, 4, (len(x), 3)).astype(np.int64)
    share = rng.dirichlet(np.ones(3), len(x))
    n_nodes = len(d["radii"]) * len(d["heights"])
    return {
        "point_pairs": lambda: LOOPS["point_pairs"](
            x, d["grid"], d["basis"], item, d["node"], K, s3, c, True, np.zeros(P),
            np.zeros((P, 3))),
        "point_segment_pairs": lambda: LOOPS["point_segment_pairs"](
            x, l, d["grid"], item[few], d["node"][few], K, s3, c, np.zeros(P // 20)),
        "moments_at": lambda: LOOPS["moments_at"](
            K, s3, c, np.hypot(xs - cx, ys - cy)[:5000], zs[:5000] - 0.006,
            np.full(5000, 0.004), True),
        "ring_pairs": lambda: LOOPS["ring_pairs"](
            xs, ys, cx, cy, *d["tables"], item, d["ring_node"], True, np.zeros((P, 5)),
            np.zeros((P, 5, 2))),
        "ring_segment_pairs": lambda: LOOPS["ring_segment_pairs"](
            xs, ys, ls[0], ls[1], cx, cy, *d["tables"], 0.1, item[few],
            d["ring_node"][few], np.zeros((P // 20, 5))),
        "shell_pairs": lambda: LOOPS["shell_pairs"](
            xs, ys, zs, cx, cy, d["radii"], d["heights"], len(d["heights"]), item[few],
            d["shell_node"][few], K, s3, c, True, np.zeros((P // 20, 5)),
            np.zeros((P // 20, 5, 3))),
        "shell_segment_pairs": lambda: LOOPS["shell_segment_pairs"](
            xs, ys, zs, *ls, cx, cy, d["radii"], d["heights"], len(d["heights"]),
            item[:P // 200], d["shell_node"][:P // 200], K, s3, c, 0.1,
            np.zeros((P // 200, 5))),
        "mixed": lambda: LOOPS["mixed"](
            item, d["ring_node"], W5, q, t_out, t_in, t_m, t_f, sector, share, 4,
            np.zeros((len(d["radii"]) * 4, 30))),
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args(argv)
    for name, call in calls(inputs()).items():
        call()                                   # warm (numba: compiled or loaded)
        took = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            call()
            took.append(time.perf_counter() - t0)
        print(f"{name:22s} {statistics.median(took) * 1e3:9.3f} ms")


if __name__ == "__main__":
    main()
