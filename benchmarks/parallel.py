"""Speed-up of averaging on a local dask cluster against the serial pass, same run.

    python benchmarks/parallel.py RUN_DIR [WORKERS ...]     # default: 1 2

Prints a markdown table: wall time of ``average_run`` (serial, in this process) and of
``average_run_dask`` with N worker processes, once cold (cluster start-up, worker
imports included) and once on the warm cluster; the speed-up ratios against serial,
each chunk's peak RSS, and whether the profiles are identical to the serial ones.
"""

from __future__ import annotations

import resource
import sys
import time

import numpy as np

from granavg.pipeline.runs import average_run
from granavg.dask_cluster import local_cluster
from granavg.pipeline.on_dask import average_run_dask


def identical(a, b) -> bool:
    return all(np.array_equal(a.values[q], b.values[q], equal_nan=True) and
               np.array_equal(a.sem[q], b.sem[q], equal_nan=True) for q in a.values)


def main(run, workers=(1, 2)):
    t0 = time.perf_counter()
    serial = average_run(run, progress=False)
    t_serial = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{serial.n_frames} frames, 20 rings, all quantities\n")
    print("| mode | wall s | speed-up | peak RSS per process (MB) | identical |")
    print("|---|---|---|---|---|")
    print(f"| serial | {t_serial:.1f} | 1.00 | {rss:.0f} | - |")
    from dask.distributed import Client

    for n in workers:
        t0 = time.perf_counter()
        cluster = local_cluster(n)
        with Client(cluster) as client:
            cold = average_run_dask(run, client=client, chunks=2 * n)
            t_cold = time.perf_counter() - t0
            t0 = time.perf_counter()
            par = average_run_dask(run, client=client, chunks=2 * n)
            t = time.perf_counter() - t0
        cluster.close()
        mem = max(par.meta["dask"]["peak_rss_bytes_per_chunk"]) / 2**20
        ok = identical(serial, par) and identical(serial, cold)
        print(f"| dask, {n} worker(s), {2 * n} chunks, cold | {t_cold:.1f} | "
              f"{t_serial / t_cold:.2f} | {mem:.0f} | {ok} |")
        print(f"| dask, {n} worker(s), {2 * n} chunks, warm | {t:.1f} | "
              f"{t_serial / t:.2f} | {mem:.0f} | {ok} |")

if __name__ == "__main__":
    main(sys.argv[1], tuple(int(a) for a in sys.argv[2:]) or (1, 2))
