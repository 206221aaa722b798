"""Steps per second of the reference DEM against LAMMPS on the same small Couette cell.

    python benchmarks/refdem.py START.data [STEPS]

START is a prepared packing of the small test cell (the ``prepared.data`` of
``granavg simulate --preset paper-hooke`` with the test suite's SMALL_CELL settings). Both
engines shear it for STEPS steps (default 4290, 1 s) in one process without dumps; the
ratio is measured in this run. Prints a markdown table and where the reference's time
goes (cProfile, by function).
"""

from __future__ import annotations

import cProfile
import pstats
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from granavg.sim.lammps_session import executable, lammps_env
from granavg.sim.refdem_run import reference_engine
from granavg.sim.scene import preset
from granavg.sim.simulate import simulate

SMALL_PRESET = "paper-hooke"     # the plain law, grown from random positions
SMALL_CELL = ["R_i=0.04", "R_o=0.0826", "n_small=250", "n_large=40", "Omega=0.5",
              "t_dump_start=0", "contacts=0"]


def lammps_rate(start: Path, scene) -> tuple[float, dict]:
    """LAMMPS steps/s and its time breakdown (s) for the shear: the run directory's
    ``run.sh`` command run by the ``lmp`` executable alone (``drive lammps``)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        simulate(scene, run, start=start, progress=False)
        cmd = shlex.split((run / "run.sh").read_text().splitlines()[-1])
        cmd[0] = executable("lmp")
        cmd[cmd.index("drive") + 1] = "lammps"
        cmd[cmd.index("log.lammps")] = "bench.log"
        subprocess.run(cmd, cwd=run, env=lammps_env(), check=True, capture_output=True)
        log = (run / "bench.log").read_text()
    t, n = re.findall(r"Loop time of ([\d.e+-]+) on \d+ procs for (\d+) steps", log)[-1]
    parts = {name: float(re.findall(rf"^{name}\s+\|[^|]*\|\s*([\d.e+-]+)", log, re.M)[-1])
             for name in ("Pair", "Neigh", "Comm", "Output", "Modify")}
    return int(n) / float(t), parts


def reference_rate(start: Path, derived, steps: int) -> tuple[float, pstats.Stats]:
    dem, _ = reference_engine(start, derived)
    for _ in range(50):                              # warm up (first tree, imports)
        dem.step()
    t0 = time.perf_counter()
    for _ in range(steps):
        dem.step()
    rate = steps / (time.perf_counter() - t0)
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(min(steps, 1000)):
        dem.step()
    prof.disable()
    return rate, pstats.Stats(prof)


def main(start, steps=4290):
    start = Path(start).resolve()
    base = preset(SMALL_PRESET).with_overrides(SMALL_CELL)
    derived = base.derive()
    scene = base.with_overrides([f"t_end={steps * derived.dt!r}", f"dump_dt={10 * steps * derived.dt!r}",
                                 f"restart_dt={10 * steps * derived.dt!r}"])
    lmp, parts = lammps_rate(start, scene)
    ref, stats = reference_rate(start, scene.derive(), steps)
    print(f"| engine | steps/s | ratio |\n|---|---|---|\n| LAMMPS (1 core) | {lmp:.0f} | 1 |\n"
          f"| reference DEM | {ref:.0f} | {ref / lmp:.3f} (LAMMPS {lmp / ref:.1f}x faster) |")
    print("\nLAMMPS loop, s: " + ", ".join(f"{k} {v:.3f}" for k, v in parts.items()))
    print("\nreference DEM, cumulative time by function (1000 steps):")
    stats.sort_stats("tottime").print_stats(8)


if __name__ == "__main__":
    main(sys.argv[1], *(int(a) for a in sys.argv[2:3]))
