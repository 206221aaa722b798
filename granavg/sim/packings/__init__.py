"""Shipped sheared packings: start states that leave the preparation's transient behind.

A packing set ``NAME`` is the directory ``NAME/`` beside this file: one LAMMPS data file
per seed, ``seed<N>.data.gz`` (the scene's disks grown from random positions with seed
N, then sheared for a while with the set's contact law), and ``provenance.json`` (the
command that made them, the law, how long they were sheared and their state at the
end), written by ``workflows/sheared_packings.py``. A scene with ``packing = NAME``
shears the file of its ``seed`` instead of growing a new packing; the data file holds
positions, velocities and spins (SI units) but no contact history, so tangential
springs start unloaded.
"""

from __future__ import annotations

import gzip
import json
import re
import shutil
from pathlib import Path

from granavg.errors import UserError

HERE = Path(__file__).parent
#: Name of the unpacked start file inside a run directory.
START = "start.data"


def seeds(name: str) -> list:
    """The seeds of the packings in set ``name`` (sorted)."""
    folder = HERE / name
    if not name or not folder.is_dir():
        known = sorted(p.name for p in HERE.iterdir() if (p / "provenance.json").is_file())
        raise UserError(f"packing {name!r}: no such shipped packing set; choose one of: "
                        f"{', '.join(known) or 'none shipped'}, or set packing= (empty) to "
                        "grow a new packing")
    return sorted(int(m.group(1)) for p in folder.iterdir()
                  if (m := re.fullmatch(r"seed(\d+)\.data\.gz", p.name)))


def provenance(name: str) -> dict:
    """What ``workflows/sheared_packings.py`` recorded about set ``name``."""
    return json.loads((HERE / name / "provenance.json").read_text())


def check(name: str, seed: int) -> Path:
    """The shipped file of ``seed`` in set ``name``; a one-line refusal if there is none."""
    have = seeds(name)
    if seed not in have:
        raise UserError(f"packing {name!r} has no packing grown from seed {seed}; shipped "
                        f"seeds: {', '.join(map(str, have))} (an ensemble of K realisations "
                        f"needs K of them), or set packing= (empty) to grow new ones")
    return HERE / name / f"seed{seed}.data.gz"


def unpack(name: str, seed: int, out: Path) -> Path:
    """Write the packing of ``seed`` in set ``name`` to ``out/start.data`` (LAMMPS reads
    plain data files); returns its path."""
    target = Path(out) / START
    with gzip.open(check(name, seed), "rb") as src, open(target, "wb") as dst:
        shutil.copyfileobj(src, dst)
    return target


def describe(name: str, seed: int) -> str:
    """One line for the manifest and report: which packing and how it was made."""
    p = provenance(name)
    before = ""
    if p.get("started_from"):
        first = provenance(p["started_from"])
        before = f"sheared {first['aged_s']:g} s with {first['law']}, then "
    aged = p["aged_s"] - (provenance(p["started_from"])["aged_s"] if before else 0.0)
    return (f"shipped sheared packing {name}/seed{seed} (grown from seed {seed}, {before}"
            f"sheared {aged:g} s with {p['law']}; {without_paths(p['made_by'])}); contacts "
            "start with unloaded tangential springs")


def without_paths(text):
    """Text (the command that made a packing, a preparation), its absolute paths (those
    of the machine that made it) as OUT; None stays None."""
    if text is None:
        return None
    return " ".join("OUT" if word.startswith("/") else word for word in text.split(" "))
