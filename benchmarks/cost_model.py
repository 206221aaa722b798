"""The cost model of docs/running-big.md: the time per frame of reading and of the engine,
measured in this process on generated frames, and its coefficients.

    python benchmarks/cost_model.py [--sizes 20000 100000 500000] [-n 3]

Engine: random spheres in a 1 x 1 x 0.3 box with velocities, spins and two contacts per
sphere (forces, normals, overlaps, couples), every quantity, over a box grid of 20 x 20 x
6 and of 40 x 40 x 12 cells, on 1 and on 2 threads; t = t0 + a P + c C per grid and
thread count (P spheres, C contacts): t0 a frame of 100 spheres, a and c at each larger
size (they grow with the frame: caches). Reader: the same spheres' frame
written as LAMMPS' ``dump custom`` text (13 columns, %g), read by granavg's reader from a
plain file and from a gzip one: seconds per MB of text. Each figure is the median of
``-n`` passes, warm.
"""

import argparse
import gzip
import logging
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

COLUMNS = ["id", "type", "radius", "mass", "x", "y", "z", "vx", "vy", "vz", "omegax",
           "omegay", "omegaz"]


def spheres(n, seed=1):
    """Atoms and contacts (2 per sphere) of n random spheres."""
    rng = np.random.default_rng(seed)
    atoms = {"id": np.arange(1.0, n + 1), "type": np.ones(n),
             "radius": rng.uniform(0.004, 0.006, n), "x": rng.uniform(0, 1, n),
             "y": rng.uniform(0, 1, n), "z": rng.uniform(0, 0.3, n),
             **{f"v{c}": rng.normal(size=n) for c in "xyz"},
             **{f"omega{c}": rng.normal(size=n) for c in "xyz"}}
    atoms["mass"] = 2500 * 4 / 3 * np.pi * atoms["radius"] ** 3
    i = np.concatenate([np.arange(n - 1), np.arange(n - 2)])
    j = np.concatenate([np.arange(1, n), np.arange(2, n)])
    nrm = rng.normal(size=(len(i), 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    contacts = {"id1": i + 1.0, "id2": j + 1.0, "wall": np.zeros(len(i)),
                **{f"fn{c}": rng.normal(size=len(i)) for c in "xyz"},
                **{f"ft{c}": rng.normal(size=len(i)) for c in "xyz"},
                **{f"n{c}": nrm[:, k] for k, c in enumerate("xyz")},
                **{f"m{c}": rng.normal(size=len(i)) for c in "xyz"},
                "overlap": rng.uniform(0, 1e-4, len(i))}
    return atoms, contacts


def median_time(fn, n):
    for _ in range(3):              # warm: the first calls of a process are slower
        fn()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def engine(sizes, n):
    from granavg.cells import Boxes
    from granavg.engine import threads
    from granavg.engine.frame_sums import frame_sums
    from granavg.engine.channels import BLOCKS, DERIVATIVE_BLOCKS
    from granavg.io.frames import Frame

    blocks = [b for b in BLOCKS if b not in DERIVATIVE_BLOCKS and b not in ("wall", "body",
                                                                             "bpow")]
    atoms, contacts = spheres(2000)             # the process warmed up before any timing
    warm = Boxes(*(np.linspace(0, L, 5) for L in (1, 1, 0.3)))
    for _ in range(20):
        frame_sums(Frame(0, 0.0, atoms, contacts), warm, 2500.0, blocks)
    rows = []
    for grid in ((20, 20, 6), (40, 40, 12)):
        cells = Boxes(*(np.linspace(0, L, k + 1) for L, k in zip((1, 1, 0.3), grid)))
        for size in [100] + list(sizes):
            atoms, contacts = spheres(size)
            for with_contacts in (False, True):
                frame = Frame(0, 0.0, atoms, contacts if with_contacts else None)
                want = blocks if with_contacts else [b for b in blocks if b in (
                    "vol", "mass", "mom", "spin", "kin", "ispin", "inertia", "erot", "ekin",
                    "kcpl")]
                for k in (1, 2):
                    threads.set_count(k)
                    t = median_time(lambda: frame_sums(frame, cells, 2500.0, want), n)
                    rows.append((grid, size, len(contacts["id1"]) if with_contacts else 0, k, t))
    threads.set_count(None)
    print("Per frame: a = (t without contacts - t0) / P, c = (t with contacts - t without) "
          "/ C;\nt0 = the frame of 100 spheres and its contacts.\n")
    print("| grid | threads | t0 ms | P spheres | C contacts | ms, no contacts | "
          "ms, contacts | a ns per sphere | c ns per contact |\n"
          "|---|---|---|---|---|---|---|---|---|")
    for grid in ((20, 20, 6), (40, 40, 12)):
        for k in (1, 2):
            pick = {(r[1], r[2] > 0): r for r in rows if r[0] == grid and r[3] == k}
            t0 = pick[100, True][4]
            for size in sizes:
                bare, full = pick[size, False], pick[size, True]
                print(f"| {'x'.join(map(str, grid))} | {k} | {t0 * 1e3:.2f} | {size} | "
                      f"{full[2]} | {bare[4] * 1e3:.1f} | {full[4] * 1e3:.1f} | "
                      f"{(bare[4] - t0) / size * 1e9:.0f} | "
                      f"{(full[4] - bare[4]) / full[2] * 1e9:.0f} |")


def reader(size, n):
    from granavg.io.reader import DumpReader

    atoms, _ = spheres(size)
    table = np.column_stack([atoms[c] for c in COLUMNS])
    head = (f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{size}\nITEM: BOX BOUNDS pp pp ff\n"
            f"0 1\n0 1\n0 0.3\nITEM: ATOMS {' '.join(COLUMNS)}\n")
    body = "\n".join(" ".join(f"{v:g}" for v in row) for row in table) + "\n"
    frames = "".join(head.replace("TIMESTEP\n0", f"TIMESTEP\n{k}") + body for k in range(4))
    with tempfile.TemporaryDirectory() as tmp:
        plain, gz = Path(tmp) / "d.dump", Path(tmp) / "d.dump.gz"
        plain.write_text(frames)
        gz.write_bytes(gzip.compress(frames.encode(), 6))
        mb = plain.stat().st_size / 1e6
        print("\n| reader | s per MB of text | MB/s | s per frame of 10^6 spheres |\n"
              "|---|---|---|---|")
        for name, path in (("plain", plain), ("gzip", gz)):
            t = median_time(lambda: sum(1 for _ in DumpReader(path)), n)
            print(f"| {name} | {t / mb:.4f} | {mb / t:.0f} | {t / 4 * 1e6 / size:.3f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[20000, 100000, 500000])
    ap.add_argument("-n", type=int, default=3)
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    engine(args.sizes, args.n)
    reader(max(args.sizes) // 5, args.n)


if __name__ == "__main__":
    main()
