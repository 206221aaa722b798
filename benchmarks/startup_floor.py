"""What the start-up leaves for the work: the fixed costs of a `granavg average` process
against `zcat` of its dumps, and the warm in-process times of the work itself.

    python benchmarks/startup_floor.py RUN

RUN: a paper-cell run directory (granavg simulate --preset paper ...). Each process is
timed whole, the median of five; the in-process times are medians of five warm passes
(numba's start paid, files in the page cache). Prints each step, then what the two
short-run aims of the speed issue would need: `granavg average` within 2.5 times `zcat`,
and `--quantities nu,v` within half the time of all quantities, start-up included.
"""

import logging
import statistics
import subprocess
import sys
import time
from pathlib import Path

FIRST_CALL = ("import numpy as np, numba; from granavg.io.parse import count_newlines; "
              "count_newlines(np.zeros(1, np.uint8), 0, 1)")
STEPS = [("python -c pass", [sys.executable, "-c", "pass"]),
         ("+ import numpy", [sys.executable, "-c", "import numpy"]),
         ("+ import numba", [sys.executable, "-c", "import numpy, numba"]),
         ("+ numba's first call of a cached kernel", [sys.executable, "-c", FIRST_CALL])]


def wall(cmd, n=5, **kw) -> float:
    times = []
    for _ in range(n):
        t = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, **kw)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main(run):
    from granavg.pipeline.runs import run_averager
    run = Path(run)
    logging.disable(logging.CRITICAL)

    def work(quantities):
        t = time.perf_counter()
        run_averager(run, bins=20, quantities=quantities).run(False)
        return time.perf_counter() - t

    work(None), work(["nu", "v"])                               # warm
    full = statistics.median(work(None) for _ in range(5))
    nuv = statistics.median(work(["nu", "v"]) for _ in range(5))
    steps = {name: wall(cmd) for name, cmd in STEPS}
    zcat = wall(f"zcat {run}/atoms.dump.gz {run}/contacts.dump.gz", shell=True)
    print("| step | wall s (median of 5) |\n|---|---|")
    for name, t in steps.items():
        print(f"| {name} | {t:.3f} |")
    print(f"| zcat of both dumps | {zcat:.3f} |")
    print(f"| in process, warm: all quantities | {full:.3f} |")
    print(f"| in process, warm: --quantities nu,v | {nuv:.3f} |")
    numba = steps["+ numba's first call of a cached kernel"]
    bare = steps["+ import numpy"]
    print(f"\nnumba's start-up alone / zcat: {numba / zcat:.2f} (the aim for the whole: 2.5)")
    print(f"with numba's start-up: whole / zcat >= {(numba + full) / zcat:.2f}, "
          f"nu,v / all >= {(numba + nuv) / (numba + full):.2f}")
    print(f"with Python and numpy only: whole / zcat >= {(bare + full) / zcat:.2f}, "
          f"nu,v / all >= {(bare + nuv) / (bare + full):.2f}")


if __name__ == "__main__":
    main(sys.argv[1])
