"""granavg's Python API: :func:`average` any source over any cells into
:class:`~granavg.engine.fields.Fields`, and :func:`read` fields written before. The
``average`` command is this function and its outputs' writers."""

from __future__ import annotations

import os
from pathlib import Path

import logging

from granavg.engine.cell_average import warn_if_drifting
from granavg.engine.combine import combine_runs
from granavg.engine.fields import Fields
from granavg.engine.stationarity import ensemble_stationarity
from granavg.errors import ParameterError, UserError
from granavg.io import formats, validate
from granavg.io.trajectory import Trajectory
from granavg.pipeline.on_dask import average_run_dask
from granavg.pipeline.runs import average_run

log = logging.getLogger(__name__)

#: Options of anyone's files that are not a format's: a run directory's manifest says
#: them instead (with the formats' own options, :func:`dump_options`).
AVERAGING_OF_FILES = ("density", "gravity", "fmt")


def dump_options() -> tuple:
    """The options of anyone's files: :data:`AVERAGING_OF_FILES` and every format's
    (:func:`granavg.io.formats.options`)."""
    return AVERAGING_OF_FILES + tuple(formats.options())


def average(source=None, *, cells=None, atoms=None, contacts=None, quantities=None,
            kernel=None, width=None, t_min=None, t_max=None, block_time=None,
            windows=None, window_frames=None, time_kernel=None, time_width=None,
            times=None, species=None, branch="contact", sectors="auto", workers=None,
            scheduler=None,
            progress=False, check_cells=None, **options) -> Fields:
    """Time-averaged continuum fields of DEM data over cells (Eqs. 1-7 of Luding et al.
    2001, with a smoothing kernel their coarse-grained forms), with standard errors.

    Parameters
    ----------
    source : path, list of paths, Trajectory or iterable of frames, optional
        A run directory of ``granavg simulate`` (manifest and dumps); several: the
        realisations of one scene, combined into an ensemble with between-run errors; a
        dump file, ``dump.*`` series or glob (the per-atom dump; ``contacts`` the
        per-contact one); frames of files opened by :func:`granavg.open`, or a selection
        of them (``frames[::10]``, ``frames.between(t0, t1)``); or frames in memory (objects with ``timestep``, ``time``,
        ``atoms`` and ``contacts``: a running LAMMPS, another engine in this process).
        None: give ``atoms``.
    cells : Cells or dict, optional
        The cells (:mod:`granavg.cells`: ``Rings``, ``Slabs``, ``Grid``, ``Boxes``, ...),
        or their options as the command line takes them, lengths defaulting to the
        data's box (``{"slabs": "z", "bins": 12}``, ``{"grid": (20, 20)}``); a run's
        default is 20 rings from R_i to R_o. Frames in memory need Cells.
    atoms, contacts : path, optional
        The per-atom and per-contact dumps (with a run directory: others than its own).
    quantities : sequence of str, optional
        What to average (:mod:`granavg.engine.quantities`); default all the data allow.
    kernel, width : optional
        A smoothing kernel (``exact``, the default, or one of
        :func:`granavg.engine.smoothing.registry`) and its width in the data's length
        unit: fields at the cells' centres, with their gradients.
    t_min, t_max : float, optional
        Average the frames with t_min <= t <= t_max.
    block_time : float, optional
        Base time blocks of the errors' blocking analysis (default one frame interval).
    windows, window_frames : optional
        Fields in time: one per window of this length of time, or of this many frames
        (:mod:`granavg.engine.timing`).
    time_kernel, time_width, times : optional
        Fields in time smoothed by a time kernel (``gauss``: width its standard
        deviation, cut at 3 widths; ``lucy``: width its half-length) at ``times``
        (START, STOP, STEP), with their time derivatives and, with a smoothing
        ``kernel`` in space, the residuals of the continuity and momentum balance.
    species : str or dict, optional
        A mixture's partial fields per species beside the whole's, on a ``species``
        axis (:mod:`granavg.engine.species`): ``"type"``, ``"radius"``,
        ``"radius:E1,E2"``, ``"small=1,2 large=3"`` or ``{"small": [1, 2], "large":
        [3]}``; with the force density between species ``f_inter``, the concentration
        ``c`` and the segregation flux ``seg_*``.
    branch : {"contact", "paper"}
        Where the branch vectors of Eqs. 5 and 7 end.
    sectors : "auto", int or None
        Spatial replicas for the errors (the cells' sectors).
    workers, scheduler : optional
        Average on a local dask cluster of this many processes, or on a scheduler's
        workers (the same fields).
    progress : bool or None
        A progress bar (None: on a terminal).
    check_cells : callable, optional
        Called with the cells before any frame is read (that an output can hold them);
        raises to refuse.
    **options
        Options of anyone's files: ``density`` (material density; or a mass column),
        ``gravity`` (a body force m g), ``fmt``, and the format's own
        (:func:`granavg.io.formats.options`: ``contact_map``, ``atom_map`` (our name ->
        dump column), ``wall_types``, ``dt``, ``units``, ``dim``, ``inertia``,
        ``liggghts``, ...).

    Returns
    -------
    Fields
        Values and standard errors on the cells' named axes (and ``time``, for fields in
        time), with units and the sidecar's metadata
        (:meth:`~granavg.engine.fields.Fields.to_xarray`,
        :meth:`~granavg.engine.fields.Fields.to_pandas`,
        :meth:`~granavg.engine.fields.Fields.plot`).

    Examples
    --------
    >>> import granavg
    >>> pile = granavg.examples.pile_3d
    >>> fields = granavg.average(pile.atoms, contacts=pile.contacts,
    ...                          contact_map=pile.contact_map, gravity=(0, 0, -9.81),
    ...                          cells={"slabs": "z", "range": (0, 0.024), "bins": 12})
    >>> fields.dims, fields.units["sigma_zz"]
    (('z',), 'Pa')
    >>> fields.to_xarray()["sigma_zz"].sel(z=0.011, method="nearest")   # doctest: +SKIP
    """
    unknown = sorted(set(options) - set(dump_options()))
    if unknown:
        raise ParameterError(unknown[0], "{param}: not an option of granavg.average")
    # the engine's axes beyond the cells: time, and the species of a mixture
    time = {k: v for k, v in dict(t_max=t_max, windows=windows, window_frames=window_frames,
                                  time_kernel=time_kernel, time_width=time_width,
                                  times=times, species=species).items() if v is not None}
    runs_given = isinstance(source, (list, tuple)) or (
        isinstance(source, (str, os.PathLike)) and Path(source).is_dir())
    if species is not None and (workers is not None or scheduler) and runs_given:
        raise ParameterError("species", "{param} on run directories averages in one "
                             "process: leave out {workers} (on dask the species of a "
                             "mixture are built for anyone's dumps)")
    common = dict(quantities=quantities, kernel=kernel, width=width, t_min=t_min,
                  block_time=block_time, branch=branch, sectors=sectors,
                  check_cells=check_cells, time=time or None)
    if workers is not None and workers < 1:
        raise ParameterError("workers", f"{{param}} {workers}: must be >= 1 (leave it out to "
                             "average in this process)")
    if isinstance(source, Trajectory):
        return _average_trajectory(source, workers or scheduler, progress, cells, common,
                                   options)
    if _frames(source):
        from granavg.engine.api import average as average_frames
        from granavg.engine.cells.base import Cells
        from granavg.engine.smoothing import smooth

        if not isinstance(cells, Cells):
            raise ParameterError("cells", "frames in memory need their {param} "
                                 "(granavg.cells), lengths given: there is no box to "
                                 "default to")
        return average_frames(source, smooth(cells, kernel, width), progress=progress,
                              rho_p=options.get("density"), quantities=quantities,
                              t_min=t_min, block_time=block_time, branch=branch,
                              sectors=sectors, **time)
    runs = [source] if isinstance(source, (str, os.PathLike)) and Path(source).is_dir() \
        else list(source) if isinstance(source, (list, tuple)) else []
    if runs:
        given = [k for k in dump_options() if options.get(k) not in (None, (), [])]
        if given:
            raise ParameterError(given[0], "{param} is for plain dumps; a run directory's "
                                 "manifest already says it (drop the option or the run "
                                 "directory)")
        return average_run_dirs(runs, atoms, contacts, workers, scheduler, progress,
                                dict(common, cells=cells))
    atoms = source if source is not None else atoms
    if not atoms:
        raise ParameterError("atoms", "give a run directory, or a LAMMPS dump with "
                             "{param} (and {contacts})")
    atoms = validate.existing_file("atoms", atoms)
    contacts = validate.existing_file("contacts", contacts)
    if workers is not None or scheduler:
        from granavg.pipeline.on_dask import average_dumps_dask
        return average_dumps_dask(atoms, contacts, workers=workers or 2,
                                  scheduler=scheduler, cells=cells, **common, **options)
    from granavg.pipeline.dumps import average_dumps
    return average_dumps(atoms, contacts, progress=progress, cells=cells, **common,
                         **options)


