"""What the start-up leaves for the work: the fixed costs of a `granavg average` process
against `zcat` of its dumps, and the warm in-process times of the work itself.

    python benchmarks/startup_floor.py RUN

RUN: a paper-cell run directory (granavg simulate --preset paper ...). Each process is
timed whole, the median of five; the in-process times are medians of five warm passes
(files in the page cache). Prints each step, then the floors that the start-up sets
for `granavg average` against `zcat` and for `--quantities nu,v` against all quantities.
The kernels are compiled at install (Cython): no step compiles or loads a JIT.
"""

import logging
import statistics
import subprocess
import sys
import time
from pathlib import Path

STEPS = [("python -c pass", [sys.executable, "-c", "pass"]),
         ("+ import numpy", [sys.executable, "-c", "import numpy"]),
         ("+ granavg's engine and reader (compiled kernels)",
          [sys.executable, "-c", "import granavg.engine.cell_average, granavg.io.reader"]),
         ("+ everything `granavg average` imports",
          [sys.executable, "-c", "import granavg.cli, granavg.pipeline.averaging"])]


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
    start = steps["+ everything `granavg average` imports"]
    print(f"\nstart-up / zcat: {start / zcat:.2f}")
    print(f"with the start-up: whole / zcat >= {(start + full) / zcat:.2f}, "
          f"nu,v / all >= {(start + nuv) / (start + full):.2f}")


if __name__ == "__main__":
    main(sys.argv[1])
