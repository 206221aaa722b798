"""The engine's public entry: average in-memory frames over any cells, no files needed.

::

    from granavg.cells import Rings
    from granavg.engine import average
    fields = average(frames, Rings.count(20, 0.10, 0.25, h=0.006), density=1060.0)

``frames`` is any iterable of objects with ``timestep``, ``time`` (s), ``atoms`` (dict of
arrays: ``x y radius`` and, as the quantities need, ``vx vy omegaz id mass``) and
``contacts`` (dict of arrays ``id1 id2 wall fnx fny ftx fty nx ny overlap``, or None;
body forces on the disks as atoms' ``bx by``):
what the dump reader, a running LAMMPS or a dask worker produce alike. For spheres in 3D
cells (:class:`~granavg.engine.cells.boxes.Boxes`, ...) the atoms add ``z vz omegax omegay``
and the contacts ``fnz ftz nz``.
"""

from __future__ import annotations

import itertools
import logging

import numpy as np

from granavg.engine.cell_average import CellAverage
from granavg.engine.fields import Fields
from granavg.engine.gate import Gate
from granavg.engine.quantities import QUANTITIES
from granavg.engine.requirements import groups_for, missing_columns, optional_columns
from granavg.engine.spec import Averaging
from granavg.engine.species import Classes, Species
from granavg.engine.unit_system import SI, UnitSystem
from granavg.errors import ParameterError, UserError

log = logging.getLogger(__name__)

#: The sidecar's word on the means' weights when the data carry no masses.
UNWEIGHED = ("no masses in the data (no mass column, no material density): velocity and "
             "spin are weighted by the particles' volumes, their mass weights for one "
             "material density")


def average(frames, cells, *, progress: bool | None = False, density: float | None = None,
            units: UnitSystem = SI, **averaging) -> Fields:
    """Time-averaged profiles of ``frames`` over ``cells`` (Eqs. 1-7):
    :func:`averager`'s, run over every frame (``progress``: a progress bar; None: on
    a terminal). ``averaging``: the options of an average as keywords
    (:meth:`~granavg.engine.spec.Averaging.of`: ``quantities``, ``t_min``, ``t_max``,
    ``block_time``, ``windows``, ``species``, ``branch``, ``sectors``, ...)."""
    return averager(frames, cells, Averaging.of(**averaging), density=density,
                    units=units).run(progress)


def _with_columns(groups, requested: bool, frame, dim: int) -> tuple:
    """The groups whose columns the frame carries, and the others with the columns they
    lack (for the sidecar). A requested group without its columns
    is refused (one line naming the first missing column); of "all the data allow", the
    others are left out, said in one log line."""
    atoms = set(frame.atoms)
    contacts = set(frame.contacts) if frame.contacts is not None else None
    lacking = {g: missing_columns(g, atoms, contacts, dim) for g in groups}
    lacking = {g: m for g, m in lacking.items() if m}
    if lacking and requested:
        g, m = next(iter(lacking.items()))
        raise ParameterError("quantities", f"{g} needs the {m[0][0]} column {m[0][1]}, "
                             "which the data do not have; dump it (or map it to a column "
                             "of the dump), or leave " + g + " out of {param}")
    if lacking:
        log.info("left out, for want of columns in the data: %s", "; ".join(
            f"{g} (no {' '.join(c for _, c in m)})" for g, m in lacking.items()))
    return [g for g in groups if g not in lacking], {g: [c for _, c in m]
                                                     for g, m in lacking.items()}


#: The blocks of the displacements between frames (:mod:`granavg.engine.smoothing.
#: displacements`), which a sheared box's images do not carry.
DISPLACED = {"jmass", "djmass", "djmom"}


def _unsheared(groups, requested: bool, frame) -> list:
    """The groups without the displacements' fluxes where the box is sheared (its
    images' paths between frames slide with the tilt): a requested one is refused in
    one line; of "all the data allow" they are left out, said in one log line."""
    if getattr(frame, "shear", None) is None:
        return groups
    sliding = [g for g in groups if DISPLACED & set(QUANTITIES[g].blocks)]
    if sliding and requested:
        raise ParameterError("quantities", f"{sliding[0]} comes from the displacements "
                             "between frames, which granavg does not follow across a "
                             "sheared (tilted) box's faces; leave it out of {param} "
                             "(continuity_v gives the continuity residual there)")
    if sliding:
        log.info("left out, in a sheared box: %s (the displacements between frames)",
                 ", ".join(sliding))
    return [g for g in groups if g not in sliding]


