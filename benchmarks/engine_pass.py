"""The engine's pass alone, for comparing two versions of granavg on the same frames.

    python benchmarks/engine_pass.py RUN_DIR            # this checkout
    PYTHONPATH=OLD python benchmarks/engine_pass.py RUN_DIR   # OLD: git worktree add OLD <commit>

Prints frames per CPU second (best of eight passes over 40 frames in memory, one core)
of the cell sums for 20 rings and all quantities, with the default 24 sectors and
without. Alternate the two versions a few times: the machine is noisy.
"""

import itertools
import sys
import time
from pathlib import Path

from granavg.engine.frame_sums import frame_sums
from granavg.engine.channels import BLOCKS
from granavg.engine.cells.rings import Rings
from granavg.engine.uncertainty.structure import FINE_SECTORS
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.io.run_dumps import RunDumps


def main(run):
    run = Path(run)
    m = read_manifest(run)
    s = m["scene"]
    frames = list(itertools.islice(RunDumps(DumpReader(run / "atoms.dump.gz"),
                                            DumpReader(run / "contacts.dump.gz"),
                                            dt=m["derived"]["dt_s"]), 40))
    rings = Rings.count(20, s["R_i"], s["R_o"], s["h"])
    every = [b for b in BLOCKS if b not in ("body", "bpow")]     # no body force here
    best = {FINE_SECTORS: float("inf"), 0: float("inf")}
    for _ in range(8):                  # the two settings in turn; the first round warms up
        for sectors in best:
            t0 = time.process_time()
            for f in frames:
                frame_sums(f, rings, s["rho_p"], every, n_sectors=sectors)
            best[sectors] = min(best[sectors], time.process_time() - t0)
    for sectors, t in best.items():
        print(f"{sectors or 'no'} sectors: {len(frames) / t:.0f} frames per CPU second")


if __name__ == "__main__":
    main(sys.argv[1])
