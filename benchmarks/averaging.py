"""Benchmark the dump reader and the ring-averaging engine on a paper-scene run.

    python benchmarks/averaging.py RUN_DIR      # a run of the paper geometry (e.g. the demo)

Prints a markdown table: reader MB/s beside MDAnalysis' DumpReader on the same per-atom
dump (ratio measured in this run), engine frames/s (frames already in memory), the
whole `average_run`, and peak traced memory of the engine for 10^2, 10^3, 10^4 frames.
"""

from __future__ import annotations

import gzip
import itertools
import sys
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path

from granavg.engine.cell_average import CellAverage
from granavg.engine.spec import Averaging
from granavg.engine.frame_sums import frame_sums
from granavg.engine.cells.rings import Rings
from granavg.pipeline.runs import average_run
from granavg.engine.channels import BLOCKS
from granavg.engine.requirements import groups_for
from granavg.engine.uncertainty.structure import FINE_SECTORS
from granavg.sim.couette_state import frame_state
from granavg.io.frames import Frame
from granavg.io.reader import DumpReader
from granavg.io.run_dumps import RunDumps
from granavg.io.run_directory import read_manifest


def best_of(fn, repeat=3, clock=time.perf_counter):
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return min(times)


def engine_rate(fn, n_frames):
    """Frames per second of wall time and of the process's CPU time (one thread: on a
    shared machine the CPU time leaves out the time other processes held the core),
    best of seven passes each."""
    return tuple(n_frames / best_of(fn, repeat=7, clock=c)
                 for c in (time.perf_counter, time.process_time))


def reader_rows(run: Path, plain: Path):
    size = plain.stat().st_size / 1e6
    list(DumpReader(plain, ["x"]))                  # load the compiled kernel
    rows = []
    for label, fn in [
        ("granavg, all 11 columns", lambda: list(DumpReader(plain))),
        ("granavg, x y radius (density)", lambda: list(DumpReader(plain, ["x", "y", "radius"]))),
        ("granavg, gzip file, all columns", lambda: list(DumpReader(run / "atoms.dump.gz"))),
    ]:
        rows.append((label, size / best_of(fn)))
    import MDAnalysis as mda

    def mdanalysis():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            u = mda.Universe(str(plain), format="LAMMPSDUMP")
            for ts in u.trajectory:
                ts.positions, ts.velocities
    rows.append(("MDAnalysis 2.x DumpReader (positions, velocities)",
                 size / best_of(mdanalysis, repeat=1)))
    return rows


def engine_rows(run: Path, m):
    scene = m["scene"]
    frames = list(itertools.islice(RunDumps(DumpReader(run / "atoms.dump.gz"),
                                              DumpReader(run / "contacts.dump.gz"),
                                              dt=m["derived"]["dt_s"]), 40))
    rows = []
    every = [b for b in BLOCKS if b not in ("body", "bpow")]            # no body forces in the dumps
    for n in (20, 60):
        rings = Rings.count(n, scene["R_i"], scene["R_o"], scene["h"])
        for label, channels in (("all quantities", every),
                                ("nu and v", ("vol", "mom"))):
            for sectors in (FINE_SECTORS, 0):
                frame_sums(frames[0], rings, scene["rho_p"], channels, n_sectors=sectors)
                rate = engine_rate(lambda: [frame_sums(f, rings, scene["rho_p"], channels,
                                                       n_sectors=sectors) for f in frames],
                                   len(frames))
                rows.append((f"{n} rings, {label}, " + (f"{sectors} sectors (default)"
                                                        if sectors else "--sectors off"),
                             rate))
    geo = (scene["R_i"], scene["R_o"], scene["h"], scene["rho_p"], scene["d_s"])
    frame_state(frames[0].atoms, frames[0].contacts, *geo)
    rows.append(("per-frame state (time series), alone",
                 engine_rate(lambda: [frame_state(f.atoms, f.contacts, *geo) for f in frames],
                             len(frames))))
    return frames, rows


def memory_rows(frames, m):
    scene = m["scene"]
    rings = Rings.count(20, scene["R_i"], scene["R_o"], scene["h"])
    rows = []
    for n in (100, 1000, 10000):
        stream = (Frame(k, 0.5 * k, f.atoms, f.contacts)
                  for k, f in zip(range(n), itertools.cycle(frames)))
        tracemalloc.start()
        t0 = time.perf_counter()
        CellAverage(stream, rings, [g for g in groups_for(None, True) if g != "body"],
                    scene["rho_p"], Averaging.of(t_min=0.0, block_time=250.0)).run(False)
        elapsed = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
        rows.append((n, peak, elapsed))
    return rows


def main(run):
    run = Path(run)
    m = read_manifest(run)
    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / "atoms.dump"
        plain.write_bytes(gzip.decompress((run / "atoms.dump.gz").read_bytes()))
        reader = reader_rows(run, plain)
        size = plain.stat().st_size / 1e6
    frames, engine = engine_rows(run, m)
    t0 = time.perf_counter()
    prof = average_run(run, bins=20, t_min=0.0, progress=False)
    whole = time.perf_counter() - t0
    memory = memory_rows(frames, m)
    mda = reader[-1][1]
    print(f"Per-atom dump: {size:.1f} MB, {len(list(DumpReader(run / 'atoms.dump.gz', ['x'])))}"
          f" frames of {len(frames[0].atoms['x'])} disks; contacts per frame: "
          f"{len(frames[0].contacts['id1'])}\n")
    print("| reader | MB/s | vs MDAnalysis |\n|---|---|---|")
    for label, mbs in reader:
        print(f"| {label} | {mbs:.0f} | {mbs / mda:.1f}x |")
    print("\n| engine (one core, frames in memory) | frames per wall second | frames per "
          "CPU second |\n|---|---|---|")
    for label, (wall, cpu) in engine:
        print(f"| {label} | {wall:.0f} | {cpu:.0f} |")
    print(f"\nWhole `average_run` (read both dumps, 20 rings, all quantities): "
          f"{prof.n_frames} frames in {whole:.2f} s = {prof.n_frames / whole:.0f} frames/s\n")
    print("| frames averaged | peak traced memory MB | seconds |\n|---|---|---|")
    for n, peak, elapsed in memory:
        print(f"| {n} | {peak:.1f} | {elapsed:.1f} |")
    print(f"\nPeak memory at 10^4 frames / at 10^2 frames: {memory[-1][1] / memory[0][1]:.2f}")


if __name__ == "__main__":
    main(sys.argv[1])
