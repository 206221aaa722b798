"""The job a user would otherwise do in OVITO: a 20 x 20 map of density and velocity from
a plain 2D per-atom dump, granavg against OVITO, whole processes, in turn.

    python benchmarks/ovito_job.py RUN --ovito-python PYTHON [--frames 60 600] [-n 5]

RUN: a run directory with ``atoms.dump.gz`` (``granavg simulate``'s). Its frames are
written to plain dumps of each ``--frames`` count (repeated, time steps shifted, when the
run has fewer). Each pair is timed as whole processes, granavg and OVITO alternating,
start-up included, the page cache warm (one warm-up each):

- ``granavg average --atoms DUMP --thickness 0.006 --grid 20 20 --dt DT --quantities
  nu,v`` (DT the run's time step, from its manifest);
- OVITO (``import_file`` + ``SpatialBinningModifier`` of Mass (summed over the bin's
  volume: a density) and of Velocity (the mean), on the same 20 x 20 grid of the box,
  every frame computed and its grids read), in PYTHON, an interpreter with the
  ``ovito`` module (``pip install ovito`` in its own environment: not a dependency of
  granavg). Without it the script says so and stops.

Prints the medians (min - max) and the median of the pairs' ratios granavg / OVITO.
"""

import argparse
import gzip
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ovito_probe import ovito_version   # benchmarks/, beside this script

OVITO = """
import sys
from ovito.io import import_file
from ovito.modifiers import SpatialBinningModifier as B
pipe = import_file(sys.argv[1], multiple_frames=True)
for prop, op in (("Mass", B.Operation.SumVol), ("Velocity", B.Operation.Mean)):
    pipe.modifiers.append(B(property=prop, reduction_operation=op, bin_count=(20, 20, 1),
                            direction=B.Direction.XY))
total = 0.0
for k in range(pipe.source.num_frames):
    data = pipe.compute(k)
    total += sum(float(g[p][...].sum()) for g in data.grids.values() for p in g.keys())
print(pipe.source.num_frames, total)
"""


def plain_dump(src: Path, dst: Path, n_frames: int) -> None:
    """``n_frames`` frames of ``src`` (gzipped) as a plain dump, repeated as needed."""
    frames = gzip.decompress(src.read_bytes()).decode().split("ITEM: TIMESTEP\n")[1:]
    steps = [int(f.split("\n", 1)[0]) for f in frames]
    period = steps[-1] - steps[0] + (steps[1] - steps[0] if len(steps) > 1 else 1)
    with dst.open("w") as out:
        for k in range(n_frames):
            f = frames[k % len(frames)]
            step, rest = f.split("\n", 1)
            out.write(f"ITEM: TIMESTEP\n{int(step) + (k // len(frames)) * period}\n{rest}")


def wall(cmd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--ovito-python", default=sys.executable)
    ap.add_argument("--frames", type=int, nargs="+", default=[60, 600])
    ap.add_argument("-n", type=int, default=5)
    args = ap.parse_args(argv)
    version = ovito_version(args.ovito_python)
    if version is None:
        return 0
    granavg = str(Path(sys.executable).with_name("granavg"))
    dt = json.loads((args.run / "manifest.json").read_text())["derived"]["dt_s"]
    print(f"OVITO {version}; granavg {granavg}")
    print("| frames | granavg s | OVITO s | granavg / OVITO |\n|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "ovito_job.py"
        script.write_text(OVITO)
        for n in args.frames:
            dump = Path(tmp) / f"atoms{n}.dump"
            plain_dump(args.run / "atoms.dump.gz", dump, n)
            out = Path(tmp) / f"map{n}"

            def ours(k):
                return [granavg, "average", "--atoms", str(dump), "--thickness", "0.006",
                        "--grid", "20", "20", "--dt", repr(dt), "--quantities", "nu,v",
                        "--units", "si",
                        "--out", f"{out}-{k}.csv"]
            theirs = [args.ovito_python, str(script), str(dump)]
            wall(ours("warm")), wall(theirs)
            pairs = [(wall(ours(k)), wall(theirs)) for k in range(args.n)]
            g, o = zip(*pairs)
            ratio = [a / b for a, b in pairs]

            def fmt(x):
                return f"{statistics.median(x):.3f} ({min(x):.3f}-{max(x):.3f})"
            print(f"| {n} | {fmt(g)} | {fmt(o)} | {fmt(ratio)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
