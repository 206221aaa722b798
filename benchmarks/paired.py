"""Time two commands as whole processes, in turn, and their ratio pair by pair.

    python benchmarks/paired.py [-n 5] [--warmup 1] 'COMMAND A' 'COMMAND B'

Each command is one string run by ``sh -c`` (its output thrown away); after the warm-up
runs, A and B alternate ``-n`` times, so that a drift of the machine's speed hits both.
Prints the median (min - max) wall and CPU seconds of each (CPU: the children's user +
system time, from ``resource``) and of the ratios A/B of each pair: the figure to quote.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import time


def run(cmd: str) -> tuple[float, float]:
    """Wall and CPU seconds of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(["sh", "-c", cmd], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def row(name: str, values: list) -> str:
    return (f"{name:<10} {statistics.median(values):10.4g} "
            f"({min(values):.4g} - {max(values):.4g})")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("-n", type=int, default=5, help="counted pairs")
    ap.add_argument("--warmup", type=int, default=1, help="uncounted runs of each, first")
    args = ap.parse_args(argv)
    for _ in range(args.warmup):
        run(args.a), run(args.b)
    pairs = [(run(args.a), run(args.b)) for _ in range(args.n)]
    print(f"{args.n} pairs; median (min - max)")
    print(row("A wall s", [a[0] for a, _ in pairs]))
    print(row("B wall s", [b[0] for _, b in pairs]))
    print(row("A/B wall", [a[0] / b[0] for a, b in pairs]))
    print(row("A/B cpu", [a[1] / b[1] for a, b in pairs if b[1] > 0]))


if __name__ == "__main__":
    main()
