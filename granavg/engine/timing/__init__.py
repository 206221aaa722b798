"""Fields in time: time kernels, one per module (each module of this package that
defines ``TIME_KERNEL``, a :class:`~granavg.engine.timing.base.TimeKernel`, found
without being listed; :func:`register` adds one of your own), and the time axes of an
average (:mod:`granavg.engine.timing.axes`): one average, windows, or fields smoothed
in time with their time derivatives. :func:`axis` builds an axis from the options.
"""

from __future__ import annotations

import math

import numpy as np

from granavg.engine.plugins import Registry
from granavg.engine.timing.axes import Smoothed, Whole, Windows
from granavg.engine.timing.base import TimeKernel, contract
from granavg.errors import ParameterError

#: The time kernels, by name.
TIME_KERNELS = Registry(__name__, "TIME_KERNEL", lambda k: isinstance(k, TimeKernel),
                        lambda k: k.name, contract, group="granavg.time_kernels")

#: At most this many times or windows in one average (each is an accumulator).
MAX_SLOTS = 100_000
#: The time options of a spec besides t_min (:class:`~granavg.engine.spec.TimeAxis`).
OPTIONS = ("t_max", "windows", "window_frames", "time_kernel", "time_width", "times")


def registry() -> dict:
    """Every time kernel, by name."""
    return TIME_KERNELS.all()


def register(kernel: TimeKernel) -> TimeKernel:
    """Add a time kernel of your own (checked against the contract); returns it."""
    return TIME_KERNELS.register(kernel)


def names() -> str:
    """The time kernels' names as a message lists them: ``gauss or lucy``."""
    found = sorted(registry())
    return found[0] if len(found) == 1 else f"{', '.join(found[:-1])} or {found[-1]}"


def catalogue() -> str:
    """The time kernels in words, for help texts (with what the width is)."""
    return ", ".join(f"{k.name} ({k.help}; the width is {k.width_is})"
                     for k in registry().values())


def get(name: str) -> TimeKernel:
    """The time kernel called ``name`` (one-line refusal of an unknown one)."""
    known = registry()
    if name not in known:
        raise ParameterError("time_kernel", f"{{param}} {name!r}: choose {names()}")
    return known[name]


def time_grid(times) -> np.ndarray:
    """The times of ``START STOP STEP`` (STOP included where the steps reach it)."""
    try:
        start, stop, step = (float(x) for x in times)
    except (TypeError, ValueError):
        raise ParameterError("times", "{param} takes START STOP STEP") from None
    if not all(map(math.isfinite, (start, stop, step))) or step <= 0 or stop < start:
        raise ParameterError("times", f"{{param}} {start:g} {stop:g} {step:g}: give START "
                             "<= STOP and a STEP > 0")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > MAX_SLOTS:
        raise ParameterError("times", f"{{param}}: {n} times, more than {MAX_SLOTS}; "
                             "take a longer STEP")
    return start + step * np.arange(n)


def axis(time, interval: float | None = None, window_start: float | None = None):
    """The time axis a spec's :class:`~granavg.engine.spec.TimeAxis` asks for (one-line
    refusals of options that do not go together).

    Parameters
    ----------
    time : TimeAxis
        The frames averaged, t_min <= t <= t_max (t_min None: 0), and one way to
        resolve time: ``windows`` (a field per window of this length),
        ``window_frames`` (a field per this many frames: windows of that many frame
        intervals) or ``time_kernel``, ``time_width`` and ``times`` (fields at START
        STOP STEP smoothed by this time kernel of this width).
    interval : float, optional
        The frames' spacing, where known (the first two frames').
    window_start : float, optional
        The first window's start (default t_min).
    """
    t_min, t_max = time.t_min or 0.0, time.t_max
    windows, window_frames = time.windows, time.window_frames
    time_kernel, time_width, times = time.time_kernel, time.time_width, time.times
    start = t_min if window_start is None else window_start
    if t_max is not None and not t_max >= t_min:
        raise ParameterError("t_max", f"{{param}} {t_max:g}: before {{t_min}} {t_min:g}; "
                             "give t_max >= t_min")
    smoothed = any(x is not None for x in (time_kernel, time_width, times))
    if (windows is not None) + (window_frames is not None) + smoothed > 1:
        raise ParameterError("windows", "{param}, {window_frames} and {time_kernel} are "
                             "three ways to resolve time: give one")
    if window_frames is not None:
        if not (isinstance(window_frames, (int, np.integer)) and window_frames >= 1):
            raise ParameterError("window_frames", f"{{param}} {window_frames!r}: give a "
                                 "whole number of frames >= 1")
        if interval is None:
            raise ParameterError("window_frames", "{param} needs the frames' interval: "
                                 "give {windows} as a length of time instead")
        return Windows(start, window_frames * interval, t_max, frames=int(window_frames))
    if windows is not None:
        return Windows(start, float(windows), t_max)
    if not smoothed:
        return Whole()
    missing = [n for n, v in (("time_kernel", time_kernel), ("time_width", time_width),
                              ("times", times)) if v is None]
    if missing:
        raise ParameterError(missing[0], "fields smoothed in time need {time_kernel}, "
                             "{time_width} and {times} together; {param} is missing")
    if not (math.isfinite(float(time_width)) and float(time_width) > 0):
        raise ParameterError("time_width", f"{{param}} {time_width}: give a width > 0")
    at = time_grid(times)
    kernel = get(time_kernel)
    axis_ = Smoothed(kernel, float(time_width), at, interval)
    late = at + axis_.cutoff > t_max if t_max is not None else np.zeros(len(at), bool)
    early = at - axis_.cutoff < t_min
    if np.any(late | early):
        t = at[np.flatnonzero(late | early)[0]]
        raise ParameterError("times", f"{{param}}: at t = {t:g} the time kernel reaches "
                             f"{t - axis_.cutoff:g} .. {t + axis_.cutoff:g}, beyond the "
                             f"frames averaged ({{t_min}} {t_min:g}"
                             + (f", {{t_max}} {t_max:g}" if t_max is not None else "")
                             + "); choose times one cutoff inside them")
    return axis_


__all__ = ["Whole", "Windows", "Smoothed", "TimeKernel", "axis", "get", "register",
           "registry", "names", "catalogue", "time_grid"]
