"""Make the small data sets shipped as :mod:`granavg.examples` (granavg/examples/data/).

Usage::

    python workflows/make_examples.py [--out granavg/examples/data]

- ``couette_2d/``: a run directory of ``granavg simulate`` (manifest.json and its gzip
  dumps): the plain-law Couette cell of the test suite, 290 disks between R_i = 0.04 m
  and R_o = 0.0826 m sheared at Omega = 0.5 rad/s for 3 s after growing and relaxing,
  frames every 0.25 s (SI units).
- ``pile_3d/``: the last 3 frames of tests/decks/pile_3d_si.lmp (k_n = 20 N/m): about
  750 spheres at rest on a floor, periodic in x and y, written as a user writes them
  (default %g dumps, pair/local + property/local contacts; SI units).

Both are real LAMMPS runs of decks in this repository; re-running this script makes them
again (LAMMPS' results are reproducible on one machine, not bit for bit across them).
"""

from __future__ import annotations

import argparse
import gzip
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COUETTE = ["R_i=0.04", "R_o=0.0826", "n_small=250", "n_large=40", "Omega=0.5", "t_grow=1",
           "t_relax=1", "t_end=3", "t_dump_start=0", "dump_dt=0.25", "restart_dt=3"]
#: Frames of the pile kept (its last ones).
PILE_FRAMES = 3


def couette(out: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        sets = [a for s in COUETTE for a in ("--set", s)]
        subprocess.run([sys.executable, "-m", "granavg", "simulate", "--preset", "paper-hooke",
                        "--out", str(run), "--no-progress", *sets], check=True)
        out.mkdir(parents=True, exist_ok=True)
        for name in ("atoms.dump.gz", "contacts.dump.gz"):
            shutil.copyfile(run / name, out / name)
        manifest = json.loads((run / "manifest.json").read_text())
        for key in ("started", "finished", "timing"):        # this machine's, not the data's
            manifest.pop(key, None)
        (out / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")


def last_frames(text: str, n: int) -> str:
    """The last ``n`` frames of a LAMMPS text dump (a frame starts at its ``ITEM: TIME``
    where the dump has them, else at ``ITEM: TIMESTEP``), after what precedes the first
    frame (``ITEM: UNITS``, written once)."""
    lead = "^ITEM: TIME\n" if "ITEM: TIME\n" in text else "^ITEM: TIMESTEP\n"
    starts = [m.start() for m in re.finditer(lead, text, re.M)]
    return text[:starts[0]] + text[starts[-n]:]


def pile(out: Path) -> None:
    sys.path.insert(0, str(ROOT))
    from tests.test_3d_dumps import run_deck

    with tempfile.TemporaryDirectory() as tmp:
        run_deck(Path(tmp), kn=20.0)
        out.mkdir(parents=True, exist_ok=True)
        for name in ("atoms.dump", "contacts.dump"):
            text = last_frames((Path(tmp) / name).read_text(), PILE_FRAMES)
            with gzip.open(out / f"{name}.gz", "wt") as fh:
                fh.write(text)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "granavg" / "examples" / "data")
    args = p.parse_args()
    couette(args.out / "couette_2d")
    pile(args.out / "pile_3d")


if __name__ == "__main__":
    main()
