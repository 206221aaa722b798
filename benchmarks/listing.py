"""Listing a plain dump's frames: a full read of no column against the header scan
(``DumpReader(..., headers_only=True)``, what the dask client cuts chunks from).

    python benchmarks/listing.py RUN_OR_DUMP [--repeat 30] [-n 5]

Builds a large plain dump from a run's atom dump (its frames repeated ``--repeat`` times
with shifted time steps, in a temporary directory), then lists it ``-n`` times each way,
alternating, in one process after a warm-up; prints the median seconds of each and
their ratio (the figure to quote).
"""

from __future__ import annotations

import argparse
import gzip
import statistics
import tempfile
import time
from pathlib import Path

from granavg.io.reader import DumpReader


def big_dump(source: Path, out: Path, repeat: int) -> int:
    """``source``'s frames ``repeat`` times, time steps shifted so that they increase;
    returns the number of frames written."""
    opener = gzip.open if source.suffix == ".gz" else open
    with opener(source, "rt") as fh:
        frames = ["ITEM: TIMESTEP" + f for f in fh.read().split("ITEM: TIMESTEP")[1:]]
    steps = [int(f.split()[2]) for f in frames]
    span = steps[-1] - steps[0] + (steps[1] - steps[0] if len(steps) > 1 else 1)
    with open(out, "w") as dst:
        for r in range(repeat):
            for f, s in zip(frames, steps):
                head, _, rest = f.split("\n", 2)
                dst.write(f"{head}\n{s + r * span}\n{rest}")
    return repeat * len(frames)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", type=Path, help="a run directory or an atom dump")
    ap.add_argument("--repeat", type=int, default=30)
    ap.add_argument("-n", type=int, default=5)
    args = ap.parse_args(argv)
    source = args.source / "atoms.dump.gz" if args.source.is_dir() else args.source
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.dump"
        n = big_dump(source, path, args.repeat)
        times = {False: [], True: []}
        for _ in range(args.n + 1):                      # the first round warms up
            for headers in (False, True):
                t0 = time.perf_counter()
                listed = sum(1 for _ in DumpReader(path, [], headers_only=headers))
                times[headers].append(time.perf_counter() - t0)
                assert listed == n
        full, scan = (statistics.median(times[h][1:]) for h in (False, True))
        print(f"{path.stat().st_size / 1e6:.0f} MB, {n} frames; median of {args.n}:")
        print(f"full read of no column  {full:.3f} s")
        print(f"header scan             {scan:.3f} s")
        print(f"full / scan             {full / scan:.2f}")


if __name__ == "__main__":
    main()
