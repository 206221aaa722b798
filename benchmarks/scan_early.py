"""Frames before --t-min scanned past against read and left out (the same dumps, the same
average, in one process; issue: --t-min skips cost a scan, not a parse).

    python benchmarks/scan_early.py RUN [--fraction 0.5] [-n 3]

RUN: a granavg run directory (e.g. one made by benchmarks/long_run.py: 600 frames), whose
atom and contact dumps are averaged as anyone's dumps would be (20 rings, every quantity),
plain and gzip, with t_min at ``--fraction`` of the frames' time span; each figure the
median of ``-n`` warm passes, the two settings in turn. Prints the seconds of each and
their ratio, and the time with t_min = 0 for scale.
"""

import argparse
import gzip
import logging
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.pipeline.dumps import dump_averager
from granavg.pipeline.spec import Spec


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--fraction", type=float, default=0.5)
    ap.add_argument("-n", type=int, default=3)
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    m = read_manifest(args.run)
    s, dt = m["scene"], m["derived"]["dt_s"]
    cells = dict(thickness=s["h"], bins=20, r_range=(s["R_i"], s["R_o"]), center=(0.0, 0.0))
    with tempfile.TemporaryDirectory() as tmp:
        plain = {}
        for name in ("atoms", "contacts"):
            plain[name] = Path(tmp) / f"{name}.dump"
            with gzip.open(args.run / f"{name}.dump.gz", "rb") as src, \
                    open(plain[name], "wb") as dst:
                shutil.copyfileobj(src, dst, 1 << 20)
        packed = {k: args.run / f"{k}.dump.gz" for k in ("atoms", "contacts")}
        steps = [h.timestep for h in DumpReader(plain["atoms"], [], headers_only=True)]
        first, last = steps[0] * dt, steps[-1] * dt
        t_min = first + args.fraction * (last - first)
        print(f"{len(steps)} frames; t_min at {args.fraction:.0%} of their span\n")
        print("| dumps | t_min = 0 s | scanned past s | read and left out s | scanned / read |"
              "\n|---|---|---|---|---|")
        for label, files in (("plain", plain), ("gzip", packed)):
            def once(t, scan):
                t0 = time.perf_counter()
                avg, _ = dump_averager(Spec.of(files["atoms"], contacts=files["contacts"],
                                               cells=cells, density=s["rho_p"], dt=dt,
                                               t_min=t), scan_early=scan)
                avg.run(False)
                return time.perf_counter() - t0
            once(t_min, True)                                          # warm
            times = {k: [] for k in ("zero", "scan", "read")}
            for _ in range(args.n):
                times["scan"].append(once(t_min, True))
                times["read"].append(once(t_min, False))
                times["zero"].append(once(0.0, True))
            med = {k: statistics.median(v) for k, v in times.items()}
            ratio = statistics.median(a / b for a, b in zip(times["scan"], times["read"]))
            print(f"| {label} | {med['zero']:.2f} | {med['scan']:.2f} | {med['read']:.2f} | "
                  f"{ratio:.2f} |")


if __name__ == "__main__":
    main()
