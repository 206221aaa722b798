"""Fields of anyone's dumps, no run directory, in any format :mod:`granavg.io.formats`
knows and in the dumps' own units: the frame source, the cells the options choose
(:func:`granavg.engine.cells.from_options` in the space the dumps give), the body
forces asked for, and the averager."""

from __future__ import annotations

import logging

from granavg.engine import body_forces
from granavg.engine.api import averager
from granavg.engine.cells import Space, from_options
from granavg.engine.cells.base import Cells
from granavg.engine.fields import Fields
from granavg.engine.smoothing import smooth
from granavg.errors import ParameterError, named
from granavg.io import formats
from granavg.pipeline.description import WithBodyForces
from granavg.pipeline.spec import Spec
from granavg.io.prefetch import Prefetched
from granavg.io.trajectory import Trajectory

log = logging.getLogger(__name__)


def average_dumps(spec: Spec) -> Fields:
    """Fields of anyone's dumps (no run directory), in their own units
    (:func:`dump_averager`), with the spec's progress bar."""
    return dump_averager(spec)[0].run(spec.execution.progress)


def dump_averager(spec: Spec, *, scan_early: bool = True, **chunk):
    """The averager of anyone's dumps (:func:`granavg.engine.api.averager`) and the
    frame source it reads (whose ``dropped`` counts rows left out).

    Parameters
    ----------
    spec : Spec
        The average (:class:`~granavg.pipeline.spec.Spec`): its source's files (or the
        selected frames of a :class:`~granavg.io.trajectory.Trajectory`), format,
        material density (masses rho V^p: pi h a^2 disks, 4/3 pi a^3 spheres, unless the
        atoms carry masses), gravity (a body force m g on every particle) and format
        options; its cells (or their options, lengths left to the dumps' box:
        :func:`granavg.engine.cells.from_options`), kernel and width in the dumps' length
        unit; its engine part; its execution's ``check_cells``, called with the cells
        before any frame is averaged.
    scan_early : bool
        Pass over the frames before ``t_min`` by scanning, their rows not parsed, where
        the format can (LAMMPS dumps whose times are time step x dt); False reads them
        (a dask client, which needs only the first two frames).
    **chunk
        A dask worker's chunk of the files: ``steps``, a time-step window, and
        ``named_steps``.
    """
    src, t_min = spec.source, spec.averaging.time.t_min
    atoms = src.frames if src.frames is not None else src.atoms
    contacts, density, gravity = src.contacts, src.density, src.gravity
    frames = atoms.source(checked=False) if isinstance(atoms, Trajectory) else \
        formats.open_frames(atoms, contacts, fmt=src.fmt, **src.options, **chunk)
    if scan_early and t_min and hasattr(frames, "skip_before"):
        frames.skip_before(t_min)
    dim = getattr(frames, "dim", 2)
    space = Space(dim, frames.box, getattr(frames, "periodic", None) or (lambda: (False,) * 3),
                  getattr(frames, "dim_reason", None))
    built = spec.cells if isinstance(spec.cells, Cells) else \
        from_options(space, **(spec.cells or {}))
    cells_of_options = smooth(built, spec.kernel, spec.width)
    if spec.execution.check_cells is not None:
        spec.execution.check_cells(cells_of_options)
    if gravity and frames.units.momentum_flux:
        raise ParameterError("gravity", f"{{param}} with LAMMPS units {frames.units.style}: "
                             "m g is not in that style's force unit; give the body force "
                             "as a per-atom column ({atom_map} bx=COL,by=COL)")
    if gravity and len(gravity) != dim:
        raise ParameterError("gravity", f"{{param}} {' '.join(map(str, gravity))}: give {dim} "
                             f"components for a {dim}D dump")
    terms = [body_forces.gravity(*gravity)] if gravity else []
    if terms:
        frames = WithBodyForces(frames, terms, cells_of_options, density)
    if frames.units.style == "unstated":
        log.info(named("%s does not say its units: the outputs are labelled 'unstated'; "
                       "name them with {units} (LAMMPS style: si, lj, ...)"), atoms)
    avg = averager(Prefetched(frames), cells_of_options, spec.averaging, density=density,
                   units=frames.units)
    avg.meta.update({"files": frames.files if isinstance(atoms, Trajectory) else {
                         "atoms": str(atoms), "contacts": str(contacts) if contacts else None},
                     "inputs": {"format": frames.format_name,
                                **({"thickness": getattr(built, "h", None)} if dim == 2
                                   else {}),
                                "density": density, **frames.describe()},
                     "body_forces": [t.describe for t in terms], "spec": spec.to_dict()})
    return avg, frames
