"""A 3D dump of about a million spheres, averaged over a box grid, against OVITO reading
the same file (issue: three dimensions at the scale of real 3D runs).

    python benchmarks/big_3d.py make DIR [--copies 36 37] [--frames 6]
    python benchmarks/big_3d.py time DIR [--ovito-python PY] [--grid 20 20 6]
    python benchmarks/big_3d.py series DIR [--files 24] [-n 3]
    python benchmarks/big_3d.py threads DIR [--files 24] [--quantities nu] [--counts 1 2]
        [--layout series|single|gzip|all] [--workers 2 4 ...] [--stages]

``make`` (every core: the frames formatted in processes, the layouts written on
threads) takes the last frame of the 3D pile of tests/decks/pile_3d_si.lmp (755 spheres at
rest on a floor, periodic in x and y, SI units; shipped as benchmarks/pile_frame.txt.gz,
so that no LAMMPS is needed), tiles it NX x NY times side by side and
writes DIR/big.dump: ``--frames`` frames of a LAMMPS text dump as LAMMPS writes it by
default (%g; columns id type diameter mass x y z vx vy vz omegax omegay omegaz, every
frame's velocities perturbed so that they differ), and DIR/two.dump, its first two
frames. ``time`` measures, each as a whole
process (start-up included), best of 3, with its peak memory:

- granavg average of the dump over a box grid, the quantities an atom dump gives (nu,
  rho, v, omega, dsigma, dsigma_fluct);
- OVITO's ``import_file`` + ``compute`` of every frame of the same file (in PYTHON, an
  interpreter with the ``ovito`` module; OVITO is not a dependency of granavg: without
  it that line is skipped with a message);
- granavg's reader alone;
- granavg average of the first two frames only (memory flat in the number of frames).

``series`` writes DIR/series/dump.<step>.txt, ``--files`` files of one frame each (the
frames of DIR/big.dump in turn, time steps and times continued), as LAMMPS' ``dump ...
dump.*.txt`` writes them, and times ``granavg average 'DIR/series/dump.*.txt'`` (the same
grid and quantities) with ``--workers 2`` against one process, whole processes in turn,
``-n`` pairs: the median of the pairs' ratios one process / two workers (the cluster
kept: GRANAVG_COST_MODEL=off).

``threads`` times one process on the same frames with each ``--threads`` count (the
files, or the pieces of one file, parsed on that many reader threads, the engine on as
many), and the baseline that reads them without parsing, ``-n`` rounds in turn (each process
right after an untimed read of its files: :func:`cached`); the
profiles' hashes must agree; ``--workers N ...`` adds a local dask cluster of N workers
for each N (its start included; GRANAVG_COST_MODEL=off, so that the cluster itself is
timed where ``--workers`` would average in one process; a single gzip file cannot be
split). Layouts: the series; one plain file of its frames
(DIR/single.dump); the series gzipped (DIR/gz; the baseline: zcat of one file times
the files over the cores). ``--stages`` adds,
for each count, where one process' time goes: its imports, the set-up until the engine
takes its first frame, the engine's time per frame in the steady state, and the end
(medians of ``-n`` processes).

Every timing first compiles granavg's bytecode (``compileall``), as an install does:
the timed processes do not compile the modules edited since.
"""

from __future__ import annotations

import argparse
import itertools
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ovito_probe import ovito_version   # benchmarks/, beside this script

ROOT = Path(__file__).resolve().parent.parent
COLUMNS = ["id", "type", "diameter", "mass", "x", "y", "z", "vx", "vy", "vz", "omegax",
           "omegay", "omegaz"]
SIDE = 0.016                                    # the pile deck's periodic box, m
OVITO = """
import sys
from ovito.io import import_file
pipe = import_file(sys.argv[1], multiple_frames=True)
for k in range(pipe.source.num_frames):
    pipe.compute(k)
"""
READ = """
import sys
from granavg.io.reader import DumpReader
for _ in DumpReader(sys.argv[1]):
    pass
"""


