"""Ring averaging of a run: frames -> accumulators -> profiles (Eqs. 1-7), SI units.

:class:`RingAverage` follows MDAnalysis' ``AnalysisBase``: ``run()`` calls
``prepare``, ``add`` for every frame and ``conclude``; the results are one
:class:`RingProfiles`. In-situ averaging (:mod:`granavg.insitu`) calls the same three
steps with frames taken from a running LAMMPS. :func:`average_run` builds the readers for a run directory,
reading only the columns (and the contact dump only if) the requested quantities need.
"""

from __future__ import annotations

import json
import logging
import math
import os
import signal
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from . import __version__
from .accumulate import RingAccumulator
from .errors import UserError
from .kernels import CHANNELS, particle_channels, ring_sums
from .profiles import (ATOM_COLUMNS, CONTACT_COLUMNS, QUANTITIES, flags,
                       standard_errors, values)
from .reader import DumpReader, FramePairs
from .rundir import read_manifest
from .timeseries import DRIFT_Z, TimeSeries, stationarity
from .uncertainty import Replicates
from .validate import check_manifest, run_directory
from .weights import ring_weights

log = logging.getLogger(__name__)

#: Base time blocks of the blocking analysis: one per frame, at most this many.
MAX_BLOCKS = 512
#: Suffix of the replicate profiles written beside a profiles table.
REPLICATES = ".replicates.npz"
#: Suffix of the per-frame time series written beside a profiles table.
TIMESERIES = ".timeseries.csv"


@dataclass(frozen=True)
class Rings:
    """Rings [r_lo, r_hi) of height h: edges (m), volumes V = pi h (r_hi^2 - r_lo^2) (m^3)."""

    edges: np.ndarray
    h: float

    @classmethod
    def count(cls, n: int, r_inner: float, r_outer: float, h: float) -> "Rings":
        """``n`` equal-width rings between r_inner and r_outer (m)."""
        if n < 1:
            raise UserError(f"--bins {n}: need at least one ring")
        return cls(np.linspace(r_inner, r_outer, n + 1), h)

    def __post_init__(self):
        e = np.asarray(self.edges, dtype=float)
        if e.ndim != 1 or len(e) < 2 or not np.all(np.diff(e) > 0) or e[0] < 0:
            raise UserError(f"ring edges must be >= 0 and increasing, at least two (got {list(e)})")
        object.__setattr__(self, "edges", e)

    @property
    def n(self) -> int:
        return len(self.edges) - 1

    @property
    def volume(self) -> np.ndarray:
        return np.pi * self.h * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (self.edges[1:] + self.edges[:-1])