def average_runs(run_dirs, average_one=average_run, **options) -> Fields:
    """Average several runs with ``average_one(run_dir, **options)``, combine them
    (:func:`~granavg.engine.combine.combine_runs`) and judge the ensemble's window
    (:func:`~granavg.engine.stationarity.ensemble_stationarity`); one run gives its own
    profiles unchanged."""
    profiles = [average_one(d, **options) for d in run_dirs]
    if len(profiles) == 1:
        return profiles[0]
    seeds = [(p.meta.get("run_manifest") or {}).get("scene", {}).get("seed") for p in profiles]
    if len(set(seeds)) < len(seeds):
        log.warning("some runs share a seed (%s): they are not independent realisations "
                    "unless their packings differ otherwise", seeds)
    combined = combine_runs(profiles, [str(d) for d in run_dirs])
    if combined.in_time:
        return combined
    warn_if_drifting(ensemble_stationarity([r["stationarity"] for r in combined.meta["runs"]]),
                     combined.meta.get("frames", {}).get("t_min_s", float("nan")))
    return combined


def average_run_dirs(run_dirs, atoms, contacts, workers, scheduler, progress, options):
    """Fields of run directories (one, or an ensemble; on dask with ``workers`` or
    ``scheduler``), ``atoms`` and ``contacts`` naming other dumps of one run."""
    for run in run_dirs:
        validate.run_directory(run)
    validate.positive("block_time", options.get("block_time"))
    validate.finite("t_min", options.get("t_min"))
    validate.existing_file("atoms", atoms)
    if contacts and Path(contacts).is_dir():                 # read only if needed
        validate.existing_file("contacts", contacts)
    if len(run_dirs) > 1 and (atoms or contacts):
        raise ParameterError("atoms", "{param} and {contacts} name the dumps of one run; "
                             "give one run directory with them")
    options = dict(options, atoms=atoms, contacts=contacts)
    if workers is not None or scheduler:
        return average_runs(run_dirs, average_run_dask, workers=workers or 2,
                            scheduler=scheduler, **options)
    return average_runs(run_dirs, average_run, progress=progress, **options)


