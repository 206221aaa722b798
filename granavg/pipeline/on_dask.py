"""Averaging fanned out on dask: a run's frames split into chunks of whole time blocks,
one accumulator per chunk, merged exactly (the serial result bit for bit).

Local by default (a ``distributed.LocalCluster`` of processes); give a scheduler address
to use a cluster (the run directory must be readable by every worker).
"""

from __future__ import annotations

import logging
import resource
import sys
from contextlib import contextmanager

import numpy as np

from granavg.engine import threads
from granavg.engine.accumulate import CellAccumulator
from granavg.engine.cell_average import CHUNK
from granavg.engine.fields import Fields
from granavg.dask_cluster import Cluster, cluster_client, refusal_safe
from granavg.errors import ParameterError, literal, named
from granavg.pipeline.dumps import average_dumps, dump_averager
from granavg.pipeline.runs import run_averager

log = logging.getLogger(__name__)


def chunk_windows(manifest: dict, t_min: float, block_time: float, n_chunks: int,
                  t_max: float | None = None) -> list:
    """Time-step windows ``(first, last)`` of a run's dump frames with t_min <= t <=
    t_max (:func:`cut_windows`)."""
    d = manifest["derived"]
    steps = np.arange(d["first_dump_step"], d["n_shear_steps"] + 1, d["dump_every_steps"])
    return cut_windows(steps, steps * d["dt_s"], t_min, block_time, n_chunks, t_max)