@dataclass
class RingProfiles:
    """Time-averaged ring profiles and their standard errors (SI units).

    Attributes
    ----------
    rings : Rings
    values, sem : dict of name -> ndarray, shape (n_rings,)
        Values and standard errors (blocking analysis for one run, between-run for an
        ensemble).
    flags : ndarray of str, shape (n_rings,)
    n_frames : int
    meta : dict
        The JSON sidecar (``meta["errors"]`` says how the errors were made and where
        they are only lower bounds).
    replicates : Replicates, optional
        Profiles on parts of the data (jackknife blocks, or one per realisation): the
        errors of derived numbers (fits, maxima) come from them.
    n_runs : ndarray, optional
        Realisations with a finite value per ring (ensembles only), shape (n_rings,).
    timeseries : DataFrame, optional
        The state of every frame read (:mod:`granavg.timeseries`), written as
        ``<path>.timeseries.csv``; ``meta["stationarity"]`` judges the averaging window.
    """

    rings: Rings
    values: dict
    sem: dict
    flags: np.ndarray
    n_frames: int
    meta: dict = field(default_factory=dict)
    replicates: Replicates | None = None
    n_runs: np.ndarray | None = None
    timeseries: pd.DataFrame | None = None

    def to_frame(self) -> pd.DataFrame:
        """One row per ring: r_lo, r_hi, r, V, n_frames, each value and ``<name>_sem``,
        flags."""
        cols = {"r_lo": self.rings.edges[:-1], "r_hi": self.rings.edges[1:],
                "r": self.rings.centre, "V": self.rings.volume,
                "n_frames": np.full(self.rings.n, self.n_frames)}
        if self.n_runs is not None:
            cols["n_runs"] = self.n_runs
        for name, v in self.values.items():
            cols[name], cols[f"{name}_sem"] = v, self.sem[name]
        cols["flags"] = self.flags
        return pd.DataFrame(cols)

    @classmethod
    def read(cls, path) -> "RingProfiles":
        """Profiles written by :meth:`write` (CSV or Parquet, with its JSON sidecar),
        checked: a damaged table or sidecar is a one-line error naming the file."""
        path = Path(path)
        side = path.with_name(path.name + ".json")
        for f in (path, side):
            if not f.exists():
                raise UserError(f"{f}: not found; write profiles with 'granavg average' (the "
                                "table and its .json sidecar)")
            if not f.is_file():
                raise UserError(f"{f}: is a directory; give a profiles table")
        try:
            table = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
        except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError,
                ValueError, OSError) as exc:
            raise UserError(f"{path}: not a readable profiles table ({str(exc).splitlines()[0]})"
                            "; average again with 'granavg average'") from None
        try:
            meta = json.loads(side.read_text())
        except json.JSONDecodeError as exc:
            raise UserError(f"{side}:{exc.lineno}: damaged JSON ({exc.msg}); average again "
                            "with 'granavg average'") from None
        except UnicodeDecodeError:
            raise UserError(f"{side}: not a text file; average again with 'granavg "
                            "average'") from None
        try:
            edges = np.asarray(meta["rings"]["edges_m"], float)
            rings = Rings(edges, float(meta["rings"]["h_m"]))
        except (KeyError, TypeError, ValueError):
            raise UserError(f"{side}: no ring geometry (rings.edges_m, rings.h_m); average "
                            "again with 'granavg average'") from None
        missing = [c for c in ("r", "n_frames", "flags") if c not in table.columns]
        if missing or len(table) != rings.n:
            what = f"column {missing[0]} is missing" if missing else \
                f"{len(table)} rows for {rings.n} rings"
            raise UserError(f"{path}: {what} (the table is cut or not granavg's); average "
                            "again with 'granavg average'")
        names = [c for c in table.columns if f"{c}_sem" in table.columns]
        bad = [n for n in names if not pd.api.types.is_numeric_dtype(table[n])]
        if bad:
            raise UserError(f"{path}: column {bad[0]} holds non-numbers; the table is damaged")
        reps = path.with_name(path.name + REPLICATES)
        replicates = None
        if reps.exists():
            try:
                with np.load(reps) as z:
                    replicates = Replicates(str(z["kind"]),
                                            {k: z[k] for k in z.files if k != "kind"})
            except (OSError, ValueError, KeyError) as exc:
                raise UserError(f"{reps}: damaged replicates ({exc}); average again") from None
        series = path.with_name(path.name + TIMESERIES)
        return cls(rings, {n: table[n].to_numpy() for n in names},
                   {n: table[f"{n}_sem"].to_numpy() for n in names},
                   np.array([f if isinstance(f, str) else "" for f in table["flags"]], dtype=object),
                   int(table["n_frames"].iloc[0]), meta, replicates,
                   table["n_runs"].to_numpy() if "n_runs" in table.columns else None,
                   pd.read_csv(series) if series.exists() else None)

    def write(self, path, parquet: bool = False) -> Path:
        """Write the table (CSV, or Parquet), a JSON sidecar ``<path>.json`` and the
        replicates ``<path>.replicates.npz``: each to a temporary name first, renamed
        only when all are complete."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        table = self.to_frame()
        if parquet:
            try:
                import pyarrow  # noqa: F401  (pandas' Parquet engine)
            except ImportError:
                raise UserError("--parquet needs pyarrow: pip install 'granavg[parquet]'") from None
        targets = [path, path.with_name(path.name + ".json")]
        if self.replicates is not None:
            targets.append(path.with_name(path.name + REPLICATES))
        if self.timeseries is not None:
            targets.append(path.with_name(path.name + TIMESERIES))
        tmp = [t.with_name(f".{t.name}.tmp{os.getpid()}") for t in targets]
        try:
            if parquet:
                table.to_parquet(tmp[0], index=False)
            else:
                table.to_csv(tmp[0], index=False, float_format="%.10g")
            tmp[1].write_text(json.dumps(self.meta, indent=2) + "\n")
            extra = iter(tmp[2:])
            if self.replicates is not None:
                with open(next(extra), "wb") as fh:
                    np.savez(fh, kind=self.replicates.kind, **self.replicates.values)
            if self.timeseries is not None:
                self.timeseries.to_csv(next(extra), index=False, float_format="%.8g")
            # the table last: when it exists, its companions do; no signal in between
            blocked = {signal.SIGINT, signal.SIGTERM}
            old = signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
            try:
                for t, final in reversed(list(zip(tmp, targets))):
                    os.replace(t, final)
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)
        finally:
            for t in tmp:
                t.unlink(missing_ok=True)
        return path


class RingAverage:
    """Average frames over rings (Eqs. 1-7).

    Parameters
    ----------
    frames : iterable of :class:`~granavg.reader.Frame`
    rings : Rings
    groups : sequence of str
        Keys of :data:`granavg.profiles.QUANTITIES`.
    rho_p : float
        Material density, kg/m^3.
    t_min : float
        Frames before t_min (s) are not averaged.
    block_time : float
        Length (s) of the base time blocks of the blocking analysis.
    series : TimeSeries, optional
        Records the state of every frame (also those before t_min).
    """

    def __init__(self, frames, rings: Rings, groups, rho_p: float, t_min: float,
                 block_time: float, series: TimeSeries | None = None):
        self.frames, self.rings, self.groups = frames, rings, list(groups)
        self.rho_p, self.t_min, self.block_time = rho_p, t_min, block_time
        self.channels = sorted({c for g in self.groups for c in QUANTITIES[g][1]})
        self.series = series
        self.results: RingProfiles | None = None
        self.meta: dict = {}

    def run(self, progress: bool | None = None) -> RingProfiles:
        """Accumulate every frame with t >= t_min; returns the profiles."""
        self.prepare()
        for frame in tqdm(self.frames, desc="averaging", unit="frame",
                          disable=None if progress is None else not progress):
            self.add(frame)
        return self.conclude()

    def prepare(self):
        """Start with an empty accumulator (and time series)."""
        self.acc = RingAccumulator((self.rings.n, len(CHANNELS)), self.t_min, self.block_time)
        if self.series is not None:
            self.series.rows = []

    def add(self, frame):
        """Record the frame's state; accumulate it if t >= t_min."""
        if self.series is not None:
            self.series.add(frame)
        if frame.time >= self.t_min:
            self.acc.add(frame.timestep, frame.time, frame_sums(
                frame, self.rings, self.rho_p, self.channels))

    def conclude(self) -> RingProfiles:
        """Profiles of the frames added so far."""
        acc, V = self.acc, self.rings.volume
        if acc.n_frames == 0:
            raise UserError(f"no frame at t >= t_min = {self.t_min:g} s; lower --t-min")
        S = acc.mean()
        vals = values(S, V, self.rho_p, self.groups)
        counts, sums = acc.block_sums()
        sem, lower, replicates = standard_errors(counts, sums, V, self.rho_p, self.groups)
        meta = {**self.meta, "frames": {**self.meta.get("frames", {}), "n": acc.n_frames}}
        ring_flags = flags(S, self.groups)
        extra = [[] for _ in ring_flags]
        if len(counts) < 2:
            log.warning("all %d frames fall in one time block: no standard errors (NaN, flag "
                        "'one_block'); average more frames or shorten --block-time",
                        acc.n_frames)
            extra = [["one_block"] for _ in ring_flags]
        else:
            bound = np.zeros(len(V), bool)
            for name, lb in lower.items():
                bound |= lb & np.isfinite(vals[name])
            for k in np.flatnonzero(bound):
                extra[k].append("sem_lower_bound")
        ring_flags = np.array([";".join(filter(None, (f, *e))) for f, e in zip(ring_flags, extra)],
                              dtype=object)
        meta["errors"] = {
            "method": "blocking analysis over time blocks (Flyvbjerg-Petersen; level by "
                      "Lee et al. 2011); derived numbers from delete-one-block jackknife",
            "base_blocks": int(len(counts)),
            "jackknife_blocks": replicates.n if replicates else 0,
            "lower_bound": {n: [int(k) for k in np.flatnonzero(lb & np.isfinite(vals[n]))]
                            for n, lb in lower.items() if np.any(lb & np.isfinite(vals[n]))}}
        dropped = dict(getattr(self.frames, "dropped", None) or {})
        if any(dropped.values()):
            meta["dropped"] = dropped
            log.warning("%d contact rows with overlap <= 0 (not touching: LAMMPS' pair/local "
                        "lists neighbours within its cutoff) were dropped",
                        dropped.get("contacts_not_touching", 0))
        series = None
        if self.series is not None and self.series.rows:
            series = self.series.frame()
            meta["stationarity"] = stationarity(series, self.t_min)
            warn_if_drifting(meta["stationarity"], self.t_min)
        self.results = RingProfiles(self.rings, vals, sem, ring_flags, acc.n_frames, meta,
                                    replicates, timeseries=series)
        return self.results


