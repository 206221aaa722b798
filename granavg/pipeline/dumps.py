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
from granavg.io import formats, validate
from granavg.pipeline.description import WithBodyForces
from granavg.io.prefetch import Prefetched
from granavg.io.trajectory import Trajectory

log = logging.getLogger(__name__)


def average_dumps(atoms, contacts=None, *, progress=None, **options) -> Fields:
    """Fields of anyone's dumps (no run directory), in their own units
    (:func:`dump_averager`'s options; ``progress``: a progress bar, None on a terminal)."""
    return dump_averager(atoms, contacts, **options)[0].run(progress)


def dump_averager(atoms, contacts=None, *, cells=None, fmt=None, density=None,
                  quantities=None, t_min=None, block_time=None, gravity=None,
                  branch="contact", sectors="auto", check_cells=None, kernel=None,
                  width=None, scan_early=True, time=None, **source_options):
    """The averager of anyone's dumps (:func:`granavg.engine.api.averager`) and the
    frame source it reads (whose ``dropped`` counts rows left out).

    Parameters
    ----------
    atoms, contacts : path
        Per-atom file; per-contact file or None. ``atoms`` may be a
        :class:`~granavg.io.trajectory.Trajectory` (:func:`granavg.open`): its selected
        frames, ``contacts`` None.
    cells : Cells or dict
        The cells (:mod:`granavg.cells`), or options of the cells
        (:func:`granavg.engine.cells.from_options`: ``thickness`` in 2D; ``bins``,
        ``edges``, ``r_range``, ``center`` for rings or shells; ``slabs``, ``grid``,
        ``polar_grid``, the ranges, ...), lengths left to the dumps' box.
    fmt : str, optional
        Input format (:func:`granavg.io.formats.available`); default the one that claims
        the files.
    density : float, optional
        Material density (masses rho V^p: pi h a^2 disks, 4/3 pi a^3 spheres), unless the
        atoms carry masses.
    gravity : tuple of float, optional
        Gravitational acceleration (gx, gy[, gz]): a body force m g on every particle.
    branch : {"contact", "paper"}
        Where the branch vectors of Eqs. 5 and 7 end.
    sectors : "auto", int or None
        Sectors per cell along the symmetry direction (rings: phi; slabs: their length)
        for the errors' spatial replicas (:mod:`granavg.engine.uncertainty.structure`).
    kernel, width : optional
        A smoothing kernel (``lucy``, ``gauss``, ``heaviside``; :mod:`granavg.engine.
        smoothing`) and its width, in the dumps' length unit: fields at the cells'
        centres instead of the cells' exact averages.
    check_cells : callable, optional
        Called with the cells before any frame is averaged (e.g. that an output can hold
        them); raises to refuse.
    time : dict, optional
        The time axis' options of :func:`granavg.engine.api.averager` (``t_max``,
        ``windows``, ``window_frames``, ``time_kernel``, ``time_width``, ``times``).
    scan_early : bool
        Pass over the frames before ``t_min`` by scanning, their rows not parsed, where
        the format can (LAMMPS dumps whose times are time step x dt); False reads them
        (a dask client, which needs only the first two frames).
    **source_options
        Options of the format (e.g. ``atom_map``, ``contact_map``, ``wall_types``,
        ``dt``, ``units`` for LAMMPS dumps; ``steps``, a time-step window, for a dask
        worker's chunk).
    """
    validate.positive("density", density)
    validate.positive("block_time", block_time)
    validate.positive("dt", source_options.get("dt"))
    validate.finite("t_min", t_min)
    if source_options.get("contact_map") and contacts is None:
        raise ParameterError("contact_map", "{param} maps the columns of a contact dump: "
                             "give it ({contacts}), or leave the map out")
    frames = atoms.source(checked=False) if isinstance(atoms, Trajectory) else \
        formats.open_frames(atoms, contacts, fmt=fmt, **source_options)
    if scan_early and t_min and hasattr(frames, "skip_before"):
        frames.skip_before(t_min)
    dim = getattr(frames, "dim", 2)
    space = Space(dim, frames.box, getattr(frames, "periodic", None) or (lambda: (False,) * 3),
                  getattr(frames, "tilt", None) or (lambda: (0.0, 0.0, 0.0)),
                  getattr(frames, "dim_reason", None))
    built = cells if isinstance(cells, Cells) else from_options(space, **(cells or {}))
    cells_of_options = smooth(built, kernel, width)
    if check_cells is not None:
        check_cells(cells_of_options)
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
    avg = averager(Prefetched(frames), cells_of_options, rho_p=density, quantities=quantities,
                   t_min=t_min, block_time=block_time, units=frames.units,
                   branch=branch, sectors=sectors, **(time or {}))
    avg.meta.update({"files": frames.files if isinstance(atoms, Trajectory) else {
                         "atoms": str(atoms), "contacts": str(contacts) if contacts else None},
                     "inputs": {"format": frames.format_name,
                                **({"thickness": getattr(built, "h", None)} if dim == 2
                                   else {}),
                                "density": density, **frames.describe()},
                     "body_forces": [t.describe for t in terms]})
    return avg, frames
