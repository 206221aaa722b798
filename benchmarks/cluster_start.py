"""What a local dask cluster costs before any work: its start, the first tasks (each
worker importing what a chunk's unpickling imports: granavg.pipeline.on_dask) and its
close, as granavg's commands start it (granavg.dask_cluster.cluster_client).

    python benchmarks/cluster_start.py [WORKERS] [-n 3]
"""

import argparse
import statistics
import time


def touch(x):
    import granavg.pipeline.on_dask  # noqa: F401  (what a chunk's unpickling imports)
    return x


def once(workers: int) -> tuple:
    from granavg.dask_cluster import cluster_client

    t0 = time.perf_counter()
    with cluster_client(workers, None, 1) as jobs:
        t1 = time.perf_counter()
        jobs.gather([jobs.client.submit(touch, k, pure=False) for k in range(workers)])
        t2 = time.perf_counter()
    return t1 - t0, t2 - t1, time.perf_counter() - t2


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("workers", type=int, nargs="?", default=2)
    ap.add_argument("-n", type=int, default=3)
    args = ap.parse_args()
    runs = [once(args.workers) for _ in range(args.n)]
    for name, values in zip(("start", "first tasks", "close"), zip(*runs)):
        print(f"{name:<12} {statistics.median(values):.2f} s "
              f"({min(values):.2f} - {max(values):.2f})")
    print(f"{'in all':<12} {statistics.median(sum(r) for r in runs):.2f} s, "
          f"{args.workers} workers")
