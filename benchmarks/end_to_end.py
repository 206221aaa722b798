"""End-to-end time of a preset: simulate, average over 20 and 60 rings, analyse (issue 14).

    python benchmarks/end_to_end.py OUT PRESET [SEEDS] [WORKERS] [--set KEY=VALUE ...]

Runs the real CLI as a user would: ``granavg simulate --preset PRESET`` (with
``--seeds SEEDS --workers WORKERS`` for an ensemble, default 1 realisation, and the
scene changes ``--set`` passed on), ``granavg average`` over 20 and 60
rings (the realisations combined) and ``granavg analyze``. Prints a markdown table: the
wall time of each phase and of the whole, and the ratio of the whole to the LAMMPS steps
of the same run (the baseline, from the runs' own timing records: the time LAMMPS spent
stepping, summed over realisations and divided by the workers), with where the rest went
(frames taken from LAMMPS, averaging, analysis and figures, start-up).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path


def granavg(*args) -> float:
    """Run ``granavg ARGS`` (no progress bar) and return its wall time (s)."""
    quiet = [] if args[0] == "analyze" else ["--no-progress"]
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "granavg", *map(str, args), *quiet], check=True)
    return time.perf_counter() - t0


def main(out, preset, seeds=1, workers=2, changes=()):
    out = Path(out)
    sim = out / "run"
    ensemble = ["--seeds", seeds, "--workers", workers] if seeds > 1 else []
    sets = [a for c in changes for a in ("--set", c)]
    t_sim = granavg("simulate", "--preset", preset, "--out", sim, *ensemble, *sets)
    runs = sorted(sim.glob("seed*")) if seeds > 1 else [sim]
    t_avg = sum(granavg("average", *runs, "--bins", n, "--out", out / f"profiles{n}.csv")
                for n in (20, 60))
    t_ana = granavg("analyze", out / "profiles20.csv", out / "profiles60.csv",
                    "--out", out / "report")
    timing = [json.loads((r / "manifest.json").read_text())["timing"] for r in runs]
    rounds = math.ceil(seeds / workers) if seeds > 1 else 1
    lammps = sum(t["lammps_steps_s"] for t in timing) / len(timing) * rounds
    frames = sum(t["frames_s"] for t in timing) / len(timing) * rounds
    total = t_sim + t_avg + t_ana
    print(f"{preset}{''.join(' --set ' + c for c in changes)}, {seeds} realisation(s), "
          f"{workers if seeds > 1 else 1} process(es)\n")
    print("| phase | wall s | share |")
    print("|---|---|---|")
    for name, t in [("LAMMPS steps (baseline, from the runs' timing records)", lammps),
                    ("frames from LAMMPS (contacts, dumps)", frames),
                    ("rest of simulate (start-up, packing, dask)", t_sim - lammps - frames),
                    ("average, 20 + 60 rings", t_avg), ("analyze (report, figures)", t_ana),
                    ("total", total)]:
        print(f"| {name} | {t:.1f} | {t / total:.2f} |")
    print(f"\ntotal / LAMMPS steps = {total / lammps:.2f}")


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out")
    ap.add_argument("preset")
    ap.add_argument("seeds", nargs="?", type=int, default=1)
    ap.add_argument("workers", nargs="?", type=int, default=2)
    ap.add_argument("--set", dest="changes", action="append", default=[])
    a = ap.parse_args()
    main(a.out, a.preset, a.seeds, a.workers, a.changes)
