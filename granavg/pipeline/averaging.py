"""The ``average`` command: profiles of run directories (one run, or several
realisations: an ensemble; :mod:`granavg.pipeline.runs`) or of anyone's dumps
(:mod:`granavg.pipeline.dumps`), in this process or on dask
(:mod:`granavg.pipeline.on_dask`), written as one set of outputs."""

from __future__ import annotations

import logging
from pathlib import Path

from granavg.engine.timing import OPTIONS
from granavg.extras import require
from granavg.io import validate
from granavg.io.output_set import OutputSet
from granavg.io.profiles_io import REPLICATES, TIMESERIES, write_profile_files
from granavg.pipeline.api import average

log = logging.getLogger(__name__)

#: The folder of a VTK time series' files, beside ``<out>.pvd``.
SERIES = ".vtu.d"


def average_to_file(run_dirs, out, *, parquet=False, netcdf=False, vtk=False, workers=None,
                    scheduler=None, atoms=None, contacts=None, progress=None,
                    **options) -> Path:
    """The ``average`` command: :func:`granavg.pipeline.api.average` of run directories
    (one run, or an ensemble; on dask with ``workers`` or ``scheduler``) or, without
    any, of the dumps ``atoms`` and ``contacts``, written to ``out`` (never over an
    existing result); with ``netcdf`` and ``vtk`` also as ``<out>.nc`` and ``<out>.vtu``
    (:mod:`granavg.io.field_files`; fields in time: ``<out>.pvd`` and the folder
    ``<out>.vtu.d``), the table last."""
    from granavg.analysis.regime import warn_if_inertial

    for wanted, extra in ((netcdf, "netcdf"), (vtk, "vtk"), (parquet, "parquet"),
                          (workers is not None, "dask"), (scheduler, "dask")):
        if wanted:
            name = {"dask": "workers" if workers is not None else "scheduler"}.get(extra,
                                                                                 extra)
            require(extra, name)
    if vtk:                  # refused before any work where the cells have no mesh
        from granavg.io.field_files import vtk_cells
        options = dict(options, check_cells=vtk_cells)
    in_time = any(options.get(k) is not None for k in OPTIONS if k != "t_max")
    vtk_files = (".pvd", SERIES) if in_time else (".vtu",)
    extra = (".nc",) * bool(netcdf) + vtk_files * bool(vtk)
    out = validate.free_output(Path(out), ("", ".json", REPLICATES, TIMESERIES, *extra))
    profiles = average(list(run_dirs) or None, atoms=atoms, contacts=contacts,
                       workers=workers, scheduler=scheduler, progress=progress, **options)
    if run_dirs:
        warn_if_inertial(profiles)
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
