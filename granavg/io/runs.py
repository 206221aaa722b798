"""Averaging runs from their files: a run directory's manifest and dumps -> a
:class:`~granavg.engine.average.CellAverage` with granavg's defaults, and several
realisations -> ensemble profiles (SI units)."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from granavg import __version__
from granavg.engine.average import MAX_BLOCKS, CellAverage, warn_if_drifting
from granavg.engine.geometry import Rings
from granavg.engine.profiles import Profiles
from granavg.engine.quantities import groups_for, needed_columns
from granavg.engine.combine import combine_runs
from granavg.engine.quantities import QUANTITIES
from granavg.engine.timeseries import TimeSeries, ensemble_stationarity
from granavg.engine.units import SI
from granavg.errors import UserError
from granavg.io.reader import DumpReader
from granavg.io.run_dumps import RunDumps
from granavg.io.run_directory import read_manifest
from granavg.io.validate import check_manifest, run_directory

log = logging.getLogger(__name__)


def average_run(run_dir=None, *, bins=None, edges=None, t_min=None, block_time=None,
                quantities=None, atoms=None, contacts=None, progress=None) -> Profiles:
    """Ring profiles of a run directory (or of dump files with a manifest beside them).

    Parameters
    ----------
    run_dir : path, optional
        A ``granavg simulate`` directory: manifest (geometry, h, rho_p, dt, Omega) and
        dumps.
    bins : int, optional
        Number of equal rings between R_i and R_o; or ``edges`` (m).
    t_min : float, optional
        Start of the average (s); default the scene's discarded transient,
        ``discard_rotations`` x T (T = 2 pi / Omega; two rotations for older manifests).
    block_time : float, optional
        Length (s) of the base blocks of the blocking analysis; default one dump
        interval (at most 512 blocks over the averaged span).
    quantities : sequence of str, optional
        Keys of :data:`~granavg.profiles.QUANTITIES`; default all that the files allow.
    atoms, contacts : path, optional
        Dump files to use instead of the run directory's.

    See :func:`granavg.parallel.average_run_dask` for the same on dask workers.
    """
    return run_averager(run_dir, bins=bins, edges=edges, t_min=t_min, block_time=block_time,
                        quantities=quantities, atoms=atoms, contacts=contacts).run(progress)


def run_averager(run_dir, *, bins=None, edges=None, t_min=None, block_time=None,
                 quantities=None, atoms=None, contacts=None, steps=None) -> CellAverage:
    """The :class:`CellAverage` of :func:`average_run`, its frames read lazily (only
    those with time steps in ``steps = (first, last)`` if given)."""
    if run_dir is None:
        raise UserError("give the run directory: its manifest holds h, rho_p and the rings")
    run_dir = run_directory(run_dir)
    manifest = check_manifest(read_manifest(run_dir), run_dir / "manifest.json")
    scene, derived = manifest["scene"], manifest["derived"]
    ext = "dump.gz" if scene.get("gzip", True) else "dump"
    atoms = Path(atoms) if atoms else run_dir / f"atoms.{ext}"
    if contacts is None and (run_dir / f"contacts.{ext}").exists():
        contacts = run_dir / f"contacts.{ext}"
    groups = groups_for(quantities, contacts is not None)
    atom_cols, contact_cols = needed_columns(groups)
    need_contacts = any(QUANTITIES[g][2] for g in groups)
    reader_a = DumpReader(atoms, _order(atom_cols), atom_cols, steps)
    reader_c = DumpReader(contacts, _order(contact_cols), contact_cols, steps) \
        if need_contacts else None
    averager = ring_average(manifest, groups, bins=bins, edges=edges, t_min=t_min,
                            block_time=block_time,
                            frames=RunDumps(reader_a, reader_c, dt=derived["dt_s"]))
    averager.meta["files"] = {"atoms": str(atoms),
                              "contacts": str(reader_c.path) if reader_c else None}
    return averager


def ring_average(manifest: dict, groups, *, bins=None, edges=None, t_min=None,
                 block_time=None, frames=None) -> CellAverage:
    """A :class:`CellAverage` of a run (its manifest) with granavg's defaults: 20 equal
    rings from R_i to R_o, t_min = the scene's discarded rotations, base blocks of one dump
    interval (at most 512). Its profiles' ``meta`` describe the average (SI units)."""
    scene, derived = manifest["scene"], manifest["derived"]
    rings = Rings(np.asarray(edges, float), scene["h"]) if edges is not None else \
        Rings.count(20 if bins is None else bins, scene["R_i"], scene["R_o"], scene["h"])
    T = 2 * math.pi / scene["Omega"]
    t_min = scene.get("discard_rotations", 2.0) * T if t_min is None else float(t_min)
    t_end = derived["t_end_s"]
    block_time = block_time or max(derived["dump_interval_s"], (t_end - t_min) / MAX_BLOCKS)
    series = TimeSeries(scene["R_i"], scene["R_o"], scene["h"], scene["rho_p"], scene["d_s"])
    avg = CellAverage(frames, rings, groups, scene["rho_p"], t_min, block_time, series)
    avg.meta = {
        "granavg_version": __version__, "units": SI.label, "unit_system": SI.describe(),
        "quantities": list(groups), "rings": {"edges_m": list(rings.edges), "h_m": rings.h},
        "geometry": rings.describe(),
        "frames": {"t_min_s": t_min, "block_time_s": block_time},
        "run_manifest": manifest,
    }
    return avg


def _order(cols: dict) -> list:
    return sorted(cols, key=list(cols).index)


def average_runs(run_dirs, average, **options):
    """Average several runs with ``average(run_dir, **options)`` and combine them
    (:func:`combine_runs`) and judge the ensemble's window
    (:func:`~granavg.engine.timeseries.ensemble_stationarity`); one run gives its own
    profiles unchanged."""
    profiles = [average(d, **options) for d in run_dirs]
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
