"""granavg's dump reader against OVITO's ``import_file`` on the same file, same run.

    python benchmarks/reader_vs_ovito.py RUN_DIR [--ovito-python PYTHON]

The run's per-atom dump is decompressed to a plain file; granavg's reader (every
column) and OVITO's (``import_file`` + ``compute`` of every frame) read it, each the best
of three passes inside its own process, import and start-up left out. OVITO runs in
PYTHON (an interpreter that has the ``ovito`` module; default this one). OVITO is not a
dependency of granavg: without it the script says so and stops.
"""

import argparse
import gzip
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ovito_probe import ovito_version   # benchmarks/, beside this script

OVITO = """
import sys, time
from ovito.io import import_file
best = float("inf")
for _ in range(3):
    t0 = time.perf_counter()
    pipe = import_file(sys.argv[1], multiple_frames=True)
    for k in range(pipe.source.num_frames):
        pipe.compute(k)
    best = min(best, time.perf_counter() - t0)
print(best)
"""


def granavg_seconds(plain: Path) -> float:
    from granavg.io.reader import DumpReader
    list(DumpReader(plain, ["x"]))                          # load the compiled kernel
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for _frame in DumpReader(plain):
            pass
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--ovito-python", default=sys.executable)
    args = ap.parse_args(argv)
    version = ovito_version(args.ovito_python)
    if version is None:
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / "atoms.dump"
        plain.write_bytes(gzip.decompress((args.run / "atoms.dump.gz").read_bytes()))
        size = plain.stat().st_size / 1e6
        ours = granavg_seconds(plain)
        theirs = float(subprocess.run([args.ovito_python, "-c", OVITO, str(plain)],
                                      capture_output=True, text=True, check=True).stdout)
    print(f"| reader ({size:.1f} MB plain per-atom dump) | MB/s |\n|---|---|")
    print(f"| granavg DumpReader, all columns | {size / ours:.0f} |")
    print(f"| OVITO {version} import_file + compute per frame | {size / theirs:.0f} |")
    print(f"\ngranavg / OVITO: {theirs / ours:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