def warn_if_drifting(judged: dict, t_min: float) -> list:
    """Log a warning naming each quantity that drifts over the window; returns them."""
    drifting = [q for q, r in judged.items() if r["drifts"]]
    unsure = [q for q, r in judged.items() if r.get("undetermined")]
    if unsure:
        log.warning("the averaging window t >= %g s may not be steady in %s: the change "
                    "exceeds %g errors, but the errors are only lower bounds (fluctuations "
                    "as slow as the window)", t_min, ", ".join(unsure), DRIFT_Z)
    if drifting:
        starts = [judged[q]["steady_from_s"] for q in drifting]
        where = ("it would be steady from t = %.0f s (--t-min)" % max(starts)
                 if None not in starts else "no later start gives a steady stretch")
        log.warning("the averaging window t >= %g s is not steady: %s; %s", t_min, ", ".join(
            f"{q} {judged[q]['first_half']:.3g} -> {judged[q]['second_half']:.3g} "
            f"({judged[q]['z']:.1f} errors)" for q in drifting), where)
    return drifting


def frame_sums(frame, rings: Rings, rho_p: float, channels) -> np.ndarray:
    """Ring sums of one frame, shape (n_rings, n_channels)."""
    a = frame.atoms
    q = particle_channels(a, frame.contacts, rings.h, rho_p, channels)
    particle, ring, w = ring_weights(np.hypot(a["x"], a["y"]), a["radius"], rings.edges)
    return ring_sums(particle, ring, w, q, rings.n)


