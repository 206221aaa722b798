"""The ``average`` command: profiles of run directories (one run, or several
realisations: an ensemble; :mod:`granavg.pipeline.runs`) or of anyone's dumps
(:mod:`granavg.pipeline.dumps`), in this process or on dask
(:mod:`granavg.pipeline.on_dask`), written as one set of outputs."""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

from granavg.extras import require
from granavg.io import validate
from granavg.io.output_set import OutputSet
from granavg.io.profiles_io import REPLICATES, TIMESERIES, write_profile_files
from granavg.pipeline.api import run
from granavg.pipeline.spec import Spec

log = logging.getLogger(__name__)

#: The folder of a VTK time series' files, beside ``<out>.pvd``.
SERIES = ".vtu.d"


def average_to_file(spec: Spec, out, *, parquet=False, netcdf=False, vtk=False,
                    time_accuracy: float | None = None) -> Path:
    """The ``average`` command: the fields of the spec (:func:`granavg.pipeline.api.run`:
    run directories, one run or an ensemble, or anyone's files; on dask with its
    execution's workers or scheduler), written to ``out`` (never over an existing
    result); with ``netcdf`` and ``vtk`` also as ``<out>.nc`` and ``<out>.vtu``
    (:mod:`granavg.io.field_files`; fields in time: ``<out>.pvd`` and the folder
    ``<out>.vtu.d``), the table last. Fields in time with the momentum balance's
    estimated quadrature error get the dump interval that a median residual of
    ``time_accuracy`` needs (:func:`~granavg.analysis.time_balance.interval_forecast`),
    logged and in the sidecar (``meta["time"]["forecast"]``)."""
    from granavg.analysis.regime import warn_if_inertial
    from granavg.analysis.time_balance import TARGET, forecast_line, interval_forecast

    execution = spec.execution
    for wanted, extra in ((netcdf, "netcdf"), (vtk, "vtk"), (parquet, "parquet"),
                          (execution.workers is not None, "dask"),
                          (execution.scheduler, "dask")):
        if wanted:
            name = {"dask": "workers" if execution.workers is not None else
                    "scheduler"}.get(extra, extra)
            require(extra, name)
    if vtk:                  # refused before any work where the cells have no mesh
        from granavg.io.field_files import vtk_cells
        spec = replace(spec, execution=replace(execution, check_cells=vtk_cells))
    vtk_files = (".pvd", SERIES) if spec.averaging.time.in_time else (".vtu",)
    extra = (".nc",) * bool(netcdf) + vtk_files * bool(vtk)
    out = validate.free_output(Path(out), ("", ".json", REPLICATES, TIMESERIES, *extra))
    profiles = run(spec)
    if spec.source.runs:
        warn_if_inertial(profiles)
    forecast = interval_forecast(profiles, time_accuracy or TARGET) if profiles.in_time \
        else None
    if forecast is not None:
        profiles.meta["time"]["forecast"] = forecast
        log.info("%s", forecast_line(forecast))
    with OutputSet(out) as outputs:          # all of them, or none
        if netcdf or vtk:
            from granavg.io import field_files

            if vtk and profiles.in_time:
                field_files.write_vtk_series(profiles, outputs.temp(".pvd"),
                                             outputs.temp_dir(SERIES), out.name + SERIES)
            elif vtk:
                field_files.write_vtk(profiles, outputs.temp(".vtu"))
            if netcdf:
                field_files.write_netcdf(profiles, outputs.temp(".nc"))
        write_profile_files(profiles, outputs, parquet=parquet)
        outputs.commit()
    at = f" at {len(profiles.times)} times" if profiles.in_time else ""
    log.info("%d %s%s x %d frames -> %s (+ %s.json)", profiles.cells.n, profiles.cells.kind,
             at, profiles.frames_averaged, out, out.name)
    return out
