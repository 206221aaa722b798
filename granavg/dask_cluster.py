"""Dask for granavg's commands: a local cluster of single-threaded processes (granavg has
no scheduler of its own), or a given scheduler, and the jobs' results gathered so that a
signal stops the command quickly and quietly.

:func:`cluster_client` defers SIGINT and SIGTERM while dask runs: the handler only
records the signal, :meth:`Cluster.completed` and :meth:`Cluster.gather` poll the
futures and stop waiting when one came, the futures are cancelled, the client and the
cluster are closed with dask's own messages muted, and the signal is then passed to the
handler that was there before (the command's, which reports it). A job's refusal of its
input (a :class:`~granavg.errors.UserError` in a worker) travels back as a value
(:func:`refusal_safe`), so the worker logs no stack for it.
"""

from __future__ import annotations

import functools
import logging
import time
from contextlib import contextmanager

from granavg.errors import ParameterError, UserError, literal
from granavg.signals import deferred

#: How often the futures are polled while waiting, s.
POLL = 0.05
#: How long closing the client and the cluster may take after a signal, s.
CLOSE_TIMEOUT = 5


def local_cluster(n_workers: int, threads_each: int | None = None):
    """A local dask cluster of ``n_workers`` single-threaded processes. glibc's default
    malloc trim threshold is kept (dask lowers it to 64 kB, which made a worker's frames
    1.2x slower here: the reader's 8 MB buffers went back to the OS every time). The
    workers log only dask's errors (a job cancelled by a signal is not one).
    ``threads_each``: the engine threads of each worker (``GRANAVG_THREADS`` in its
    environment), so that the workers together do not oversubscribe the cores."""
    import dask
    from dask.distributed import LocalCluster

    environ = {k: v for k, v in dask.config.get("distributed.nanny.pre-spawn-environ").items()
               if k != "MALLOC_TRIM_THRESHOLD_"}
    if threads_each is not None:
        environ["GRANAVG_THREADS"] = str(int(threads_each))
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                            dashboard_address=None)


def _quiet_worker():
    """In a worker of granavg's local cluster: only dask's errors are logged (the
    workers' logging is set up from the environment at their start, before any config
    reaches them), and granavg's lines go to the client alone (forwarded there, said
    once however many workers say them: :func:`cluster_client`)."""
    logging.getLogger("distributed").setLevel(logging.ERROR)
    own = logging.getLogger("granavg")
    own.setLevel(logging.INFO)
    own.propagate = False


def _mute_worker():
    """In a worker of granavg's local cluster that is about to be closed after a refusal
    or a signal: no dask message at all (its heartbeat to a scheduler already closing
    would log a stack)."""
    for name in ("distributed", "asyncio", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


class Refused:
    """A worker's :class:`UserError`, carried back as a value."""

    def __init__(self, message: str):
        self.message = message


def refusal_safe(job):
    """``job`` returning a :class:`Refused` instead of raising a UserError in a worker."""
    @functools.wraps(job)
    def wrapped(*args, **kwargs):
        try:
            return job(*args, **kwargs)
        except UserError as exc:
            return Refused(str(exc))
    return wrapped


class _Stopped(Exception):
    """Waiting ended because a signal came."""


class Cluster:
    """The client of :func:`cluster_client` and the signals deferred meanwhile."""

    def __init__(self, client, signals: list):
        self.client, self.signals = client, signals

    def completed(self, futures):
        """The futures as they finish (any order); stops (the block ends, then the
        signal acts) when a signal came."""
        waiting = list(futures)
        while waiting:
            if self.signals:
                self.client.cancel(waiting)
                raise _Stopped()
            done = [f for f in waiting if f.done()]
            if not done:
                time.sleep(POLL)
                continue
            for f in done:
                waiting.remove(f)
                yield f

    def gather(self, futures) -> list:
        """The futures' results, in order; a worker's refusal (:class:`Refused`) raised
        here as the UserError it was, a failure at the first that fails."""
        futures, results = list(futures), {}
        for f in self.completed(futures):
            if f.status == "error":
                self.client.cancel(futures)
            results[f.key] = r = f.result()                  # raises the job's error
            if isinstance(r, Refused):
                self.client.cancel(futures)
                raise UserError(r.message)
        return [results[f.key] for f in futures]

    @property
    def n_workers(self) -> int:
        return len(self.client.scheduler_info()["workers"])


@contextmanager
def cluster_client(n_workers: int = 2, address: str | None = None,
                   threads_each: int | None = None):
    """A :class:`Cluster` on ``address``, or on a new local cluster of ``n_workers``
    processes (:func:`local_cluster`) closed after the block; SIGINT and SIGTERM deferred
    within it (module docstring)."""
    from dask.distributed import Client

    with deferred() as received:
        cluster = client = None
        failed = False
        try:
            cluster = None if address else local_cluster(n_workers, threads_each)
            client = _connect(Client, address, cluster)
            if cluster is not None:
                client.run(_quiet_worker)
                client.forward_logging("granavg", level=logging.INFO)
            if not received:
                yield Cluster(client, received)
        except _Stopped:
            pass
        except BaseException:
            failed = True
            raise
        finally:
            _close(client, cluster, quiet=bool(received) or failed)


#: How long connecting to a given scheduler may take, s.
CONNECT_TIMEOUT = 10


def _connect(Client, address, cluster):
    """A client of the local cluster, or of the scheduler at ``address`` (one-line
    refusal if it cannot be reached within :data:`CONNECT_TIMEOUT`)."""
    if address is None:
        return Client(cluster)
    try:
        return Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ParameterError("scheduler", f"{{param}} {literal(address)}: cannot reach it "
                             f"({literal(text)}); give the address of a running dask "
                             "scheduler (tcp://host:8786), or leave {param} out") from None


def _close(client, cluster, quiet: bool):
    """Close the client and the cluster; after a signal within :data:`CLOSE_TIMEOUT`
    and with dask's messages (cancelled tasks, closing comms) muted."""
    names = ("distributed", "asyncio", "tornado")
    levels = {n: logging.getLogger(n).level for n in names}
    if quiet:
        for n in names:
            logging.getLogger(n).setLevel(logging.CRITICAL + 1)
        if client is not None and cluster is not None:      # our own workers, muted too
            try:
                client.run(_mute_worker)
            except Exception:                      # noqa: BLE001 - a worker already gone
                pass
    try:
        for part in (client, cluster):
            if part is None:
                continue
            try:
                part.close(timeout=CLOSE_TIMEOUT) if quiet else part.close()
            except Exception:                      # noqa: BLE001 - closing after a signal
                if not quiet:
                    raise
    finally:
        if quiet:
            for n, level in levels.items():
                logging.getLogger(n).setLevel(level)
