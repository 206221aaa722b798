"""Write LAMMPS text dumps (``dump local`` format), gz or not; reading is in
:mod:`granavg.io.reader`."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np


def open_text(path, mode="rt"):
    """Open a plain or gzip text file (chosen by the ``.gz`` suffix).

    gzip output uses level 1: 2.7x faster than Python's default 9 on a contact frame,
    for files 10% larger (measured on the demo's contact dump).
    """
    path = Path(path)
    if path.suffix == ".gz":
        return gzip.open(path, mode, compresslevel=1) if "r" not in mode else gzip.open(path, mode)
    return open(path, mode)


def write_frame(fh, timestep, time, columns, data, box, fmt, item="ENTRIES"):
    """Write one frame in LAMMPS dump text format (``dump local`` style by default;
    ``item="ATOMS"`` for a per-atom dump). ``time=None`` leaves out the UNITS and TIME
    items, as granavg's per-atom dumps do."""
    when = [] if time is None else ["ITEM: UNITS", "si", "ITEM: TIME", repr(float(time))]
    head = when + [
        "ITEM: TIMESTEP", str(timestep),
        f"ITEM: NUMBER OF {item}", str(len(data)), "ITEM: BOX BOUNDS ff ff pp",
        *(f"{lo:.16e} {hi:.16e}" for lo, hi in box),
        f"ITEM: {item} " + " ".join(columns),
    ]
    fh.write("\n".join(head) + "\n")
    row = " ".join(fmt)                  # one %-format per row: 1.5x faster than savetxt
    fh.write("".join(row % tuple(values) + "\n" for values in np.asarray(data).tolist()))
