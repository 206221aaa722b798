"""Yade's VTK output (https://yade-dem.org) as frames: the spheres of ``VTKRecorder``
and, for the stress, the interactions of ``yade.export.VTKExporter``.

Atoms: the ``spheres`` files of ``VTKRecorder(fileName="out/pile-", recorders=["spheres",
"velocity", "mass", "id", "pericell"])``, ``out/pile-spheres.<step>.vtu``; give one, or
the series with a ``*`` for the step (``out/pile-spheres.*.vtu``). Their points (single
precision) are the centres, wrapped into a periodic cell; the point arrays ``radii``,
``id``, ``linVelVec``, ``angVelVec``, ``mass`` and ``materialId`` become ``radius``,
``id``, ``vx vy vz``, ``omegax omegay omegaz``, ``mass`` and ``type`` where present. A
frame's time is its step times ``dt`` (Yade's ``O.dt``: the files do not hold it). The
box is the periodic cell of the ``pericell`` file of the same step where there is one
(periodic along x, y and z, as Yade's cell), else the spheres' extent (no axis
periodic).

Contacts (optional): ``VTKExporter("out/pile").exportInteractions(ids=REAL,
what=INTERACTIONS, numLabel=O.iter)`` files, ``out/pile-intrs-<step>.vtk``, with
:data:`INTERACTIONS` as ``what`` (Yade's own names; ``REAL`` the real interactions'
``(i.id1, i.id2)``): converted as in process (:func:`granavg.io.yade.yade_contacts`); a
body whose id is not among the spheres is a wall. Each interaction's bodies, as
VTKExporter writes them, must lie at their spheres' centres and a wall at none
(:meth:`YadeVtk._centres`). VTKExporter prints 6 significant
digits (``%g``): forces and normals to 5e-6 of themselves, ids exactly below 10^6.
``VTKRecorder``'s own ``intr`` files are refused: they hold the normal force's magnitude
and the shear force's absolute components, no sign, no normal and no wall contact.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np

from granavg.engine.gate import Origin
from granavg.engine.kernels import lookup
from granavg.engine.unit_system import SI
from granavg.errors import ParameterError, UserError, literal
from granavg.io.box import Box
from granavg.io.formats import DT, Format
from granavg.io.frames import Columns, Frame, check_atoms, check_contacts
from granavg.io.reader import numbered_series
from granavg.io.vtk_read import component, is_vtk, read_vtk
from granavg.io.yade import DAMPED, yade_contacts

log = logging.getLogger(__name__)

#: The ``what`` of ``VTKExporter.exportInteractions`` this format reads.
INTERACTIONS = {"id1": "i.id1", "id2": "i.id2", "normal": "i.geom.normal",
                "penetrationDepth": "i.geom.penetrationDepth",
                "normalForce": "i.phys.normalForce", "shearForce": "i.phys.shearForce"}
#: The scalar arrays among :data:`INTERACTIONS` (the others are vectors).
SCALARS = ("id1", "id2", "penetrationDepth")
#: Our atom column -> (VTKRecorder's point array, component).
ATOM_ARRAYS = {"radius": ("radii", None), "id": ("id", None), "mass": ("mass", None),
               "type": ("materialId", None),
               **{f"v{x}": ("linVelVec", k) for k, x in enumerate("xyz")},
               **{f"omega{x}": ("angVelVec", k) for k, x in enumerate("xyz")}}
#: Ids VTKExporter's %g prints exactly.
EXACT_IDS = 1e6
#: How far an interaction's body may lie from its sphere, relative to the coordinates'
#: size: VTKExporter's %g (5e-6) and VTKRecorder's single precision (6e-8), with room.
PRINTED = 2e-5


def _steps(path) -> list:
    """(step, file) of one file or a ``*`` series; a single file's step from its name
    (``pile-spheres.2000.vtu``, ``pile-intrs-00002000.vtk``)."""
    found = numbered_series(path)
    if found[0][0] >= 0:
        return found
    match = re.search(r"(\d+)\.vt[kpu]$", Path(path).name)
    if match is None:
        raise UserError(f"{path}: no step in the name (Yade names its files "
                        "NAME-spheres.STEP.vtu and NAME-intrs-STEP.vtk); give Yade's file")
    return [(int(match.group(1)), Path(path))]


def _cells(steps) -> dict:
    """step -> VTKRecorder's ``pericell`` file beside each ``NAME-spheres.STEP.vtu``
    (found by its own name); empty where none is (an aperiodic scene). Refuses a series
    where some steps have one and others not."""
    cells = {}
    for step, path in steps:
        match = re.fullmatch(r"(.*)spheres(\.\d+\.vtu)", path.name)
        cell = path.with_name(f"{match.group(1)}pericell{match.group(2)}") if match else None
        if cell is not None and cell.exists():
            cells[step] = cell
    missing = [(step, path) for step, path in steps if step not in cells]
    if cells and missing:
        step, path = missing[0]
        has = next(iter(cells.values()))
        raise UserError(f"{path}: no pericell file beside it (step {step}), where "
                        f"{has.name} is: the periodic cell is lost for that step; record "
                        "pericell at every step (VTKRecorder recorders [..., 'pericell']), "
                        "or give only the steps that have it")
    return cells


class _Where:
    """A frame's step, for the checks' messages (the rows of a VTK file have no line)."""

    line = None

    def __init__(self, timestep):
        self.timestep = timestep


class YadeVtk:
    """Frames of Yade's VTK files (see the module docstring).

    Parameters
    ----------
    atoms : path
        VTKRecorder's spheres file, or their series (``*`` for the step).
    contacts : path, optional
        VTKExporter's interactions files (``*`` for the step), one per atoms' step.
    dt : float
        Yade's time step ``O.dt`` (s).

    Attributes
    ----------
    dropped : dict of str -> int
        Interactions left out (:func:`granavg.io.yade.yade_contacts`).
    """

    format_name = "yade-vtk"
    dim = 3

    def __init__(self, atoms, contacts=None, *, dt=None):
        if dt is None:
            raise ParameterError("dt", f"{literal(atoms)}: Yade's VTK files hold no time: "
                                 "give the time step ({param}, Yade's O.dt)")
        self.atoms, self.contacts, self.dt, self.units = atoms, contacts, float(dt), SI
        self.steps = _steps(atoms)
        self.contact_files = dict(_steps(contacts)) if contacts is not None else None
        self.dropped = {"contacts_not_touching": 0, "contacts_between_walls": 0}
        self.walls = None                # the wall bodies' ids seen so far
        self.cells = _cells(self.steps)
        self.cell = read_vtk(self.cells[self.steps[0][0]]).points if self.cells else None
        log.warning("%s: Yade's VTK files do not say whether NewtonIntegrator's local "
                    "damping was on; if it was: %s", atoms, DAMPED)

    def describe(self) -> dict:
        """The options the frames were read with, for the sidecar."""
        return {"dim": 3, "dt": self.dt, "periodic_cell": None if self.cell is None else
                [float(s) for s in np.ptp(self.cell, axis=0)],
                "walls": "the bodies not among the spheres",
                "inertia": {"shape": "sphere", "I": "2/5 m a^2", "why": "3D"}}

    def box(self) -> tuple:
        """Per axis (lo, hi): the periodic cell (``pericell``), else the first frame's
        spheres' extent."""
        if self.cell is not None:
            return tuple((float(lo), float(hi)) for lo, hi in
                         zip(self.cell.min(axis=0), self.cell.max(axis=0)))
        atoms = self._atoms(*self.steps[0])
        a = atoms["radius"]
        return tuple((float((atoms[x] - a).min()), float((atoms[x] + a).max())) for x in "xyz")

    def periodic(self) -> tuple:
        """Periodic along x, y and z where there is a ``pericell`` file (Yade's cell)."""
        return (self.cell is not None,) * 3

    def __iter__(self):
        for step, path in self.steps:
            atoms = self._atoms(step, path)
            contacts, box = None, self._box(step)
            if self.contact_files is not None:
                if step not in self.contact_files:
                    raise UserError(f"{path}: step {step} has no interactions file among "
                                    f"{self.contacts}; export the interactions at each "
                                    "step the spheres are recorded")
                contacts = self._contacts(step, self.contact_files[step], atoms, box, path)
            yield Frame(step, step * self.dt, atoms, contacts, box=box,
                        origin={"atoms": Origin(str(path)), "contacts": Origin(
                            str(self.contact_files[step])) if contacts is not None else None})

    def _box(self, step):
        """The step's periodic cell as its frame's box (None for an aperiodic scene)."""
        if not self.cells:
            return None
        cell = read_vtk(self.cells[step]).points
        return Box(tuple(map(float, cell.min(axis=0))), tuple(map(float, cell.max(axis=0))),
                   periodic=(True, True, True))

    def _atoms(self, step, path) -> dict:
        data = read_vtk(path)
        if "radii" not in data.point_data:
            raise UserError(f"{path}: no 'radii' array (arrays: "
                            f"{', '.join(data.point_data) or 'none'}); give VTKRecorder's "
                            "spheres file (recorders 'spheres', 'velocity', 'mass', 'id')")
        cols = dict(zip("xyz", data.points.T))
        for ours, (name, k) in ATOM_ARRAYS.items():
            if name in data.point_data:
                cols[ours] = component(path, data.point_data, name, k)
        return check_atoms(path, Columns(cols, _Where(step)))

    def _contacts(self, step, path, atoms, box, spheres) -> dict:
        data = read_vtk(path)
        arrays = data.cell_data
        if "forceN" in arrays or "absForceT" in arrays:
            raise UserError(f"{path}: VTKRecorder's interactions hold the normal force's "
                            "magnitude and the shear force's absolute components (no sign, "
                            "no wall contact): no stress from them; export the "
                            "interactions with yade.export.VTKExporter (docs/formats.md)")
        missing = [k for k in INTERACTIONS if k not in arrays]
        if missing:
            raise UserError(f"{path}: no {missing[0]!r} array (arrays: "
                            f"{', '.join(arrays) or 'none'}); export the interactions with "
                            "what=granavg.io.yade_vtk.INTERACTIONS")
        if "id" not in atoms:
            raise UserError(f"{self.atoms}: contacts need the spheres' ids (VTKRecorder "
                            "recorder 'id')")
        arrays = {k: component(path, arrays, k, None) if k in SCALARS else
                  np.column_stack([component(path, arrays, k, j) for j in range(3)])
                  for k in INTERACTIONS}
        ids = (arrays["id1"], arrays["id2"])
        if any(np.any(i >= EXACT_IDS) for i in ids):
            raise UserError(f"{path}: body ids of 10^6 or more, which VTKExporter's %g "
                            "prints inexactly; give the contacts another way (in process: "
                            "granavg.io.yade)")
        (r1, in1), (r2, in2) = (lookup(atoms["id"], i) for i in ids)
        if len(data.lines) == len(ids[0]):
            ends = [data.points[data.lines[:, k]] for k in (0, 1)]
            self._centres(path, spheres, step, box, atoms, ids, ends, ((r1, in1), (r2, in2)))
        radius = [np.where(found, atoms["radius"][np.where(found, rows, 0)], 0.0)
                  for rows, found in ((r1, in1), (r2, in2))]
        columns, dropped = yade_contacts(*ids, arrays["normal"], arrays["penetrationDepth"],
                                         arrays["normalForce"], arrays["shearForce"],
                                         *radius, (~in1).astype(int), (~in2).astype(int))
        for k, n in dropped.items():
            self.dropped[k] += n
        self._walls(path, step, np.concatenate([ids[0][~in1], ids[1][~in2]]))
        return check_contacts(path, Columns(columns, _Where(step)))

    def _centres(self, path, spheres, step, box, atoms, ids, ends, rows) -> None:
        """Refuse interactions whose bodies are not where the spheres file has them.

        VTKExporter writes each interaction's two bodies' positions (the second shifted
        by its periodic image); they must be the spheres' centres (to :data:`PRINTED`,
        up to a period of the cell), and a body taken as a wall (its id not among the
        spheres) must not sit at a sphere's centre. Else the spheres and interactions
        are of different steps or runs, or an id is damaged.
        """
        from scipy.spatial import cKDTree

        centres = np.column_stack([atoms[x] for x in "xyz"])
        lo = np.zeros(3) if box is None else np.asarray(box.lo)
        period = None if box is None else np.subtract(box.hi, box.lo)
        tree = cKDTree(_wrapped(centres - lo, period), boxsize=period)
        for end, (p, (row, found)) in enumerate(zip(ends, rows)):
            tol = PRINTED * (np.abs(p).max(axis=1) + np.abs(centres).max())
            off = p - centres[np.where(found, row, 0)]
            if period is not None:
                off -= period * np.round(off / period)
            off = np.abs(off).max(axis=1)
            bad = np.flatnonzero(found & (off > tol))
            if len(bad):
                k = bad[0]
                raise UserError(
                    f"{path}: interaction {k} (step {step}) puts body {int(ids[end][k])} "
                    f"at ({', '.join(f'{v:g}' for v in p[k])}), {off[k]:.3g} m from its "
                    f"centre in {spheres}: the spheres and the interactions are of "
                    "different steps or runs, or the id is damaged; give the files "
                    "VTKRecorder and VTKExporter wrote at one step of one run")
            walls = np.flatnonzero(~found)
            dist, near = tree.query(_wrapped(p[walls] - lo, period), p=np.inf)
            hit = np.flatnonzero(dist <= tol[walls])
            if len(hit):
                k = walls[hit[0]]
                raise UserError(
                    f"{path}: interaction {k} (step {step}) names body {int(ids[end][k])}, "
                    "not among the spheres, at the centre of sphere "
                    f"{int(atoms['id'][near[hit[0]]])} of {spheres}: the id is damaged "
                    "(a wall does not sit at a sphere's centre); export the interactions "
                    "again")

    def _walls(self, path, step, ids) -> None:
        """Say which bodies the interactions name that are not among the spheres (taken
        as walls): those of the first step in a log line, and a warning for one that
        first appears later (a wall added during the run, or a damaged file)."""
        found = set(np.unique(ids).astype(int).tolist())
        if self.walls is None:
            self.walls = found
            log.info("%s: bodies not among the spheres, taken as walls: %s", path,
                     " ".join(map(str, sorted(found))) or "none")
        elif found - self.walls:
            new = sorted(found - self.walls)
            log.warning("%s: step %d names body %d, not among the spheres and in no "
                        "interaction before: taken as a wall (walls so far: %s); if no wall "
                        "was added, the file is damaged", path, step, new[0],
                        " ".join(map(str, sorted(self.walls))))
            self.walls |= found


def _wrapped(x, period):
    """Coordinates from the cell's corner into [0, period) (unchanged: no period)."""
    if period is None:
        return x
    x = np.mod(x, period)
    return np.where(x >= period, 0.0, x)


def _claims(path) -> bool:
    """VTKRecorder's spheres files: ``NAME-spheres.STEP.vtu`` (or the series)."""
    path = Path(path)
    if not re.search(r"spheres\.(\d+|\*)\.vtu$", path.name):
        return False
    try:
        return is_vtk(numbered_series(path)[0][1] if "*" in path.name else path)
    except UserError:
        return False


FORMAT = Format("yade-vtk", "Yade's VTK output: VTKRecorder's spheres files (atoms), "
                "VTKExporter's interactions files (contacts)", _claims, YadeVtk, (DT,))
