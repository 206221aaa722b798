"""Averaging fanned out on dask: a run's frames split into chunks of whole time blocks,
one accumulator per chunk, merged exactly (the serial result bit for bit).

Local by default (a ``distributed.LocalCluster`` of processes); give a scheduler address
to use a cluster (the run directory must be readable by every worker).
"""

from __future__ import annotations

import logging
import math
import os
import resource
import sys
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from granavg.engine import threads
from granavg.engine.accumulate import CellAccumulator
from granavg.engine.frame_sums import CHUNK
from granavg.engine.fields import Fields
from granavg.engine.spec import Averaging, TimeAxis
from granavg.dask_cluster import Cluster, cluster_client, refusal_safe
from granavg.errors import ParameterError, UserError, literal, named
from granavg.io.reader import DumpReader, numbered_series, processor_files, series
from granavg.pipeline.dumps import average_dumps, dump_averager
from granavg.pipeline.runs import average_run, run_averager, run_dumps
from granavg.pipeline.spec import Execution, Spec

log = logging.getLogger(__name__)


def chunk_windows(manifest: dict, time: TimeAxis, n_chunks: int) -> list:
    """Time-step windows ``(first, last)`` of a run's dump frames with t_min <= t <=
    t_max of the resolved ``time`` (:func:`cut_windows`), cut where the manifest's dump
    interval puts frames; the
    first reaches back to t_min's step and the last has no end, so that a frame off
    that grid (a run continued with other dump settings) is still in one window."""
    d = manifest["derived"]
    steps = np.arange(d["first_dump_step"], d["n_shear_steps"] + 1, d["dump_every_steps"])
    windows = cut_windows(steps, steps * d["dt_s"], time, n_chunks)
    if windows:
        first = min(windows[0][0], math.ceil(time.t_min / d["dt_s"] - 1e-9))
        windows[0] = (first, windows[0][1])
        windows[-1] = (windows[-1][0], sys.maxsize)
    return windows


def cut_windows(steps, times, time: TimeAxis, n_chunks: int) -> list:
    """Time-step windows ``(first, last)`` of the frames (``steps`` at ``times``) with
    t_min <= t <= t_max of the resolved ``time``, cut only at its base blocks' boundaries
    into at most ``n_chunks`` parts of about equal frame counts; each reaches to the step
    before the next one's first."""
    steps, times = np.asarray(steps), np.asarray(times, float)
    keep = (times >= time.t_min) & (times <= (np.inf if time.t_max is None else time.t_max))
    steps, times = steps[keep], times[keep]
    if len(steps) == 0:
        return []
    acc = CellAccumulator((1, 1), time.t_min, time.block_time)
    blocks = np.array([acc.block_of(t) for t in times])
    starts = np.flatnonzero(np.r_[True, blocks[1:] != blocks[:-1]])   # first frame of a block
    cuts = sorted({int(starts[np.argmin(np.abs(starts - k * len(steps) / n_chunks))])
                   for k in range(n_chunks)} | {0})
    bounds = cuts + [len(steps)]
    firsts = [int(steps[a]) for a in bounds[:-1]]
    return [(a, b - 1) for a, b in zip(firsts, firsts[1:])] + [(firsts[-1], int(steps[-1]))]