def needed_columns(groups):
    """Atom-dump and contact-dump columns (with what needs each) for these groups."""
    atoms, contacts = {}, {}
    for g in groups:
        for ch in QUANTITIES[g][1]:
            for c in ATOM_COLUMNS.get(ch, []):
                atoms.setdefault(c, g)
            for c in CONTACT_COLUMNS.get(ch, []):
                contacts.setdefault(c, g)
    return atoms, contacts


def average_run(run_dir=None, *, bins=None, edges=None, t_min=None, block_time=None,
                quantities=None, atoms=None, contacts=None, progress=None) -> RingProfiles:
    """Ring profiles of a run directory (or of dump files with a manifest beside them).

    Parameters
    ----------
    run_dir : path, optional
        A ``granavg simulate`` directory: manifest (geometry, h, rho_p, dt, Omega) and
        dumps.
    bins : int, optional
        Number of equal rings between R_i and R_o; or ``edges`` (m).
    t_min : float, optional
        Start of the average (s); default two inner-ring rotations, 2 T = 4 pi / Omega.
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
                 quantities=None, atoms=None, contacts=None, steps=None) -> RingAverage:
    """The :class:`RingAverage` of :func:`average_run`, its frames read lazily (only
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
                            frames=FramePairs(reader_a, reader_c, dt=derived["dt_s"]))
    averager.meta["files"] = {"atoms": str(atoms),
                              "contacts": str(reader_c.path) if reader_c else None}
    return averager


def ring_average(manifest: dict, groups, *, bins=None, edges=None, t_min=None,
                 block_time=None, frames=None) -> RingAverage:
    """A :class:`RingAverage` of a run (its manifest) with granavg's defaults: 20 equal
    rings from R_i to R_o, t_min = two inner-ring rotations, base blocks of one dump
    interval (at most 512). Its profiles' ``meta`` describe the average (SI units)."""
    scene, derived = manifest["scene"], manifest["derived"]
    rings = Rings(np.asarray(edges, float), scene["h"]) if edges is not None else \
        Rings.count(20 if bins is None else bins, scene["R_i"], scene["R_o"], scene["h"])
    T = 2 * math.pi / scene["Omega"]
    t_min = 2 * T if t_min is None else float(t_min)
    t_end = derived["t_end_s"]
    block_time = block_time or max(derived["dump_interval_s"], (t_end - t_min) / MAX_BLOCKS)
    series = TimeSeries(scene["R_i"], scene["R_o"], scene["h"], scene["rho_p"], scene["d_s"])
    avg = RingAverage(frames, rings, groups, scene["rho_p"], t_min, block_time, series)
    avg.meta = {
        "granavg_version": __version__, "units": "SI (m, s, kg, N, Pa)",
        "quantities": list(groups), "rings": {"edges_m": list(rings.edges), "h_m": rings.h},
        "frames": {"t_min_s": t_min, "block_time_s": block_time},
        "run_manifest": manifest,
    }
    return avg


def groups_for(quantities, have_contacts: bool) -> list:
    """The quantity groups to compute: the requested ones (checked), or all that the
    data allow (without contacts, only those that need none)."""
    if quantities is None:
        return [g for g, (_, _, needs) in QUANTITIES.items() if have_contacts or not needs]
    unknown = [q for q in quantities if q not in QUANTITIES]
    if unknown:
        raise UserError(f"unknown quantity {unknown[0]!r}; choose from {', '.join(QUANTITIES)}")
    lacking = [q for q in quantities if QUANTITIES[q][2] and not have_contacts]
    if lacking:
        raise UserError(f"{lacking[0]} needs the contact dump, and none was found; give "
                        "--contacts or run the simulation with contacts")
    return list(quantities)


def _order(cols: dict) -> list:
    return sorted(cols, key=list(cols).index)