def _average_trajectory(frames, on_dask, progress, cells, common, options) -> Fields:
    """Fields of a Trajectory's selected frames (:func:`granavg.open`): the format's
    options are the Trajectory's; the averaging's are given here."""
    given = [k for k, v in options.items() if v not in (None, (), [])
             and k in formats.choose(frames.atoms, frames.fmt).accepts + ("fmt",)]
    if given:
        raise ParameterError(given[0], "{param} belongs to the files: give it to "
                             "granavg.open, which made these frames")
    if on_dask:
        raise ParameterError("workers", "{param}: a selection of frames averages in this "
                             "process; leave out {param}, or give the files")
    from granavg.pipeline.dumps import average_dumps
    return average_dumps(frames, None, progress=progress, cells=cells, **common, **options)


def _frames(source) -> bool:
    """Whether a source is frames in memory (not a path, nor a list of paths)."""
    if source is None or isinstance(source, (str, os.PathLike)):
        return False
    if isinstance(source, (list, tuple)):
        return bool(source) and not isinstance(source[0], (str, os.PathLike))
    return True


def read(path) -> Fields:
    """Fields written by ``granavg average`` (the table and its ``.json`` sidecar; the
    replicates and time series beside them where there are)."""
    from granavg.io.profiles_io import read_profiles

    if not Path(path).exists():
        raise UserError(f"{path}: not found; give a table written by 'granavg average'")
    return read_profiles(path)