def cut_windows(steps, times, t_min: float, block_time: float, n_chunks: int,
                t_max: float | None = None) -> list:
    """Time-step windows ``(first, last)`` of the frames (``steps`` at ``times``) with
    t_min <= t <= t_max, cut only at block boundaries into at most ``n_chunks`` parts of
    about equal frame counts."""
    steps, times = np.asarray(steps), np.asarray(times, float)
    keep = (times >= t_min) & (times <= (np.inf if t_max is None else t_max))
    steps, times = steps[keep], times[keep]
    if len(steps) == 0:
        return []
    acc = CellAccumulator((1, 1), t_min, block_time)
    blocks = np.array([acc.block_of(t) for t in times])
    starts = np.flatnonzero(np.r_[True, blocks[1:] != blocks[:-1]])   # first frame of a block
    cuts = sorted({int(starts[np.argmin(np.abs(starts - k * len(steps) / n_chunks))])
                   for k in range(n_chunks)} | {0})
    bounds = cuts + [len(steps)]
    return [(int(steps[a]), int(steps[b - 1])) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


@refusal_safe
def _chunk(run_dir, window, options):
    """One worker's job: the accumulators of the frames in ``window``, its peak RSS and
    the frames' time-series rows."""
    avg = run_averager(run_dir, steps=window, **options)
    avg.prepare()
    for frame in avg.frames:
        avg.add(frame)
    return avg.state(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, avg.series.rows


def average_run_dask(run_dir, *, workers: int = 2, scheduler: str | None = None,
                     chunks: int | None = None, client=None, **options) -> Fields:
    """:func:`granavg.pipeline.runs.average_run` on dask workers; identical profiles.

    Parameters
    ----------
    workers : int
        Processes of the local cluster (ignored with ``scheduler``).
    scheduler : str, optional
        Address of a dask scheduler (``tcp://host:8786``).
    chunks : int, optional
        Number of chunks (default 2 per worker).
    client : dask.distributed.Client, optional
        Use this client (and its cluster) instead of starting one; for many runs.
    **options
        ``bins``, ``edges``, ``t_min``, ``block_time``, ``quantities``, ``atoms``,
        ``contacts`` as for ``average_run``.

    The profiles' ``meta["dask"]`` records the chunks and each worker's peak memory (B).
    """
    base = run_averager(run_dir, fed=True, **options)      # validates; reads no frame
    windows = chunk_windows(base.meta["run_manifest"], base.t_min, base.block_time,
                            chunks or 2 * workers, base.t_max)
    with cluster_client(workers, scheduler, _threads_each(workers)) if client is None else \
            _given(client) as dask_jobs:
        futures = [dask_jobs.client.submit(_chunk, str(run_dir), w, options, pure=False)
                   for w in windows]
        results = dask_jobs.gather(futures)
        workers_used = dask_jobs.n_workers
    base.prepare()
    for state, _, rows in results:
        base.merge(state)
        base.series.rows.extend(rows)
    base.series.rows.sort(key=lambda row: row["step"])
    profiles = base.conclude()
    profiles.meta["dask"] = {"chunks": [list(w) for w in windows], "workers": workers_used,
                             "listed_by": "manifest",
                             "peak_rss_bytes_per_chunk": [int(r) for _, r, _ in results]}
    return profiles


def resolved_time(base, time: dict | None) -> dict | None:
    """The time options a worker's averager needs, resolved by the client's ``base``
    (which read the first frames): windows of frames as their length, the frames'
    interval (a chunk may hold a single frame), and the species of a mixture as the
    first frame fixed them (a chunk's first frame may lack one)."""
    if not time:
        return time
    axis = base.axis
    out = dict(time)
    if out.get("species") is not None and base.classes is not None:
        out["species"] = base.classes      # the species the first frame fixed, for all
    if axis.kind == "windows":
        out.pop("window_frames", None)
        out["windows"] = axis.length
    if getattr(axis, "interval", None):
        out["interval"] = axis.interval
    return out


@contextmanager
def _given(client):
    """A :class:`~granavg.dask_cluster.Cluster` of a client the caller owns (not closed
    here; no signals deferred)."""
    yield Cluster(client, [])


def _threads_each(workers: int) -> int:
    """Engine threads per local worker: this command's threads shared among them."""
    return max(1, threads.count() // max(int(workers or 1), 1))


def series_windows(atoms, contacts, time_of, t_min: float, block_time: float,
                   n_chunks: int, t_max: float | None = None) -> list | None:
    """Windows ``(first, last)`` of time steps that split a ``dump.*`` series into runs
    of whole files, from each file's first header alone (no row read): the number in
    each name must be that frame's time step, as LAMMPS names them (and the contact
    series' numbers the atom series'); None where it is not, or for a single file (then
    the frames are listed by a scan). A window reaches to the step before the next
    one's first file, so files of several frames stay whole."""
    from granavg.io.reader import DumpReader, numbered_series

    numbered = numbered_series(atoms)
    steps = [n for n, _ in numbered]
    if len(numbered) < 2 or (contacts is not None and
                             [n for n, _ in numbered_series(contacts)] != steps):
        return None
    reader = DumpReader(atoms, [])
    heads = [reader.first_header(path) for _, path in numbered]
    if any(h is None or h.timestep != n for h, (n, _) in zip(heads, numbered)):
        log.info("%s: the numbers in the file names are not their time steps; the frames "
                 "are listed by a scan", atoms)
        return None
    windows = cut_windows(steps, [time_of(h) for h in heads], t_min, block_time, n_chunks,
                          t_max)
    starts = [w[0] for w in windows[1:]]
    return [(lo, nxt - 1) for (lo, _), nxt in zip(windows, starts)] + \
        [(windows[-1][0], sys.maxsize)] if windows else []


@refusal_safe
def _dump_chunk(atoms, contacts, window, options):
    """One worker's job for anyone's dumps: the accumulators of the frames in
    ``window``, its peak RSS and the rows it dropped."""
    avg, frames = dump_averager(atoms, contacts, steps=window, **options)
    avg.prepare()
    for frame in avg.frames:
        avg.add(frame)
    return (avg.state(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
            dict(frames.dropped))


def _one_process_pays(atoms, workers: int) -> bool:
    """Whether one process averages the dumps at least as fast as a local cluster: where
    its frames hold :data:`~granavg.engine.cell_average.CHUNK` particles or more, one
    process already reads (a series' files, a plain file's pieces) and sums (a frame's
    chunks) on every core, and a cluster would only add its start and its workers'
    imports (measured: docs/running-big.md). Said in one line."""
    from granavg.io.reader import DumpReader

    head = DumpReader(atoms, []).first_header()
    if head is None or len(head.data) < CHUNK:
        return False
    log.info(named("{workers} %d: frames of %d particles are read and averaged on every "
                   "core by one process, which a local dask cluster would only slow down "
                   "(its start); averaging in this process on %d threads (a cluster of "
                   "machines: {scheduler})"), workers, len(head.data), threads.count())
    return True


def average_dumps_dask(atoms, contacts=None, *, workers: int = 2,
                       scheduler: str | None = None, chunks: int | None = None,
                       **options) -> Fields:
    """:func:`granavg.pipeline.dumps.average_dumps` on dask workers, for LAMMPS
    dumps each worker can read its own part of: a ``dump.*`` file series, or a plain
    (uncompressed) file (each worker skips to its frames by scanning). Identical
    profiles; ``meta["dask"]`` records the chunks. A single gzip file is refused: it is
    one stream, which only one process can decompress. Without a scheduler, frames of
    :data:`~granavg.engine.cell_average.CHUNK` particles or more are averaged in this
    process, said in one line (:func:`_one_process_pays`)."""
    from granavg.io import formats
    from granavg.io.reader import DumpReader, series

    chosen = formats.choose(atoms, options.get("fmt")).name
    if chosen != "lammps":
        raise ParameterError("workers", f"{literal(atoms)}: {{param}} averages LAMMPS dumps; "
                             f"average {chosen} files in this process (leave out {{param}})")
    for path in filter(None, (atoms, contacts)):
        files = series(path)
        if len(files) == 1 and files[0].suffix == ".gz":
            raise ParameterError("workers", f"{literal(path)}: one gzip file is one stream "
                                 "that only one process can decompress, so {param} cannot "
                                 "help; give a dump.* series or an uncompressed dump, or "
                                 "leave out {param}")
    if scheduler is None and _one_process_pays(atoms, workers):
        return average_dumps(atoms, contacts, **options)
    base, frames = dump_averager(atoms, contacts, scan_early=False, **options)  # checks;
    # the first two frames read
    base.frames = ()                                  # (and stops its reader thread)
    n_chunks = chunks or 2 * workers
    by_file = series_windows(atoms, contacts, frames.time, base.t_min, base.block_time,
                             n_chunks, base.t_max)
    listed_by = "file names" if by_file is not None else "header scan"
    if by_file is not None:                  # each worker opens its own files alone
        windows, named = by_file, {"named_steps": True}
    else:
        heads = list(DumpReader(atoms, [], headers_only=True))     # no row is parsed
        windows = cut_windows([f.timestep for f in heads], [frames.time(f) for f in heads],
                              base.t_min, base.block_time, n_chunks, base.t_max)
        named = {}
    if not windows:
        raise ParameterError("t_min", f"no frame at t >= {base.t_min:g}, the start of the "
                             "average ({param}); lower it")
    fixed = dict(options, quantities=base.groups, block_time=base.block_time,
                 check_cells=None, time=resolved_time(base, options.get("time")),
                 **named)                             # checked above
    with cluster_client(workers, scheduler, _threads_each(workers)) as dask_jobs:
        futures = [dask_jobs.client.submit(_dump_chunk, str(atoms),
                                           str(contacts) if contacts else None, w, fixed,
                                           pure=False) for w in windows]
        results = dask_jobs.gather(futures)
        workers_used = dask_jobs.n_workers
    base.prepare()
    dropped = {}
    for state, _, rows in results:
        base.merge(state)
        for k, v in rows.items():
            dropped[k] = dropped.get(k, 0) + v
    profiles = base.conclude()
    if any(dropped.values()):
        profiles.meta["dropped"] = dropped
    profiles.meta["dask"] = {"chunks": [list(w) for w in windows], "workers": workers_used,
                             "listed_by": listed_by,
                             "peak_rss_bytes_per_chunk": [int(r) for _, r, _ in results]}
    return profiles
