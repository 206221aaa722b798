"""granavg's Python API: :func:`average` any source over any cells into
:class:`~granavg.engine.fields.Fields`, :func:`read` fields written before, and
:func:`rheology`, their local rheology. The ``average`` command is this function and its
outputs' writers; the ``rheology`` command is :func:`rheology` and its."""

from __future__ import annotations

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
from granavg.pipeline.spec import Spec

log = logging.getLogger(__name__)


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
    return run(Spec.of(source, atoms=atoms, contacts=contacts, cells=cells,
                       quantities=quantities, kernel=kernel, width=width, t_min=t_min,
                       t_max=t_max, block_time=block_time, windows=windows,
                       window_frames=window_frames, time_kernel=time_kernel,
                       time_width=time_width, times=times, species=species, branch=branch,
                       sectors=sectors, workers=workers, scheduler=scheduler,
                       progress=progress, check_cells=check_cells, **options))


def run(spec: Spec) -> Fields:
    """The fields of an average's spec (:class:`~granavg.pipeline.spec.Spec`): of frames
    in this process, run directories (one, or an ensemble) or anyone's files, here or on
    dask; the spec in the sidecar (``meta["spec"]``)."""
    fields = _run(spec)
    fields.meta["spec"] = spec.to_dict()
    return fields


def _run(spec: Spec) -> Fields:
    src, on_dask = spec.source, spec.execution.on_dask
    if isinstance(src.frames, Trajectory):
        return _average_trajectory(spec)
    if src.frames is not None:
        from granavg.engine.api import averager
        from granavg.engine.cells.base import Cells
        from granavg.engine.smoothing import smooth

        if not isinstance(spec.cells, Cells):
            raise ParameterError("cells", "frames in memory need their {param} "
                                 "(granavg.cells), lengths given: there is no box to "
                                 "default to")
        return averager(src.frames, smooth(spec.cells, spec.kernel, spec.width),
                        spec.averaging, density=src.density).run(spec.execution.progress)
    if src.runs:
        return average_run_dirs(spec)
    if not src.atoms:
        raise ParameterError("atoms", "give a run directory, or a LAMMPS dump with "
                             "{param} (and {contacts})")
    validate.existing_file("atoms", src.atoms)
    validate.existing_file("contacts", src.contacts)
    if on_dask:
        from granavg.pipeline.on_dask import average_dumps_dask
        return average_dumps_dask(spec)
    from granavg.pipeline.dumps import average_dumps
    return average_dumps(spec)


def average_runs(spec: Spec, average_one=average_run) -> Fields:
    """Average the spec's run directories each with ``average_one(run_dir, spec)``,
    combine them (:func:`~granavg.engine.combine.combine_runs`) and judge the ensemble's
    window (:func:`~granavg.engine.stationarity.ensemble_stationarity`); one run gives its
    own profiles unchanged."""
    run_dirs = spec.source.runs
    profiles = [average_one(d, spec) for d in run_dirs]
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


def average_run_dirs(spec: Spec) -> Fields:
    """Fields of the spec's run directories (one, or an ensemble; on dask with its
    workers or scheduler), its ``atoms`` and ``contacts`` naming other dumps of one run."""
    src = spec.source
    for run_dir in src.runs:
        validate.run_directory(run_dir)
    validate.existing_file("atoms", src.atoms)
    if src.contacts and Path(src.contacts).is_dir():         # read only if needed
        validate.existing_file("contacts", src.contacts)
    if len(src.runs) > 1 and (src.atoms or src.contacts):
        raise ParameterError("atoms", "{param} and {contacts} name the dumps of one run; "
                             "give one run directory with them")
    return average_runs(spec, average_run_dask if spec.execution.on_dask else average_run)


def _average_trajectory(spec: Spec) -> Fields:
    """Fields of a Trajectory's selected frames (:func:`granavg.open`): the format's
    options are the Trajectory's; the averaging's are given here."""
    frames = spec.source.frames
    given = [k for k in spec.source.given()
             if k in formats.choose(frames.atoms, frames.fmt).accepts + ("fmt",)]
    if given:
        raise ParameterError(given[0], "{param} belongs to the files: give it to "
                             "granavg.open, which made these frames")
    if spec.execution.on_dask:
        raise ParameterError("workers", "{param}: a selection of frames averages in this "
                             "process; leave out {param}, or give the files")
    from granavg.pipeline.dumps import average_dumps
    return average_dumps(spec)


def read(path) -> Fields:
    """Fields written by ``granavg average`` (the table and its ``.json`` sidecar; the
    replicates and time series beside them where there are)."""
    from granavg.io.profiles_io import read_profiles

    if not Path(path).exists():
        raise UserError(f"{path}: not found; give a table written by 'granavg average'")
    return read_profiles(path)


def rheology(fields, **material) -> Fields:
    """The local rheology of fields, per cell, with errors from their replicates and
    flags where a number is undefined (:func:`granavg.analysis.rheology.rheology`): the
    columns of :data:`granavg.analysis.rheology.COLUMNS`, ``pressure``, ``shear_stress``,
    ``shear_rate``, ``inertial_number``, ``friction``, ``nu``, ``N1``, ``N2`` (3D),
    ``axes_angle`` (between the stress's and the strain rate's principal axes) and
    ``fluidity`` (docs/rheology.md).

    Parameters
    ----------
    fields : Fields or path
        Fields of :func:`average`, or a table written by ``granavg average`` (read with
        :func:`read`).
    **material
        ``diameter`` (float or dict: the particles' mean diameter in the fields' length
        unit, a mixture's species -> diameter; default the run's scene) and ``density``
        (their material density; default the run's scene or the density the fields
        were averaged with), as :func:`granavg.analysis.rheology.rheology` takes them.

    Returns
    -------
    Fields
        The rheology on the fields' cells; :func:`granavg.fit_mu_I` and
        :func:`granavg.fit_phi_I` fit the constitutive laws to one or several.

    Examples
    --------
    >>> import granavg
    >>> fields = granavg.average(granavg.examples.couette_2d.run, cells={"bins": 8},
    ...                          t_min=1.0)
    >>> rh = granavg.rheology(fields)
    >>> rh.units["pressure"], rh.units["inertial_number"], rh.units["axes_angle"]
    ('Pa', '1', 'deg')
    >>> rh.meta["rheology"]["from"]["diameter"]
    "the run's scene (mean)"
    """
    from granavg.analysis.rheology import rheology as local_rheology

    return local_rheology(fields if isinstance(fields, Fields) else read(fields), **material)
