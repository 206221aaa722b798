"""How one command runs as a process: logging (dask's own chatter kept quiet), and
Ctrl-C or SIGTERM turned into a clean stop with exit code 130 or 143."""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
from contextlib import contextmanager

from granavg.errors import literal, named
from granavg.io import output_set


def outputs_written() -> list:
    """The main files of the output sets this command committed (a signal after them
    finds them complete; :mod:`granavg.io.output_set`)."""
    return output_set.committed()


def no_room(raised: BaseException) -> str | None:
    """The one-line message for a write that failed for want of room (a full disk, a
    file-size limit), else None."""
    if isinstance(raised, OSError) and raised.errno in output_set.NO_ROOM:
        where = f"{raised.filename}: " if raised.filename else ""
        return named(f"{literal(where)}{os.strerror(raised.errno).lower()} (the disk is "
                     "full or a file-size limit was reached); free some space or choose "
                     "another {out}")
    return None


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an exception like Ctrl-C's."""


_signalled: list[int] = []          # the signals received during this command


def _on_signal(signum, frame):
    _signalled.append(signum)
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def interrupt_code(raised: BaseException) -> int | None:
    """Exit code when ``raised`` is (the aftermath of) Ctrl-C or SIGTERM, else None.

    A signal can land inside a compiled (numba) call or a ctypes callback; there the
    interrupt is swallowed or turned into another error (``SystemError``, numba's
    ``RuntimeError``), so any error raised after a signal arrived counts as the signal's.
    """
    if isinstance(raised, Terminated) or signal.SIGTERM in _signalled:
        return 143
    if isinstance(raised, KeyboardInterrupt) or _signalled:
        return 130
    return None


def _unraisable(previous):
    """``sys.unraisablehook`` that keeps an interrupt inside a callback quiet (the
    command reports it)."""
    def hook(unraisable):
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            previous(unraisable)
    return hook


class _Once(logging.Filter):
    """Lets each distinct line through once per command: a verdict on the same window
    (the demo averages it over 20 and over 60 rings) is said once."""

    def __init__(self):
        super().__init__()
        self._seen = set()

    def filter(self, record: logging.LogRecord) -> bool:
        key = (record.levelno, record.getMessage())
        if key in self._seen:
            return False
        self._seen.add(key)
        return True


def configure_logging(verbose: bool) -> None:
    """granavg's log lines on stderr; dask's INFO chatter (and its shutdown tracebacks)
    only with ``verbose``."""
    handler = logging.StreamHandler()
    handler.addFilter(_Once())
    handler.setFormatter(logging.Formatter("granavg: %(message)s"))
    logging.basicConfig(level=logging.DEBUG if verbose else logging.INFO, handlers=[handler])
    quiet = "debug" if verbose else "warning"
    for noisy in ("distributed", "tornado", "bokeh"):     # dask's own chatter
        logging.getLogger(noisy).setLevel(quiet.upper())
    # distributed resets its loggers from dask's config when imported: set it there, and
    # in the environment for a dask imported later (without importing it here)
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", quiet)
    if "dask" in sys.modules:
        sys.modules["dask"].config.set({"logging.distributed": quiet})


def use_threads(n) -> None:
    """The engine's thread count for this command (``--threads``; None: the default,
    :func:`granavg.engine.threads.count`)."""
    if n is not None:
        from granavg.engine import threads
        threads.set_count(n)


@contextmanager
def signals_as_interrupts():
    """Within the block, SIGTERM and SIGINT raise :class:`Terminated` or
    KeyboardInterrupt (the previous handlers come back after it)."""
    _signalled.clear()
    output_set.forget()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, _on_signal)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:   # not if ignored
            previous[signal.SIGINT] = signal.signal(signal.SIGINT, _on_signal)
    unraisable, sys.unraisablehook = sys.unraisablehook, _unraisable(sys.unraisablehook)
    try:
        yield
    finally:
        sys.unraisablehook = unraisable
        for signum, handler in previous.items():
            signal.signal(signum, handler)
