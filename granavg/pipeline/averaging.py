"""Profiles from files: run directories (one run, or several realisations: an
ensemble; :mod:`granavg.pipeline.runs`), or anyone's dumps in any format
:mod:`granavg.io.formats` knows; and the ``average`` command that writes them."""

from __future__ import annotations

import logging
from pathlib import Path

from granavg.engine.api import averager
from granavg.engine.average import warn_if_drifting
from granavg.engine.combine import combine_runs
from granavg.engine.profiles import Profiles
from granavg.engine.timeseries import ensemble_stationarity
from granavg.errors import UserError
from granavg.io import formats, validate
from granavg.io.output_set import OutputSet
from granavg.io.profiles_io import REPLICATES, TIMESERIES, write_profile_files
from granavg.engine import body_forces
from granavg.pipeline.description import DumpAverage, WithBodyForces
from granavg.pipeline.on_dask import average_dumps_dask, average_run_dask
from granavg.pipeline.prefetch import Prefetched
from granavg.pipeline.runs import average_run

log = logging.getLogger(__name__)


def average_runs(run_dirs, average_one=average_run, **options) -> Profiles:
    """Average several runs with ``average_one(run_dir, **options)``, combine them
    (:func:`~granavg.engine.combine.combine_runs`) and judge the ensemble's window
    (:func:`~granavg.engine.timeseries.ensemble_stationarity`); one run gives its own
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


def average_dumps(atoms, contacts=None, *, progress=None, **options) -> Profiles:
    """Profiles of anyone's dumps (no run directory), in their own units
    (:func:`dump_averager`'s options; ``progress``: a progress bar, None on a terminal)."""
    avg, frames = dump_averager(atoms, contacts, **options)
    profiles = avg.run(progress)
    if any(frames.dropped.values()):
        profiles.meta["dropped"] = dict(frames.dropped)
    return profiles


def dump_averager(atoms, contacts=None, *, cells: dict, fmt=None, density=None,
                  quantities=None, t_min=None, block_time=None, gravity=None,
                  branch="contact", sectors="auto", check_cells=None, **source_options):
    """The averager of anyone's dumps (:func:`granavg.engine.api.averager`) and the
    frame source it reads (whose ``dropped`` counts rows left out).

    Parameters
    ----------
    atoms, contacts : path
        Per-atom file; per-contact file or None.
    cells : dict
        Options of :meth:`~granavg.pipeline.description.DumpAverage.of` (``thickness`` in
        2D; rings or shells, ``slabs`` or ``grid``).
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
        for the errors' spatial replicas (:mod:`granavg.engine.replicas`).
    check_cells : callable, optional
        Called with the cells before any frame is averaged (e.g. that an output can hold
        them); raises to refuse.
    **source_options
        Options of the format (e.g. ``atom_map``, ``contact_map``, ``wall_types``,
        ``dt``, ``units`` for LAMMPS dumps; ``steps``, a time-step window, for a dask
        worker's chunk).
    """
    validate.positive("--density", density)
    validate.positive("--block-time", block_time)
    validate.positive("--dt", source_options.get("dt"))
    validate.finite("--t-min", t_min)
    if source_options.get("contact_map") and contacts is None:
        raise UserError("--contact-columns maps the columns of a contact dump: give it "
                        "with --contacts, or leave the map out")
    frames = formats.open_frames(atoms, contacts, fmt=fmt, **source_options)
    dim = getattr(frames, "dim", 2)
    spec = DumpAverage.of(frames.box, dim=dim, periodic=getattr(frames, "periodic", None) or
                          (lambda: (False,) * 3), tilt=getattr(frames, "tilt", None) or
                          (lambda: (0.0, 0.0, 0.0)), why_2d=getattr(frames, "dim_reason", None),
                          **cells)
    if check_cells is not None:
        check_cells(spec.geometry)
    if gravity and frames.units.momentum_flux:
        raise UserError(f"--gravity with LAMMPS units {frames.units.style}: m g is not in "
                        "that style's force unit; give the body force as a per-atom column "
                        "(--atom-columns bx=COL,by=COL)")
    if gravity and len(gravity) != dim:
        raise UserError(f"--gravity {' '.join(map(str, gravity))}: give {dim} components "
                        f"for a {dim}D dump")
    terms = [body_forces.gravity(*gravity)] if gravity else []
    if terms:
        frames = WithBodyForces(frames, terms, spec.geometry, density)
    if frames.units.style == "unstated":
        log.info("%s does not say its units: the outputs are labelled 'unstated'; --units "
                 "STYLE names them", atoms)
    avg = averager(Prefetched(frames), spec.geometry, rho_p=density, quantities=quantities,
                   t_min=t_min or 0.0, block_time=block_time, units=frames.units,
                   branch=branch, sectors=sectors)
    avg.meta.update({"files": {"atoms": str(atoms), "contacts": str(contacts) if contacts
                               else None},
                     "inputs": {"format": frames.format_name,
                                **({"thickness": cells["thickness"]} if dim == 2 else {}),
                                "density": density, **frames.describe()},
                     "body_forces": [t.describe for t in terms]})
    return avg, frames


def average_to_file(run_dirs, out, *, parquet=False, netcdf=False, vtk=False, workers=None,
                    scheduler=None, atoms=None, contacts=None, progress=None,
                    **options) -> Path:
    """The ``average`` command: profiles of run directories (one run, or an ensemble;
    on dask with ``workers`` or ``scheduler``) or, without any, of the dumps ``atoms``
    and ``contacts`` (``options`` as :func:`average_dumps` takes them), written to ``out``
    (never over an existing result); with ``netcdf`` and ``vtk`` also as ``<out>.nc``
    and ``<out>.vtu`` (:mod:`granavg.io.field_files`), the table last."""
    from granavg.analysis.claims import warn_if_inertial     # the analysis, when used

    if vtk and run_dirs:
        raise UserError("--vtk is for grids, boxes and cylindrical shells of plain dumps; a "
                        "run's rings are 1D (--netcdf writes them)")
    extra = (".nc",) * bool(netcdf) + (".vtu",) * bool(vtk)
    out = validate.free_output(Path(out), ("", ".json", REPLICATES, TIMESERIES, *extra))
    if workers is not None and workers < 1:
        raise UserError(f"--workers {workers}: must be >= 1 (leave it out to average "
                        "in this process)")
    if run_dirs:
        profiles = _average_run_dirs(run_dirs, atoms, contacts, workers, scheduler,
                                     progress, options)
        warn_if_inertial(profiles)
    else:
        if not atoms:
            raise UserError("give a run directory, or a LAMMPS dump with --atoms (and "
                            "--contacts)")
        atoms = validate.existing_file("--atoms", atoms)
        contacts = validate.existing_file("--contacts", contacts)
        if vtk:
            from granavg.io.field_files import vtk_cells
            options = dict(options, check_cells=vtk_cells)
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
    log.info("%d %s x %d frames -> %s (+ %s.json)", profiles.rings.n, profiles.rings.kind,
             profiles.n_frames, out, out.name)
    return out


def _average_run_dirs(run_dirs, atoms, contacts, workers, scheduler, progress, options):
    for run in run_dirs:
        validate.run_directory(run)
    validate.positive("--block-time", options.get("block_time"))
    validate.finite("--t-min", options.get("t_min"))
    validate.existing_file("--atoms", atoms)
    if contacts and Path(contacts).is_dir():                 # read only if needed
        validate.existing_file("--contacts", contacts)
    if len(run_dirs) > 1 and (atoms or contacts):
        raise UserError("--atoms and --contacts name the dumps of one run; give one run "
                        "directory with them")
    options = dict(options, atoms=atoms, contacts=contacts)
    if workers is not None or scheduler:
        return average_runs(run_dirs, average_run_dask, workers=workers or 2,
                            scheduler=scheduler, **options)
    return average_runs(run_dirs, average_run, progress=progress, **options)
