"""Particles from other engines' VTK files: one file per frame, a ``*`` in the name
standing for the time step (LIGGGHTS' ``dump custom/vtk 1000 atoms_*.vtk ...``, legacy
or XML), read with VTK's own readers (:mod:`granavg.io.vtk_read`).

The points are the centres; the point arrays give the rest by name (:data:`ALIASES`:
LIGGGHTS' ``id type radius mass v omega f``). A frame's time is its step (the number in
the file name) times ``dt``. The box is that of LIGGGHTS' ``*_boundingBox_*`` file of
the same step where there is one, else the particles' extent; no axis is taken as
periodic. VTK particle files carry no contacts: the kinematic fields only (density,
velocity, spin, kinetic stress); the stress needs the engine's contact dump with a text
atom dump (:mod:`granavg.io.liggghts`).
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np

from granavg.engine.gate import Origin
from granavg.engine.unit_system import SI
from granavg.errors import ParameterError, UserError, literal
from granavg.io.dump_units import choose_units
from granavg.io.formats import DT, UNITS, Format
from granavg.io.frames import Columns, Frame, check_atoms
from granavg.io.reader import numbered_series
from granavg.io.vtk_read import component, is_vtk, read_vtk

log = logging.getLogger(__name__)

#: Our atom column -> the point arrays that hold it (first found), and the component.
ALIASES = {"id": (("id", None),), "type": (("type", None),),
           "radius": (("radius", None), ("diameter", None)), "mass": (("mass", None),),
           **{f"v{x}": (("v", k), ("velocity", k)) for k, x in enumerate("xyz")},
           **{f"omega{x}": (("omega", k), ("angular_velocity", k)) for k, x in
              enumerate("xyz")},
           **{f"f{x}": (("f", k), ("force", k)) for k, x in enumerate("xyz")}}


class VtkAtoms:
    """Frames of a series of VTK particle files (see the module docstring).

    Parameters
    ----------
    atoms : path
        One file, or a pattern with ``*`` for the time step.
    dt : float
        The time step, in the data's time unit.
    units : str, optional
        LAMMPS units style of the numbers, for the labels (LIGGGHTS: si).
    steps : (int, int), optional
        Only the files whose step is in the window (a dask worker's chunk).
    """

    format_name = "vtk"
    dim = 3

    def __init__(self, atoms, contacts=None, *, dt=None, units=None, steps=None,
                 named_steps=False):
        if contacts is not None:
            raise ParameterError("contacts", f"{literal(atoms)}: VTK particle files carry "
                                 "no contacts and are not paired with a contact dump; for "
                                 "the stress give the engine's text atom dump with "
                                 "{contacts}")
        self.files = [(s, p) for s, p in numbered_series(atoms)
                      if steps is None or steps[0] <= s <= steps[1]]
        if dt is None:
            raise ParameterError("dt", f"{literal(atoms)}: VTK files hold no time; give "
                                 "the time step ({param}): a frame's time is the number in "
                                 "its name times it")
        self.path, self.dt = Path(atoms), dt
        self.units = choose_units(None, units) if units else SI
        self.units_said = units is not None
        self.dropped = {}
        self._first = None

    def describe(self) -> dict:
        return {"files": f"{len(self.files)} VTK files ({self.path})", "dt": self.dt,
                "dim": 3, "walls": "none: VTK particle files carry no contacts",
                "periodic": "none taken"}

    def _frame_data(self, step, path):
        data = read_vtk(path)
        cols = {x: data.points[:, k] for k, x in enumerate("xyz")}
        for ours, names in ALIASES.items():
            for name, comp in names:
                a = data.point_data.get(name)
                if a is not None and (comp is None) == (a.ndim == 1 or a.shape[1] == 1):
                    cols[ours] = component(path, data.point_data, name, comp)
                    if name == "diameter":
                        cols[ours] = 0.5 * cols[ours]
                    break
        if "radius" not in cols:
            raise UserError(f"{path}: no radius (or diameter) point array (arrays: "
                            f"{' '.join(data.point_data) or 'none'}); dump radius")
        return cols

    def box(self):
        """Per axis (lo, hi): LIGGGHTS' bounding-box file of the first step, else the
        first frame's particle extent."""
        step, path = self.files[0]
        stem = path.name.rsplit(f"_{step}", 1)[0]
        bb = sorted(path.parent.glob(f"{stem}_boundingBox_{step}.vt*")) if step >= 0 else []
        if bb:
            b = read_vtk(bb[0]).points
            return [(float(b[:, k].min()), float(b[:, k].max())) for k in range(3)]
        cols = self._frame_data(step, path)
        r = cols["radius"].max()
        return [(float(cols[x].min() - r), float(cols[x].max() + r)) for x in "xyz"]

    def periodic(self) -> tuple:
        return (False, False, False)

    def __iter__(self):
        for step, path in self.files:
            if step < 0:
                raise UserError(f"{path}: a single VTK file has no time step in its name; "
                                "give the series as a pattern with * for the step "
                                "(atoms_*.vtk)")
            cols = self._frame_data(step, path)

            class _Where:                        # what the checks name: file, row
                line, timestep = None, step
            checked = check_atoms(path, Columns(cols, _Where))
            yield Frame(step, step * self.dt, checked, None,
                        origin={"atoms": Origin(str(path))})


def _claims(path) -> bool:
    """A VTK file (or series), not Yade's spheres files (:mod:`granavg.io.yade_vtk`)."""
    path = Path(path)
    if re.search(r"spheres\.(\d+|\*)\.vtu$", path.name):
        return False
    try:
        first = numbered_series(path)[0][1] if "*" in path.name else path
    except UserError:
        return False
    return is_vtk(first)


FORMAT = Format("vtk", "VTK particle files, one per frame (LIGGGHTS' dump custom/vtk, "
                "legacy or XML): kinematic fields only", _claims, VtkAtoms,
                (DT, UNITS, "steps", "named_steps"))
