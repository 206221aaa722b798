"""Ring averaging: frames -> accumulators -> profiles (Eqs. 1-7), SI units.

:class:`RingAverage` follows MDAnalysis' ``AnalysisBase``: ``run()`` calls ``prepare``,
``add`` for every frame and ``conclude``; the results are one :class:`RingProfiles`.
Frames are in-memory arrays (:class:`~granavg.io.reader.Frame`-like: ``timestep``,
``time``, ``atoms``, ``contacts``) from any source: a dump reader
(:mod:`granavg.io.runs`), a running LAMMPS (:mod:`granavg.sim.insitu`) or dask workers.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from granavg.engine.accumulate import RingAccumulator
from granavg.engine.kernels import CHANNELS, particle_channels, ring_sums
from granavg.engine.profiles import (ATOM_COLUMNS, CONTACT_COLUMNS, QUANTITIES, flags,
                                     standard_errors, values)
from granavg.engine.timeseries import DRIFT_Z, TimeSeries, stationarity
from granavg.engine.uncertainty import Replicates
from granavg.engine.geometry import Rings, rename
from granavg.errors import UserError

log = logging.getLogger(__name__)

#: Base time blocks of the blocking analysis: one per frame, at most this many.
MAX_BLOCKS = 512


@dataclass
class RingProfiles:
    """Time-averaged ring profiles and their standard errors (SI units).

    Attributes
    ----------
    rings : Rings, Slabs or Grid
        The cells (:mod:`granavg.engine.geometry`).
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
        The state of every frame read (:mod:`granavg.engine.timeseries`), written as
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
        """One row per cell: its coordinates (r_lo, r_hi, r for rings), V, n_frames, each
        value and ``<name>_sem``, flags."""
        cols = {**self.rings.coordinates(), "V": self.rings.volume,
                "n_frames": np.full(self.rings.n, self.n_frames)}
        if self.n_runs is not None:
            cols["n_runs"] = self.n_runs
        for name, v in self.values.items():
            cols[name], cols[f"{name}_sem"] = v, self.sem[name]
        cols["flags"] = self.flags
        return pd.DataFrame(cols)

class RingAverage:
    """Average frames over rings, slabs or a grid (Eqs. 1-7).

    Parameters
    ----------
    frames : iterable of :class:`~granavg.io.reader.Frame`
    rings : Rings, Slabs or Grid
        The cells (:mod:`granavg.engine.geometry`); vectors and tensors come out in their
        basis (r, phi for rings; x, y otherwise).
    groups : sequence of str
        Keys of :data:`granavg.engine.profiles.QUANTITIES`.
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
        if self.rings.axes != ("r", "phi"):                 # Cartesian cells: x, y names
            vals, sem = ({rename(k, self.rings): v for k, v in d.items()} for d in (vals, sem))
            if replicates is not None:
                replicates.values = {rename(k, self.rings): v
                                     for k, v in replicates.values.items()}
            meta["errors"]["lower_bound"] = {rename(k, self.rings): v for k, v in
                                             meta["errors"]["lower_bound"].items()}
        self.results = RingProfiles(self.rings, vals, sem, ring_flags, acc.n_frames, meta,
                                    replicates, timeseries=series)
        return self.results


def warn_if_drifting(judged: dict, t_min: float) -> list:
    """Log a warning naming each quantity that drifts over the window (of one run, or of
    an ensemble judged by :func:`~granavg.engine.timeseries.ensemble_stationarity`);
    returns them."""
    drifting = [q for q, r in judged.items() if r["drifts"]]
    unsure = [q for q, r in judged.items() if r.get("undetermined")]
    runs = {r["n_runs"] for r in judged.values() if "n_runs" in r}
    whose = f"the ensemble's ({max(runs)} runs) averaging window" if runs else \
        "the averaging window"
    if unsure:
        log.warning("%s t >= %g s may not be steady in %s: the change exceeds %g errors, "
                    "but the errors are only lower bounds (fluctuations as slow as the "
                    "window)", whose, t_min, ", ".join(unsure), DRIFT_Z)
    if drifting:
        starts = [judged[q]["steady_from_s"] for q in drifting]
        where = ("averaging each run from a later --t-min or more realisations may tell"
                 if runs else "it would be steady from t = %.0f s (--t-min)" % max(starts)
                 if None not in starts else "no later start gives a steady stretch")
        log.warning("%s t >= %g s is not steady: %s; %s", whose, t_min, ", ".join(
            f"{q} {judged[q]['first_half']:.3g} -> {judged[q]['second_half']:.3g} "
            f"({judged[q]['z']:.1f} errors)" for q in drifting), where)
    elif runs and judged:
        log.info("%s t >= %g s is steady in %s (changes within %g between-run errors)",
                 whose, t_min, ", ".join(judged), DRIFT_Z)
    return drifting


def frame_sums(frame, rings, rho_p: float, channels) -> np.ndarray:
    """Cell sums of one frame, shape (n_cells, n_channels), for any geometry of
    :mod:`granavg.engine.geometry`."""
    a = frame.atoms
    q = particle_channels(a, frame.contacts, rings.h, rho_p, channels,
                          basis=rings.basis(a["x"], a["y"]))
    particle, ring, w = rings.weights(a["x"], a["y"], a["radius"])
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
