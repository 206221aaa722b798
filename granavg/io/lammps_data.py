"""Read a LAMMPS data file of ``atom_style sphere`` (as ``write_data`` writes it), SI units.

Used to start the reference DEM from the packing LAMMPS prepared (``prepared.data``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from granavg.errors import UserError
from granavg.io.dumpfile import open_text

#: Columns of the ``Atoms # sphere`` and ``Velocities`` sections.
ATOM_COLUMNS = ["id", "type", "diameter", "density", "x", "y", "z"]
VELOCITY_COLUMNS = ["id", "vx", "vy", "vz", "wx", "wy", "wz"]


def read_data(path) -> dict:
    """Atoms of a sphere-style data file (plain, or gzip by the ``.gz`` suffix), sorted by id.

    Returns
    -------
    dict
        ``id``, ``type`` (int, shape (N,)), ``x`` (N, 2) m, ``v`` (N, 2) m/s,
        ``omega`` (N,) rad/s, ``radius`` (N,) m and ``mass`` (N,) kg, computed as
        LAMMPS' ``read_data`` does (density * 4 pi r^3 / 3, bit for bit); ``box``
        (3, 2) m.
    """
    path = Path(path)
    try:
        with open_text(path) as fh:
            lines = fh.read().splitlines()
    except (OSError, EOFError) as exc:
        raise UserError(f"cannot read the data file {path}: "
                        f"{getattr(exc, 'strerror', None) or exc}") from None
    atoms = _section(path, lines, "Atoms", len(ATOM_COLUMNS))
    vel = _section(path, lines, "Velocities", len(VELOCITY_COLUMNS))
    atoms, vel = atoms[np.argsort(atoms[:, 0])], vel[np.argsort(vel[:, 0])]
    if not np.array_equal(atoms[:, 0], vel[:, 0]):
        raise UserError(f"{path}: the Atoms and Velocities sections list different atoms")
    radius = 0.5 * atoms[:, 2]
    volume = 4.0 * math.pi / 3.0 * radius * radius * radius
    box = [[float(w) for w in line.split()[:2]] for line in lines[:40]
           if line.split()[2:4] in (["xlo", "xhi"], ["ylo", "yhi"], ["zlo", "zhi"])]
    return {"box": np.array(box), "id": atoms[:, 0].astype(int), "type": atoms[:, 1].astype(int),
            "x": atoms[:, 4:6].copy(), "v": vel[:, 1:3].copy(), "omega": vel[:, 6].copy(),
            "radius": radius, "mass": atoms[:, 3] * volume}


def _section(path, lines, name, ncol) -> np.ndarray:
    """Rows of the named section (between its header and the next header)."""
    start = next((k for k, line in enumerate(lines) if line.split("#")[0].strip() == name),
                 None)
    if start is None:
        raise UserError(f"{path}: no '{name}' section; give a data file written by "
                        "LAMMPS' write_data (atom_style sphere), e.g. a run's prepared.data")
    rows = []
    for k in range(start + 1, len(lines)):
        text = lines[k].split("#")[0].strip()
        if not text:
            if rows:
                break
            continue
        parts = text.split()
        if not parts[0].lstrip("-").replace(".", "", 1).isdigit():
            break                                          # next section header
        if len(parts) < ncol:
            raise UserError(f"{path}:{k + 1}: {name} row has {len(parts)} columns, "
                            f"expected {ncol}; the file is truncated or not sphere style")
        rows.append([float(p) for p in parts[:ncol]])
    return np.array(rows, float).reshape(-1, ncol)