def _taken_as_zero(groups, frame, dim: int) -> dict:
    """Optional contact columns the groups read and the frame lacks (the contact
    couple: a law without rolling resistance, or dumps that do not hold it), said in
    one log line; ``{column: what that means}`` for the sidecar."""
    if frame.contacts is None:
        return {}
    absent = {c: g for c, g in optional_columns(groups, dim).items()
              if c not in frame.contacts}
    if not absent:
        return {}
    cols = " ".join(absent)
    log.info("no contact couple (%s) in the contact data: taken as zero, so %s come from "
             "the contact forces alone (rolling and twisting resistance, if the law has "
             "any, are missed)", cols, ", ".join(dict.fromkeys(absent.values())))
    return {c: "not in the contact data: taken as zero (the couples come from the forces "
               "alone)" for c in absent}


def resolvable(cells, radius, warn: bool = True) -> None:
    """Refuse a kernel narrower than half the smallest particle radius: the fields
    would resolve single particles (a particle-resolved, not a continuum, picture);
    warn below the mean radius (``warn``)."""
    radius = np.asarray(radius, float)
    if not len(radius):
        return
    smallest = float(radius.min())
    if cells.width < 0.5 * smallest:
        raise ParameterError("width", f"{{param}} {cells.width:g}: below half the smallest "
                             f"particle radius ({smallest:g}), the fields would resolve "
                             "single particles; give a width of at least "
                             f"{0.5 * smallest:g} (a diameter or more for continuum "
                             "fields)")
    mean = float(radius.mean())
    if warn and cells.width < mean:
        log.warning("kernel width %g below the mean particle radius %g: the fields are "
                    "particle-resolved (layers show; the volume fraction at a node can "
                    "exceed 1), not continuum fields", cells.width, mean)


