"""How one command runs as a process: logging (dask's own chatter kept quiet), and
Ctrl-C or SIGTERM turned into a clean stop with exit code 130 or 143."""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import warnings
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

    A signal can land inside a compiled call or a ctypes callback (LAMMPS); there the
    interrupt is swallowed or turned into another error (``SystemError``, a
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


#: What each line the command writes to stderr starts with, once.
PREFIX = "granavg: "
#: Loggers of dask's own chatter (quiet unless ``verbose``).
DASK_LOGGERS = ("distributed", "tornado", "bokeh")


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


class _OnePrefix(logging.Formatter):
    """Each line of a message with exactly one :data:`PREFIX` (one it already carries,
    e.g. a line passed on from another granavg process, is not doubled)."""

    def format(self, record: logging.LogRecord) -> str:
        return "\n".join(PREFIX + _unprefixed(line)
                         for line in super().format(record).splitlines() or [""])


def _unprefixed(line: str) -> str:
    """``line`` without the :data:`PREFIX` (or prefixes) it starts with."""
    while line.startswith(PREFIX):
        line = line[len(PREFIX):]
    return line


class _Stderr(logging.StreamHandler):
    """The command's one handler: the stderr of the moment (so a redirected or captured
    stream gets the lines), one :data:`PREFIX` per line, each distinct line once."""

    def __init__(self):
        super().__init__()
        self.addFilter(_Once())
        self.setFormatter(_OnePrefix("%(message)s"))

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        """The stream is always the current ``sys.stderr``; setting it does nothing."""


def log_to_stderr(verbose: bool = False) -> None:
    """granavg's log lines, and Python's warnings, on stderr through one handler
    (:class:`_Stderr`), set up anew by each command (before its options are parsed:
    a refusal of them is such a line too).

    Parameters
    ----------
    verbose : bool
        Debug lines too (``-v``).
    """
    root = logging.getLogger()
    for old in [h for h in root.handlers if isinstance(h, _Stderr)]:
        root.removeHandler(old)
    root.addHandler(_Stderr())
    root.setLevel(logging.DEBUG if verbose else logging.INFO)
    warnings.showwarning = _warning_line


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A Python warning as one log line (``warnings.showwarning``), not the two
    unprefixed lines Python writes."""
    logging.getLogger("py.warnings").warning("%s: %s (%s:%s)", category.__name__,
                                             str(message).strip(), filename, lineno)


def configure_logging(verbose: bool) -> None:
    """The command's logging (:func:`log_to_stderr`): more with ``verbose``; dask's INFO
    chatter (and its shutdown tracebacks) only with ``verbose``, through the same
    handler, and with the same prefix in the processes of a local dask cluster
    (:func:`_dask_workers_log`).

    Parameters
    ----------
    verbose : bool
        Debug lines, granavg's and dask's (``-v``).
    """
    log_to_stderr(verbose)
    quiet = "debug" if verbose else "warning"
    for noisy in DASK_LOGGERS:                     # dask's own chatter
        logger = logging.getLogger(noisy)
        logger.setLevel(quiet.upper())
        for own in [h for h in logger.handlers if not isinstance(h, _Stderr)]:
            logger.removeHandler(own)              # distributed imported before: its
        logger.propagate = True                    # handler, without the prefix
    _dask_workers_log(quiet)


def _dask_workers_log(quiet: str) -> None:
    """The logging of the dask worker processes this command starts, set up from the
    environment when they import distributed: its messages at ``quiet`` and up, and
    granavg's warnings, each with one :data:`PREFIX` (their granavg logger's level
    NOTSET: in a worker, the root's WARNING; in this process it changes nothing).

    distributed resets its loggers from dask's config when imported: set it there, and
    in the environment for a dask imported later (without importing it here); a user's
    own settings win.

    Parameters
    ----------
    quiet : str
        The level of distributed's messages: "warning", or "debug" with ``-v``.
    """
    settings = {"logging.distributed": quiet, "logging.granavg": "notset",
                "distributed.admin.log-format": PREFIX + "%(message)s"}
    for key, value in settings.items():
        os.environ.setdefault("DASK_" + key.upper().replace(".", "__").replace("-", "_"),
                              value)
    if "dask" in sys.modules:
        sys.modules["dask"].config.set(settings)


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
