"""The engine's threads: the chunks of a frame's particles summed on several cores (the
count also sets the reader threads of :mod:`granavg.io.reader`; one: no thread beside
the engine).

The compiled kernels release the GIL, so chunks of a frame's particles
(:data:`granavg.engine.frame_sums.CHUNK` each) run on threads of one pool. Their partial
sums are added in chunk order, and the chunks' bounds do not depend on the thread count,
so the result is bit-identical for any thread count (tests/test_threads.py).

The count defaults to the cores this process may run on (``os.sched_getaffinity``),
``GRANAVG_THREADS`` in the environment overrides it and :func:`set_count` (the CLI's
``--threads``) sets it.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

from granavg.errors import ParameterError

_chosen: int | None = None
_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_lock = threading.Lock()


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                                  # not on Linux
        return os.cpu_count() or 1


def _checked(n, where: str) -> int:
    """``n`` (an int or its digits) as a thread count >= 1; a one-line refusal else."""
    text = str(n).strip()
    if isinstance(n, bool) or not (isinstance(n, int) or text.isdigit()) or int(text) < 1:
        raise ParameterError("threads", f"{where} {n!r}: give a whole number of threads, 1 "
                             f"or more (this machine has {cores()} cores)")
    return int(text)


def count() -> int:
    """The engine's thread count: :func:`set_count`'s, else ``GRANAVG_THREADS``, else
    :func:`cores`."""
    if _chosen is not None:
        return _chosen
    env = os.environ.get("GRANAVG_THREADS")
    return _checked(env, "GRANAVG_THREADS") if env else cores()


def set_count(n) -> int:
    """Set the engine's thread count (``None``: back to the default); returns it."""
    global _chosen
    _chosen = None if n is None else _checked(n, "{param}")
    return count()


def map_ordered(fn, items):
    """``fn`` over ``items``, on the engine's threads when there are several items and
    threads; the results in the items' order (an iterator)."""
    items = list(items)
    n = min(count(), len(items))
    if n <= 1:
        return map(fn, items)
    return _executor(count()).map(fn, items)


def _executor(n: int) -> ThreadPoolExecutor:
    """The pool of ``n`` threads, started once per process (and again if n changes)."""
    global _pool, _pool_size
    with _lock:
        if _pool is None or _pool_size != n:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool, _pool_size = ThreadPoolExecutor(n, thread_name_prefix="granavg-engine"), n
        return _pool
