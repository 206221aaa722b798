"""Shear a prepared packing with the reference DEM and write a granavg run directory.

The same dumps as a LAMMPS run (per-atom and per-contact, granavg's formats, SI units),
so :func:`granavg.pipeline.runs.average_run` and the analysis read both. Used through
``granavg simulate --engine reference --start RUN/prepared.data``; see docs/refdem.md.
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from granavg.io.contacts import COLUMNS, FORMAT, contact_table, radius_by_id
from granavg.io.dumpfile import open_text, write_frame
from granavg.io.lammps_data import read_data
from granavg.sim.refdem import Disks, ReferenceDEM
from granavg.sim.scene import Derived
from granavg.sim.run_layout import ATOMS, CONTACTS, dump_ext, is_dump_step, shear_bar

ATOM_COLUMNS = ["id", "type", "x", "y", "z", "vx", "vy", "vz", "omegaz", "radius", "mass"]
ATOM_FORMAT = ["%d", "%d"] + ["%.12g"] * 9

#: Atom types of the deck (granavg.io.contacts): 3 inner (rotating) wall, 4 outer wall.
INNER_WALL, OUTER_WALL = 3, 4


def reference_engine(start: Path, derived: Derived):
    """A :class:`ReferenceDEM` of the packing in ``start`` with the deck's walls.

    Returns the engine and the data file's atoms (ids, types, box).
    """
    data = read_data(start)
    t = data["type"]
    disks = Disks(x=data["x"], v=data["v"], omega=data["omega"], radius=data["radius"],
                  mass=data["mass"], frozen=t >= INNER_WALL)
    # fix move rotate turns at 2 pi / period, the period written with %.17g: the same double
    omega_move = 2 * math.pi / (2 * math.pi / derived.scene.Omega)
    dem = ReferenceDEM(disks, derived.coeffs, derived.dt, rotating=t == INNER_WALL,
                       Omega=omega_move, base=(derived.scene.mu_base, derived.scene.v_base,
                                                 derived.scene.base_every))
    return dem, data


def run_reference(out: Path, derived: Derived, start: Path, progress=None) -> None:
    """Shear for ``derived.n_shear`` steps, dumping like the deck (every ``dump_every``
    steps from ``n_dump_start``)."""
    dem, data = reference_engine(start, derived)
    s, d = derived.scene, dem.d
    mobile = np.flatnonzero(~d.frozen)
    ids, types = data["id"], data["type"]
    radius = radius_by_id(data["id"], data["radius"])
    ext = dump_ext(s)
    with shear_bar(derived, 0, progress) as bar, \
            open_text(out / ATOMS.format(ext=ext), "wt") as fa, \
            (open_text(out / CONTACTS.format(ext=ext), "wt") if s.contacts else nullcontext()) as fc:
        for step in range(derived.n_shear + 1):
            if step:
                dem.step()
                if step % 100 == 0:
                    bar.update(100 * derived.dt)
            if not is_dump_step(step, derived):
                continue
            atoms = np.column_stack([ids[mobile], types[mobile], d.x[mobile],
                                     np.zeros(len(mobile)), d.v[mobile], np.zeros(len(mobile)),
                                     d.omega[mobile], d.radius[mobile], d.mass[mobile]])
            write_frame(fa, step, None, ATOM_COLUMNS, atoms, data["box"], ATOM_FORMAT, "ATOMS")
            if s.contacts:
                i, j, rows = dem.contact_rows()
                raw = np.column_stack([ids[i], ids[j], types[i], types[j], rows])
                write_frame(fc, step, step * derived.dt, COLUMNS, contact_table(raw, radius),
                            data["box"], FORMAT)

