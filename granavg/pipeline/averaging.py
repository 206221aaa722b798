"""The ``average`` command: profiles of run directories (one run, or several
realisations: an ensemble; :mod:`granavg.pipeline.runs`) or of anyone's dumps
(:mod:`granavg.pipeline.dumps`), in this process or on dask
(:mod:`granavg.pipeline.on_dask`), written as one set of outputs."""

from __future__ import annotations

import logging
from pathlib import Path

from granavg.engine.average import warn_if_drifting
from granavg.engine.combine import combine_runs
from granavg.engine.profiles import Profiles
from granavg.engine.stationarity import ensemble_stationarity
from granavg.errors import ParameterError
from granavg.extras import require
from granavg.io import validate
from granavg.io.output_set import OutputSet
from granavg.io.profiles_io import REPLICATES, TIMESERIES, write_profile_files
from granavg.pipeline.dumps import average_dumps
from granavg.pipeline.on_dask import average_dumps_dask, average_run_dask
from granavg.pipeline.runs import average_run

log = logging.getLogger(__name__)


def average_runs(run_dirs, average_one=average_run, **options) -> Profiles:
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
    warn_if_drifting(ensemble_stationarity([r["stationarity"] for r in combined.meta["runs"]]),
                     combined.meta.get("frames", {}).get("t_min_s", float("nan")))
    return combined


def average_to_file(run_dirs, out, *, parquet=False, netcdf=False, vtk=False, workers=None,
                    scheduler=None, atoms=None, contacts=None, progress=None,
                    **options) -> Path:
    """The ``average`` command: profiles of run directories (one run, or an ensemble;
    on dask with ``workers`` or ``scheduler``) or, without any, of the dumps ``atoms``
    and ``contacts`` (``options`` as :func:`average_dumps` takes them), written to ``out``
    (never over an existing result); with ``netcdf`` and ``vtk`` also as ``<out>.nc``
    and ``<out>.vtu`` (:mod:`granavg.io.field_files`), the table last."""
    from granavg.analysis.claims import warn_if_inertial     # the analysis, when used

    for wanted, extra in ((netcdf, "netcdf"), (vtk, "vtk"), (parquet, "parquet"),
                          (workers is not None, "dask"), (scheduler, "dask")):
        if wanted:
            name = {"dask": "workers" if workers is not None else "scheduler"}.get(extra,
                                                                                 extra)
            require(extra, name)
    if vtk:                  # refused before any work where the cells have no mesh
        from granavg.io.field_files import vtk_cells
        options = dict(options, check_cells=vtk_cells)
    extra = (".nc",) * bool(netcdf) + (".vtu",) * bool(vtk)
    out = validate.free_output(Path(out), ("", ".json", REPLICATES, TIMESERIES, *extra))
    if workers is not None and workers < 1:
        raise ParameterError("workers", f"{{param}} {workers}: must be >= 1 (leave it out to "
                             "average in this process)")
    if run_dirs:
        profiles = average_run_dirs(run_dirs, atoms, contacts, workers, scheduler,
                                     progress, options)
        warn_if_inertial(profiles)
    else:
        if not atoms:
            raise ParameterError("atoms", "give a run directory, or a LAMMPS dump with "
                                 "{param} (and {contacts})")
        atoms = validate.existing_file("atoms", atoms)
        contacts = validate.existing_file("contacts", contacts)
        if workers is not None or scheduler:
            profiles = average_dumps_dask(atoms, contacts, workers=workers or 2,
                                          scheduler=scheduler, **options)
        else:
            profiles = average_dumps(atoms, contacts, progress=progress, **options)
    with OutputSet(out) as outputs:          # all of them, or none
        if netcdf or vtk:
            from granavg.io import field_files

            if vtk:
                field_files.write_vtk(profiles, outputs.temp(".vtu"))
            if netcdf:
                field_files.write_netcdf(profiles, outputs.temp(".nc"))
        write_profile_files(profiles, outputs, parquet=parquet)
        outputs.commit()
    log.info("%d %s x %d frames -> %s (+ %s.json)", profiles.cells.n, profiles.cells.kind,
             profiles.n_frames, out, out.name)
    return out


def average_run_dirs(run_dirs, atoms, contacts, workers, scheduler, progress, options):
    """Profiles of run directories (one, or an ensemble; on dask with ``workers`` or
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
