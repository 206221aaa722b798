"""Does reading overlap averaging? The engine and per-frame state on frames in memory,
the reader alone, and the two at once in two threads (as ``granavg average`` runs them).

    python benchmarks/overlap.py RUN LONG [N]

RUN: a paper-cell run directory (its first 40 frames, held in memory, feed the engine);
LONG: a run whose dumps the reader reads (python benchmarks/long_run.py RUN LONG 20);
N frames of each (default 300). Prints wall seconds of each alone, of both at once, and
the ideal (the slower alone) and serial (their sum) times to compare with.
"""

import itertools
import sys
import threading
import time
from pathlib import Path

from granavg.engine.frame_sums import frame_sums
from granavg.engine.channels import BLOCKS
from granavg.engine.cells.rings import Rings
from granavg.engine.uncertainty.structure import FINE_SECTORS
from granavg.sim.couette_state import frame_state
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.io.run_dumps import RunDumps


def frames_of(run, dt, n=None):
    pair = RunDumps(DumpReader(run / "atoms.dump.gz"), DumpReader(run / "contacts.dump.gz"),
                    dt=dt)
    return itertools.islice(pair, n)


def main(run, long, n=300):
    run, long = Path(run), Path(long)
    s, dt = (m := read_manifest(run))["scene"], m["derived"]["dt_s"]
    frames = list(frames_of(run, dt, 40))
    rings = Rings.count(20, s["R_i"], s["R_o"], s["h"])
    every = [b for b in BLOCKS if b not in ("body", "bpow")]

    def engine(k):
        for j in range(k):
            f = frames[j % len(frames)]
            frame_sums(f, rings, s["rho_p"], every, n_sectors=FINE_SECTORS)
            frame_state(f.atoms, f.contacts, s["R_i"], s["R_o"], s["h"], s["rho_p"], s["d_s"])

    def read(k):
        for _ in frames_of(long, dt, k):
            pass

    engine(len(frames))                                  # warm: caches, compiled kernels
    read(5)
    t = time.perf_counter()
    engine(n)
    te = time.perf_counter() - t
    t = time.perf_counter()
    read(n)
    tr = time.perf_counter() - t
    t = time.perf_counter()
    reader = threading.Thread(target=read, args=(n,))
    reader.start()
    engine(n)
    reader.join()
    tb = time.perf_counter() - t
    print(f"{n} frames: engine and per-frame state {te:.2f} s, reader {tr:.2f} s, both at "
          f"once {tb:.2f} s (ideal {max(te, tr):.2f} s, serial {te + tr:.2f} s)")


if __name__ == "__main__":
    main(*sys.argv[1:3], *map(int, sys.argv[3:4]))