#: The settled pile's last frame (tests/decks/pile_3d_si.lmp with its defaults, LAMMPS
#: 2025.7.22), shipped so that the data is made the same way where LAMMPS is absent.
FRAME = Path(__file__).with_name("pile_frame.txt.gz")


def pile_frame() -> np.ndarray:
    """The settled pile's last frame, columns :data:`COLUMNS` (:data:`FRAME`)."""
    return np.loadtxt(FRAME)


def make(out: Path, copies, frames: int) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    base = pile_frame()
    nx, ny = copies
    n0 = len(base)
    tiles = []
    for i in range(nx):
        for j in range(ny):
            t = base.copy()
            t[:, 0] += (i * ny + j) * n0
            t[:, 4] += i * SIDE
            t[:, 5] += j * SIDE
            tiles.append(t)
    atoms = np.concatenate(tiles)
    rng = np.random.default_rng(1)
    path = out / "big.dump"
    perturbed = (atoms + np.pad(rng.normal(0, 1e-4, (len(atoms), 6)), ((0, 0), (7, 0)))
                 for _ in range(frames))
    with open(path, "w") as fh, open(out / "two.dump", "w") as two, \
            ProcessPoolExecutor(min(frames, os.cpu_count() or 1)) as pool:
        # each frame formatted in a process of its own (the %g text is the slow part)
        for k, text in enumerate(pool.map(frame_text, range(frames), perturbed,
                                          itertools.repeat((nx, ny)))):
            fh.write(text)
            if k < 2:                     # the first two frames alone: memory against frames
                two.write(text)
    print(f"{path}: {len(atoms)} spheres x {frames} frames, {path.stat().st_size / 1e6:.0f} MB")
    return path


def frame_text(k: int, a: np.ndarray, tiles) -> str:
    """Frame ``k`` of :func:`make` as LAMMPS writes it (%g, the :data:`COLUMNS`)."""
    import pandas as pd

    nx, ny = tiles
    table = pd.DataFrame(a, columns=COLUMNS).astype({"id": int, "type": int})
    return (f"ITEM: UNITS\nsi\nITEM: TIME\n{0.001 * k:g}\nITEM: TIMESTEP\n{100 * k}\n"
            f"ITEM: NUMBER OF ATOMS\n{len(a)}\nITEM: BOX BOUNDS pp pp ff\n"
            f"0 {nx * SIDE:g}\n0 {ny * SIDE:g}\n0 0.09\n"
            f"ITEM: ATOMS {' '.join(COLUMNS)}\n"
            + table.to_csv(sep=" ", header=False, index=False, float_format="%g"))


def on_cores(fn, items) -> list:
    """``fn`` of each item on a thread per core (file writes, reads and ISA-L's
    compression release the GIL)."""
    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        return list(pool.map(fn, items))