@refusal_safe
def _chunk(run_dir, window, spec):
    """One worker's job: the accumulators of the frames in ``window``, its peak RSS and
    the frames' time-series rows."""
    avg = run_averager(run_dir, spec, steps=window)
    avg.prepare()
    for frame in avg.frames:
        avg.add(frame)
    return avg.state(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, avg.series.rows


def average_run_dask(run_dir, spec: Spec | None = None, *, chunks: int | None = None,
                     client=None, **keywords) -> Fields:
    """:func:`granavg.pipeline.runs.average_run` on dask workers; identical profiles.

    Parameters
    ----------
    spec : Spec, optional
        The average (:class:`~granavg.pipeline.spec.Spec`; None: of ``keywords``), its
        execution's ``workers`` (the local cluster's processes; default 2) or
        ``scheduler`` (a dask scheduler's address, ``tcp://host:8786``).
    chunks : int, optional
        Number of chunks (default :func:`chunk_count`).
    client : dask.distributed.Client, optional
        Use this client (and its cluster) instead of starting one; for many runs.

    Without a scheduler (or client), where one process is as fast
    (:func:`one_process_reason`: a run's dumps are gzip streams), the run is averaged in
    this process, said in one line.

    The profiles' ``meta["dask"]`` records the chunks and each worker's peak memory (B).
    """
    spec = spec if spec is not None else Spec.of(run_dir, **keywords)
    workers, scheduler = spec.execution.workers or 2, spec.execution.scheduler
    base = run_averager(run_dir, spec, fed=True)      # validates; reads no frame
    manifest = base.meta["run_manifest"]
    paths = [p for p in run_dumps(run_dir, manifest, spec.source.atoms,
                                  spec.source.contacts) if p]
    here = replace(spec, execution=Execution(progress=False))
    if scheduler is None and client is None and in_this_process(paths, workers):
        return average_run(run_dir, here)
    with cluster_client(workers, scheduler, _threads_each(workers)) if client is None else \
            _given(client) as dask_jobs:
        windows = chunk_windows(manifest, base.averaging.time,
                                chunks or chunk_count(paths, dask_jobs.n_workers))
        futures = [dask_jobs.client.submit(_chunk, str(run_dir), w, here, pure=False)
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


def resolved(base) -> Averaging:
    """The engine part a worker's averager needs, resolved by the client's ``base``
    (which read the first frames): its quantities and base block, windows of frames as
    their length, the frames' interval (a chunk may hold a single frame), and the
    species of a mixture as the first frame fixed them (a chunk's first frame may lack
    one)."""
    averaging, axis = base.averaging, base.axis
    out = replace(averaging, quantities=tuple(base.groups))
    if averaging.species is not None and base.classes is not None:
        out = replace(out, species=base.classes)   # the species the first frame fixed
    changes = {"block_time": base.block_time}
    if axis.kind == "windows":
        changes.update(window_frames=None, windows=axis.length,
                       window_start=axis.start)  # the data's first frame, not a chunk's
    if getattr(axis, "interval", None):
        changes["interval"] = axis.interval
    if getattr(axis, "origin", None) is not None:
        changes["origin"] = axis.origin         # the data's first frame, not a chunk's
    return out.with_time(**changes)


@contextmanager
def _given(client):
    """A :class:`~granavg.dask_cluster.Cluster` of a client the caller owns (not closed
    here; no signals deferred)."""
    yield Cluster(client, [])


def _threads_each(n_workers: int) -> int:
    """Engine threads per local worker: this command's threads shared among them."""
    return max(1, threads.count() // max(int(n_workers or 1), 1))


def series_windows(atoms, contacts, time_of, time: TimeAxis, n_chunks: int) -> list | None:
    """Windows ``(first, last)`` of time steps that split a ``dump.*`` series into runs
    of whole files, from each file's first header alone (no row read): the number in
    each name must be that frame's time step, as LAMMPS names them (and the contact
    series' numbers the atom series'); None where it is not, or for a single file (then
    the frames are listed by a scan). A window reaches to the step before the next
    one's first file, so files of several frames stay whole."""
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
    windows = cut_windows(steps, [time_of(h) for h in heads], time, n_chunks)
    starts = [w[0] for w in windows[1:]]
    return [(lo, nxt - 1) for (lo, _), nxt in zip(windows, starts)] + \
        [(windows[-1][0], sys.maxsize)] if windows else []


@refusal_safe
def _dump_chunk(spec, window, named):
    """One worker's job for anyone's dumps: the accumulators of the frames in
    ``window``, its peak RSS and the rows it dropped."""
    avg, frames = dump_averager(spec, steps=window, **named)
    avg.prepare()
    for frame in avg.frames:
        avg.add(frame)
    return (avg.state(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
            dict(frames.dropped))


#: One process's averaging speed on one core, in text bytes per second, for frames
#: of fewer than :data:`~granavg.engine.frame_sums.CHUNK` particles (where it sums
#: a frame on one thread): 240-245 MB/s measured (docs/running-big.md).
ONE_CORE_RATE = 250e6
#: A local cluster's fixed cost, s: ``a + b x workers`` for its start, the workers'
#: imports, the chunks' listing, the merge and the close (2.2 s for 2 workers measured
#: here; 4.65 s to start and close 16 on a 16-core machine; docs/running-big.md).
CLUSTER_COST = (1.6, 0.3)
#: Work (s at :data:`ONE_CORE_RATE`) of a chunk at least: 25 times a chunk's own cost
#: on a running cluster (40 ms measured: set-up, first header, the sums sent back).
CHUNK_WORK = 1.0


def text_bytes(paths) -> int:
    """The text bytes of the dump files ``paths`` (a ``%`` in a name: every processor's
    file): a gzip file's from its trailer (the uncompressed size modulo 2**32, lifted to
    at least the compressed size)."""
    total = 0
    for path in (f for p in paths for f in
                 ([q for _, q in processor_files(p)] if "%" in Path(p).name else [p])):
        size = Path(path).stat().st_size
        if str(path).endswith(".gz") and size >= 18:
            with open(path, "rb") as fh:
                fh.seek(-4, 2)
                inner = int.from_bytes(fh.read(4), "little")
            while inner < size:
                inner += 1 << 32
            size = inner
        total += size
    return total


def one_process_reason(paths, n_workers: int, frame_particles: int = 0) -> str | None:
    """Why one process averages the dump files ``paths`` at least as fast as a local
    cluster of ``n_workers`` processes, or None where the cluster pays: frames of
    :data:`~granavg.engine.frame_sums.CHUNK` particles or more (one process reads and
    sums them on every core), one gzip stream (each worker would inflate it up to its
    chunk; measured 1.4x slower on 2 workers), or too little work to pay back the
    cluster's fixed cost (:data:`ONE_CORE_RATE`, :data:`CLUSTER_COST`)."""
    if frame_particles >= CHUNK:
        return (f"frames of {frame_particles} particles are read and summed on every core "
                "by one process")
    if any(len(series(p)) == 1 and str(p).endswith(".gz") for p in paths):
        return "one gzip stream, which every worker would inflate up to its part"
    work = text_bytes(f for p in paths for f in series(p)) / ONE_CORE_RATE
    cost = CLUSTER_COST[0] + CLUSTER_COST[1] * n_workers
    if work * (1 - 1 / n_workers) <= cost:
        return (f"about {work:.1f} s of work on one core, which {n_workers} workers would "
                f"cut by less than a local cluster's fixed cost (about {cost:.1f} s)")
    return None


def cost_model() -> bool:
    """Whether the cost model decides (``GRANAVG_COST_MODEL=on``, the default): off,
    ``--workers`` always starts its local cluster and the chunks are two per worker."""
    wanted = os.environ.get("GRANAVG_COST_MODEL", "on")
    if wanted not in ("on", "off"):
        raise UserError(f"GRANAVG_COST_MODEL={wanted!r}: give on (a local dask cluster only "
                        "where it pays, chunks sized to their work) or off")
    return wanted == "on"


def in_this_process(paths, n_workers: int, frame_particles=lambda: 0) -> bool:
    """Whether one process averages ``paths`` (:func:`one_process_reason`, the cost model
    on: :func:`cost_model`; ``frame_particles()`` the first frame's count), said in one
    line with the reason."""
    if not cost_model():
        return False
    reason = one_process_reason(paths, n_workers, frame_particles())
    if reason is None:
        return False
    log.info(named("{workers}: %s, so a local dask cluster would only be slower; averaging "
                   "in this process on %d threads (a running cluster: {scheduler})"),
             reason, threads.count())
    return True


def chunk_count(paths, n_workers: int) -> int:
    """Chunks for ``n_workers`` processes: two each where each chunk then holds
    :data:`CHUNK_WORK` or more, else one each, else fewer (at least one); two each where
    the cost model is off (:func:`cost_model`)."""
    n_workers = max(int(n_workers or 1), 1)
    if not cost_model():
        return 2 * n_workers
    work = text_bytes(f for p in paths for f in series(p)) / ONE_CORE_RATE
    if work >= 2 * n_workers * CHUNK_WORK:
        return 2 * n_workers
    return n_workers if work >= n_workers * CHUNK_WORK else max(1, int(work // CHUNK_WORK))


def average_dumps_dask(spec: Spec, *, chunks: int | None = None, client=None) -> Fields:
    """:func:`granavg.pipeline.dumps.average_dumps` of the spec on dask workers (its
    execution's ``workers``, default 2, or ``scheduler``), for LAMMPS
    dumps each worker can read its own part of: a ``dump.*`` file series, or a plain
    (uncompressed) file (each worker skips to its frames by scanning). Identical
    profiles; ``meta["dask"]`` records the chunks. Without a scheduler (or client),
    where one process is as fast (:func:`one_process_reason`), the dumps are averaged in
    this process, said in one line; on a cluster a single gzip file is refused (one
    stream that every worker would inflate up to its part). Chunks:
    :func:`chunk_count` for the cluster's workers, unless ``chunks`` is given."""
    from granavg.io import formats

    atoms, contacts = spec.source.atoms, spec.source.contacts
    workers, scheduler = spec.execution.workers or 2, spec.execution.scheduler
    chosen = formats.choose(atoms, spec.source.fmt).name
    if chosen != "lammps":
        raise ParameterError("workers", f"{literal(atoms)}: {{param}} averages LAMMPS dumps; "
                             f"average {chosen} files in this process (leave out {{param}})")
    paths = [p for p in (atoms, contacts) if p]
    if scheduler is None and client is None:
        def particles():
            head = DumpReader(atoms, []).first_header()
            return 0 if head is None else len(head.data)
        if in_this_process(paths, workers, particles):
            return average_dumps(spec)
    for path in paths:
        files = series(path)
        if len(files) == 1 and files[0].suffix == ".gz":
            raise ParameterError("scheduler" if scheduler else "workers",
                                 f"{literal(path)}: one gzip file is one stream "
                                 "that every worker would inflate up to its part, so a "
                                 "cluster cannot help; give a dump.* series or an "
                                 "uncompressed dump, or leave out {param}")
    base, frames = dump_averager(spec, scan_early=False)  # checks;
    # the first two frames read
    base.frames = ()                                  # (and stops its reader thread)
    with cluster_client(workers, scheduler, _threads_each(workers)) if client is None else \
            _given(client) as dask_jobs:
        workers_used = dask_jobs.n_workers
        n_chunks = chunks or chunk_count(paths, workers_used)
        time = base.averaging.time
        by_file = series_windows(atoms, contacts, frames.time, time, n_chunks)
        listed_by = "file names" if by_file is not None else "header scan"
        if by_file is not None:                  # each worker opens its own files alone
            windows, named = by_file, {"named_steps": True}
        else:
            heads = list(DumpReader(atoms, [], headers_only=True))     # no row is parsed
            windows = cut_windows([f.timestep for f in heads],
                                  [frames.time(f) for f in heads], time, n_chunks)
            named = {}
        if not windows:
            raise ParameterError("t_min", f"no frame at t >= {base.t_min:g}, the start of "
                                 "the average ({param}); lower it")
        fixed = replace(spec, averaging=resolved(base),
                        execution=Execution())             # checked above
        futures = [dask_jobs.client.submit(_dump_chunk, fixed, w, named, pure=False)
                   for w in windows]
        results = dask_jobs.gather(futures)
    base.prepare()
    dropped = {}
    for state, _, rows in results:
        base.merge(state)
        for k, v in rows.items():
            dropped[k] = dropped.get(k, 0) + v
    frames.dropped = dropped                  # the workers' counts, not the head's
    profiles = base.conclude()
    profiles.meta["dask"] = {"chunks": [list(w) for w in windows], "workers": workers_used,
                             "listed_by": listed_by,
                             "peak_rss_bytes_per_chunk": [int(r) for _, r, _ in results]}
    return profiles
