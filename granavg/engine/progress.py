"""The progress of a pass over frames: a tqdm bar where stderr is a terminal, else a log
line now and then, so that a log file (stderr redirected) shows a long pass going on.

Off a terminal nothing is said before :data:`EVERY` seconds have passed: a short pass
(and a refusal on its first frame) stays silent; a long one says how far it got every
:data:`EVERY` seconds and, at its end, how many frames it took and how long.
"""

from __future__ import annotations

import logging
import numbers
import sys
import time

log = logging.getLogger(__name__)

#: Seconds between two progress lines off a terminal (and before the first).
EVERY = 15.0


def progress_of(frames, progress: bool | None, what: str = "averaging"):
    """The frames, wrapped to show the pass' progress as ``progress`` asks.

    Parameters
    ----------
    frames : iterable
        The frames of the pass.
    progress : bool or None
        True: a tqdm bar; False: nothing; None: a bar where stderr is a terminal, else
        log lines (:func:`logged`).
    what : str
        The pass' name in the bar or the lines.

    Returns
    -------
    iterable
        The same frames, in the same order.
    """
    if progress is not None and not progress:
        return frames
    if progress or sys.stderr.isatty():
        from tqdm.auto import tqdm          # only where a bar shows: its import is 0.04 s
        return tqdm(frames, desc=what, unit="frame")
    return logged(frames, what)


def logged(frames, what: str = "averaging", every: float | None = None,
           clock=time.monotonic):
    """The frames, with an INFO log line on the pass' progress at most every ``every``
    seconds, and one at its end if any was said.

    Parameters
    ----------
    frames : iterable
        The frames of the pass (those with a ``time`` attribute say it).
    what : str
        The pass' name, first in each line.
    every : float, optional
        Seconds between two lines (and before the first); default :data:`EVERY`.
    clock : callable
        Seconds of a monotonic clock (a test's own).

    Yields
    ------
    object
        Each frame, as ``frames`` gives it.
    """
    every = EVERY if every is None else every
    total = len(frames) if hasattr(frames, "__len__") else None
    start = last = clock()
    count, said = 0, False
    for frame in frames:
        yield frame
        count += 1
        now = clock()
        if now - last >= every:
            log.info("%s: %s", what, _line(count, total, now - start,
                                           getattr(frame, "time", None)))
            last, said = now, True
    if said:
        log.info("%s: %d frames read in %.0f s", what, count, clock() - start)


def _line(count: int, total: int | None, seconds: float, t) -> str:
    """How far a pass got: ``40/200 frames read (20%), t = 3.25, 12 s``.

    Parameters
    ----------
    count : int
        Frames taken so far.
    total : int or None
        Frames in all, where known.
    seconds : float
        Time since the pass started.
    t : float or None
        The last frame's time, where it has one.

    Returns
    -------
    str
        The line, without the pass' name.
    """
    frames = "frame" if count == 1 else "frames"
    done = f"{count}/{total} {frames} read ({100 * count / total:.0f}%)" if total else \
        f"{count} {frames} read"
    at = f", t = {t:g}" if isinstance(t, numbers.Real) else ""
    return f"{done}{at}, {seconds:.0f} s"