def run(cmd) -> tuple:
    """(wall seconds, peak RSS in MiB) of one whole process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode()
    proc.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"failed: {' '.join(map(str, cmd))}\n{err}")
    return wall, usage.ru_maxrss / 1024


def cached(pattern) -> None:
    """Read the files of ``pattern`` (a path, or a glob) whole, untimed, so that the
    process timed next finds them in the page cache: a kernel that pages out cold page
    cache (a VM's memory reclaim can, within seconds) would otherwise make some rounds
    read from disk."""
    import glob

    def read(name):
        with open(name, "rb") as fh:
            while fh.read(1 << 24):
                pass
    on_cores(read, glob.glob(str(pattern)))


def best(cmd, repeat=3) -> tuple:
    runs = [run(cmd) for _ in range(repeat)]
    return min(w for w, _ in runs), max(m for _, m in runs)


def timing(d: Path, ovito_python: str, grid) -> None:
    dump = d / "big.dump"
    size = dump.stat().st_size / 1e6
    granavg = [sys.executable, "-m", "granavg"]
    quantities = "nu,rho,v,omega,dsigma,dsigma_fluct"

    def average(path, dest):
        return [*granavg, "average", "--atoms", str(path), "--grid", *map(str, grid),
                "--z-range", "0", "0.03", "--quantities", quantities, "--out", str(dest),
                "--no-progress"]

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ours = best(["sh", "-c", f'rm -f {tmp}/a.csv*; exec "$@"', "sh",
                     *average(dump, tmp / "a.csv")])
        reader = best([sys.executable, "-c", READ, str(dump)])
        small = best(["sh", "-c", f'rm -f {tmp}/b.csv*; exec "$@"', "sh",
                      *average(d / "two.dump", tmp / "b.csv")])
    with open(dump, "rb") as fh:
        frames = sum(chunk.count(b"ITEM: TIMESTEP") for chunk in iter(lambda: fh.read(1 << 24), b""))
    print(f"| {dump.name}: {size:.0f} MB, {frames} frames | wall s (best of 3) | MB/s | peak "
          "memory MiB |\n|---|---|---|---|")
    print(f"| granavg average, {'x'.join(map(str, grid))} boxes, {quantities} | {ours[0]:.1f} | "
          f"{size / ours[0]:.0f} | {ours[1]:.0f} |")
    print(f"| granavg reader alone | {reader[0]:.1f} | {size / reader[0]:.0f} | {reader[1]:.0f} |")
    print(f"| granavg average, first 2 frames | {small[0]:.1f} | - | {small[1]:.0f} |")
    version = ovito_version(ovito_python)
    if version is None:
        return
    theirs = best([ovito_python, "-c", OVITO, str(dump)])
    print(f"| OVITO {version} import_file + compute of every frame | "
          f"{theirs[0]:.1f} | {size / theirs[0]:.0f} | {theirs[1]:.0f} |")
    print(f"\ngranavg average / OVITO reading: {ours[0] / theirs[0]:.2f} of its time "
          f"({theirs[0] / ours[0]:.2f}x its speed)")


def write_series(d: Path, files: int) -> Path:
    """DIR/series/dump.<step>.txt: ``files`` one-frame files from DIR/big.dump's frames."""
    text = (d / "big.dump").read_text()
    frames = ["ITEM: UNITS" + f for f in text.split("ITEM: UNITS")[1:]]
    out = d / "series"
    out.mkdir(exist_ok=True)

    def write(k):
        head, rest = frames[k % len(frames)].split("ITEM: NUMBER OF ATOMS", 1)
        (out / f"dump.{100 * k}.txt").write_text(
            f"ITEM: UNITS\nsi\nITEM: TIME\n{0.001 * k:g}\nITEM: TIMESTEP\n{100 * k}\n"
            f"ITEM: NUMBER OF ATOMS{rest}")
    on_cores(write, range(files))
    print(f"{out}: {files} files, {sum(p.stat().st_size for p in out.iterdir()) / 1e6:.0f} MB")
    return out


def series_timing(d: Path, files: int, n: int, grid) -> None:
    import statistics

    out = d / "series"
    if len(list(out.glob("dump.*.txt"))) != files:
        write_series(d, files)
    quantities = "nu,rho,v,omega,dsigma,dsigma_fluct"

    def average(extra, dest):
        return ["sh", "-c", f'rm -f {dest}*; exec env GRANAVG_COST_MODEL=off "$@"', "sh",
                sys.executable, "-m", "granavg",
                "average", "--atoms", str(out / "dump.*.txt"), "--grid", *map(str, grid),
                "--z-range", "0", "0.03", "--quantities", quantities, "--out", str(dest),
                "--no-progress", *extra]
    with tempfile.TemporaryDirectory() as tmp:
        one, two = average([], f"{tmp}/one.csv"), average(["--workers", "2"], f"{tmp}/two.csv")
        pairs = []
        for _ in range(n):
            cached(out / "dump.*.txt")
            t_one = run(one)[0]
            cached(out / "dump.*.txt")
            pairs.append((t_one, run(two)[0]))
    a, b = zip(*pairs)
    ratio = [x / y for x, y in pairs]
    print(f"| {files} files | one process s | --workers 2 s | one / two workers |\n"
          "|---|---|---|---|")
    print(f"| median (range) | {statistics.median(a):.1f} ({min(a):.1f}-{max(a):.1f}) | "
          f"{statistics.median(b):.1f} ({min(b):.1f}-{max(b):.1f}) | "
          f"{statistics.median(ratio):.2f} ({min(ratio):.2f}-{max(ratio):.2f}) |")


def layouts(d: Path, files: int) -> dict:
    """The same frames three ways: the series (DIR/series), one plain file of them all
    (DIR/single.dump) and the series gzipped (DIR/gz, level 1), each as (path, the
    baseline's name, its command, the factor on its time): ``cat`` of the files, and
    ``zcat`` of one gzip file times the files over the cores (what every core
    decompressing its share of the files at zcat's speed would take)."""
    from isal import igzip

    out = d / "series"
    if len(list(out.glob("dump.*.txt"))) != files:
        write_series(d, files)
    names = sorted(out.glob("dump.*.txt"), key=lambda p: int(p.name.split(".")[1]))
    single, gz = d / "single.dump", d / "gz"
    sizes = [p.stat().st_size for p in names]
    if not single.exists() or single.stat().st_size != sum(sizes):
        # each file written at its own offset, on a thread per core
        fd = os.open(single, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        try:
            os.ftruncate(fd, sum(sizes))
            starts = itertools.accumulate([0] + sizes[:-1])
            on_cores(lambda job: os.pwrite(fd, job[0].read_bytes(), job[1]),
                     zip(names, starts))
        finally:
            os.close(fd)
    gz.mkdir(exist_ok=True)

    def compress(p):
        if not (gz / f"{p.name}.gz").exists():
            with igzip.open(gz / f"{p.name}.gz", "wb", compresslevel=1) as fh:
                fh.write(p.read_bytes())
    on_cores(compress, names)
    cores = os.cpu_count() or 1
    return {"series": (out / "dump.*.txt", "cat", f"cat {out}/dump.*.txt", 1),
            "single": (single, "cat", f"cat {single}", 1),
            # the gzip baseline: one file's zcat, times the files over the cores
            "gzip": (gz / "dump.*.txt.gz", f"zcat of one file x {files}/{cores}",
                     f"zcat {gz / names[0].name}.gz", files / cores)}


def threads_timing(d: Path, files: int, n: int, grid, quantities: str, counts,
                   layout: str = "series", workers=()) -> None:
    """One process on one layout of the frames (:func:`layouts`) with each
    ``--threads`` count (readers and engine), ``--workers`` N (a local dask cluster,
    start-up included) for each of ``workers``, and the layout's baseline (cat, zcat),
    runs in turn; the profiles' hashes compared."""
    import hashlib
    import statistics

    atoms, label, baseline, factor = layouts(d, files)[layout]
    runs = {f"--threads {k}": ["--threads", str(k)] for k in counts}
    runs.update({f"--workers {w}": ["--workers", str(w)] for w in workers})
    with tempfile.TemporaryDirectory() as tmp:
        def average(name):
            dest = f"{tmp}/{name.replace(' ', '')}.csv"
            return ["sh", "-c", f'rm -f {dest}*; exec env GRANAVG_COST_MODEL=off "$@"', "sh",
                    sys.executable, "-m",
                    "granavg", "average", "--atoms", str(atoms), "--grid",
                    *map(str, grid), "--z-range", "0", "0.03", "--quantities", quantities,
                    "--out", dest, "--no-progress", *runs[name]]
        first = next(iter(runs))
        run(average(list(runs)[-1]))                             # the page cache warm
        times = {name: [] for name in (*runs, label)}
        for _ in range(n):
            cached(atoms)
            times[label].append(factor * run(["sh", "-c", f"{baseline} > /dev/null"])[0])
            for name in runs:
                cached(atoms)
                times[name].append(run(average(name))[0])
        digests = {name: hashlib.sha256(Path(f"{tmp}/{name.replace(' ', '')}.csv")
                                        .read_bytes()).hexdigest()[:12] for name in runs}
    base = statistics.median(times[first])
    print(f"| {layout}: {files} frames, --quantities {quantities} | wall s, median (range) | "
          f"vs {first} | profile sha256 |\n|---|---|---|---|")
    for name, v in times.items():
        med = statistics.median(v)
        print(f"| {name} | {med:.2f} ({min(v):.2f}-{max(v):.2f}) | {base / med:.2f} | "
              f"{digests.get(name, '-')} |")
    print("identical profiles:", len(set(digests.values())) == 1)


STAGES = """
import sys, time
t0 = time.perf_counter()
from granavg import cli
from granavg.engine import cell_average
imported, seen, add = time.perf_counter() - t0, [], cell_average.CellAverage.add
def timed(self, frame):
    seen.append(time.perf_counter() - t0)
    return add(self, frame)
cell_average.CellAverage.add = timed
try:
    cli.main(sys.argv[1:])
except SystemExit:
    pass
print(imported, seen[0], (seen[-1] - seen[0]) / (len(seen) - 1), time.perf_counter() - t0)
"""


def stages(atoms, grid, quantities: str, counts, n: int) -> None:
    """Where one process' time goes on each ``--threads`` count (:data:`STAGES`)."""
    import statistics

    print("| --threads | imports s | first frame at s | per frame ms | end s |\n"
          "|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k in counts:
            rows = []
            for i in range(n):
                cached(atoms)
                out = subprocess.run(
                    [sys.executable, "-c", STAGES, "average", "--atoms", str(atoms), "--grid",
                     *map(str, grid), "--z-range", "0", "0.03", "--quantities", quantities,
                     "--out", f"{tmp}/s{k}-{i}.csv", "--no-progress", "--threads", str(k)],
                    capture_output=True, text=True, check=True).stdout.split()
                rows.append([float(x) for x in out])
            a, b, c, d = (statistics.median(col) for col in zip(*rows))
            print(f"| {k} | {a:.2f} | {b:.2f} | {1000 * c:.0f} | {d:.2f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    mk = sub.add_parser("make")
    mk.add_argument("dir", type=Path)
    mk.add_argument("--copies", type=int, nargs=2, default=(36, 37))
    mk.add_argument("--frames", type=int, default=6)
    tm = sub.add_parser("time")
    tm.add_argument("dir", type=Path)
    tm.add_argument("--ovito-python", default=sys.executable)
    tm.add_argument("--grid", type=int, nargs=3, default=(20, 20, 6))
    sr = sub.add_parser("series")
    sr.add_argument("dir", type=Path)
    sr.add_argument("--files", type=int, default=24)
    sr.add_argument("-n", type=int, default=3)
    sr.add_argument("--grid", type=int, nargs=3, default=(20, 20, 6))
    th = sub.add_parser("threads")
    th.add_argument("dir", type=Path)
    th.add_argument("--files", type=int, default=24)
    th.add_argument("-n", type=int, default=3)
    th.add_argument("--grid", type=int, nargs=3, default=(20, 20, 6))
    th.add_argument("--quantities", default="nu")
    th.add_argument("--counts", type=int, nargs="+", default=(1, 2))
    th.add_argument("--layout", choices=("series", "single", "gzip", "all"),
                    default="series")
    th.add_argument("--workers", type=int, nargs="*", default=())
    th.add_argument("--stages", action="store_true")
    args = ap.parse_args(argv)
    if args.what != "make":
        # the bytecode of the sources as they are, as an install leaves it (`make`): else,
        # after an edit and with PYTHONDONTWRITEBYTECODE set, each process compiles again
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(ROOT / "granavg")],
                       check=True)
    if args.what == "threads":
        for layout in (args.layout,) if args.layout != "all" else ("series", "single", "gzip"):
            threads_timing(args.dir, args.files, args.n, args.grid, args.quantities,
                           args.counts, layout, args.workers)
            if args.stages:
                stages(layouts(args.dir, args.files)[layout][0], args.grid, args.quantities,
                       args.counts, args.n)
    elif args.what == "make":
        make(args.dir, args.copies, args.frames)
    elif args.what == "series":
        series_timing(args.dir, args.files, args.n, args.grid)
    else:
        timing(args.dir, args.ovito_python, args.grid)


if __name__ == "__main__":
    main()