def averager(frames, cells, averaging: Averaging = Averaging(), *,
             density: float | None = None, units: UnitSystem = SI,
             series=None) -> CellAverage:
    """The averager of ``frames`` over ``cells`` (Eqs. 1-7): the one way every route
    (anyone's dumps, run directories, in situ, dask, ensembles, the scale study) builds
    its average, with every check and the same metadata. ``run()`` it, or
    ``prepare()``, ``add()`` frames, ``merge()`` other averagers' ``state()`` (disjoint
    frames: a dask worker's) and ``conclude()``.

    The quantities and the first block's length are chosen from the first two frames
    (kept); with ``frames`` None (frames fed later by ``add``: a running LAMMPS, a dask
    client merging its workers' sums) they must be given. The checks that need a frame
    (the kernel's width against the particles, the requested quantities' columns) are
    made on the first frame added.

    Parameters
    ----------
    frames : iterable or None
        Frames as described in the module docstring, in increasing time.
    cells : Cells
        The cells (:mod:`granavg.cells`: disks of height h in 2D, spheres in 3D), or the
        nodes of a smoothing kernel (:func:`granavg.engine.smoothing.smooth`).
    averaging : Averaging
        The engine's part of the spec (:class:`~granavg.engine.spec.Averaging`): the
        quantities (default all the frames allow), the frames averaged and the time axis
        (:class:`~granavg.engine.spec.TimeAxis`: t_min <= t <= t_max, each bound within
        :data:`~granavg.engine.timing.axes.TIME_TOLERANCE` of the frames' spacing; the
        blocking analysis' base block, default the first two frames' spacing; windows,
        or fields smoothed in time with their time derivatives and, with a smoothing
        kernel in space, the residuals of the continuity and momentum balance), the
        species of a mixture (partial fields on a ``species`` axis), where the branch
        vectors end, and the sectors of the errors' spatial replicas (rings: phi; slabs
        with a ``span``: their length; None for errors from time alone).
    density : float, optional
        Material density rho_p (kg/m^3): masses rho_p V^p (pi h a^2, or 4/3 pi a^3). Not needed
        when the atoms carry a ``mass`` column (kg), nor for quantities without mass (nu,
        v, omega, F, sigma, eps, coordination).
    units : UnitSystem
        The units the frames are in (:mod:`granavg.engine.unit_system`); only named in the
        sidecar (``meta["units"]``, ``meta["unit_system"]``), nothing is converted. The
        parameters above are in the same units (the SI names are those of SI frames).
    series : FrameObserver, optional
        Records the state of every frame (the Couette cell's, :mod:`granavg.sim`).

    Returns
    -------
    CellAverage
        Its fields (:meth:`~granavg.engine.cell_average.CellAverage.conclude`): values,
        standard errors, flags and jackknife replicates per cell, in ``units``.
    """
    source, gate = frames, Gate(cells.dim)
    quantities, time, species = averaging.quantities, averaging.time, averaging.species
    if frames is None:
        if quantities is None or time.block_time is None:
            raise ValueError("an averager fed later needs its quantities and block time")
        if species is not None and not isinstance(species, Classes):
            raise ParameterError("species", "{param}: the species are found in the first "
                                 "frame, which an averager fed later (in situ, dask "
                                 "workers of a run directory) does not see; average the "
                                 "dumps, or in one process")
        head, groups, lacking, has_mass = [], list(quantities), {}, True
        axis = time.axis()
        groups_for(groups, True, True, smooth=True, in_time=axis.derivative)
    else:
        it = iter(frames)
        head = list(itertools.islice(it, 2))
        if not head and time.t_min:     # a source may have scanned past the frames before
            raise ParameterError("t_min", f"no frame at t >= {time.t_min:g}, the start of "
                                 "the average ({param}); give an earlier one")
        if not head:
            raise UserError("no frame to average")
        gate.ahead(head)                # every check of the first two frames, now
        has_mass = "mass" in head[0].atoms
        spacing = gate.spacing
        # windows from t_min, else from the first frame
        axis = time.axis(spacing, time.t_min if time.t_min is not None else head[0].time)
        if axis.kind == "smoothed" and axis.origin is None:
            axis.origin = head[0].time          # a frame on the frames' grid
        kernel = getattr(cells, "kernel", None)
        groups = groups_for(quantities, head[0].contacts is not None, "bx" in head[0].atoms,
                            smooth=bool(kernel and kernel.smooth_edge),
                            in_time=axis.derivative, species=species is not None,
                            have_forces="fx" in head[0].atoms)
        groups, lacking = _with_columns(groups, quantities is not None, head[0], cells.dim)
        groups = _unsheared(groups, quantities is not None, head[0])
        if time.block_time is None:
            averaging = averaging.with_time(block_time=spacing if spacing is not None
                                            else 1.0)
        frames = itertools.chain(head, it)
    if density is not None and head and has_mass:
        log.info("the masses come from the atoms' mass column; the material density "
                 "given is not used")
    massive = [g for g in groups if QUANTITIES[g].needs_mass]
    unweighed = density is None and not has_mass
    if unweighed:
        if quantities is not None and massive:
            raise ParameterError("density", f"{massive[0]} needs masses: give the material "
                                 "density ({param}) or a mass column")
        groups = [g for g in groups if g not in massive]
    # without masses the mass-weighted means (velocity, spin) weigh by volume: one
    # material, of a density that cancels (UNWEIGHED)
    if head:                              # checked now; frames fed later: on the first
        check_frame(head[0], cells, groups)
    classes = species if isinstance(species, Classes) or species is None else \
        Species.parse(species).classes(head[0].atoms)
    averaging = averaging.with_time(t_min=time.t_min or 0.0)
    avg = CellAverage(frames, cells, groups, density if density is not None else 1.0,
                      averaging, series,
                      check=None if head else (lambda frame: check_frame(frame, cells, groups)),
                      source=source, axis=axis, classes=classes, gate=gate)
    t_min, t_max, block_time = (averaging.time.t_min, averaging.time.t_max,
                                averaging.time.block_time)
    window = {"t_min_s": t_min, **({"t_max_s": t_max} if t_max is not None else {}),
              "block_time_s": block_time}
    avg.meta = {"units": units.label, "unit_system": units.describe(), "quantities": groups,
                "geometry": cells.describe(), "frames": window}
    if lacking:
        avg.meta["left_out"] = {g: f"no {' '.join(c)} in the data" for g, c in lacking.items()}
    if unweighed:
        avg.meta["weights"] = UNWEIGHED
    zero = _taken_as_zero(groups, head[0], cells.dim) if head else {}
    if zero:
        avg.meta["taken_as_zero"] = zero
    return avg


def check_frame(frame, cells, groups) -> None:
    """The checks of an average that need a frame, made on the first one added: the
    kernel's width against the particles' radii, and the quantities' columns (one-line
    refusals)."""
    if getattr(cells, "kernel", None) is not None:
        resolvable(cells, frame.atoms["radius"])
    _with_columns(groups, True, frame, cells.dim)
