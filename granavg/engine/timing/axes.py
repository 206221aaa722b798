"""What times an average gives fields at: one average over every frame (:class:`Whole`),
one per window of time (:class:`Windows`), or fields smoothed by a time kernel at given
times (:class:`Smoothed`), with their time derivatives.

An axis tells the averager which of its accumulators ("slots") a frame at time t adds
to, with which weight w and which weight dw of the time derivative: the field of slot j
is sum_f w_fj S_f / sum_f w_fj (S_f the frame's cell sums), and its time derivative
(sum_f dw_fj S_f - field sum_f dw_fj) / sum_f w_fj, the exact derivative of the
smoothed field sampled at the frames. Each slot is its own accumulator: slots merge
exactly, so dask workers, ensembles and the serial pass agree, and memory grows with
slots x cells, not with frames.
"""

from __future__ import annotations

import math

import numpy as np

from granavg.errors import ParameterError

#: Relative slack of frame times against window edges and time steps (their rounding).
SLACK = 1e-9

#: Two times closer than this fraction of the frames' spacing are the same time: a frame
#: at t_min or t_max (or a window's edge) is in, whatever the rounding of its time
#: (a binary dump's 0.48000000000000004 is a text dump's 0.48). One tolerance for every
#: format and every comparison of a frame's time with a bound.
TIME_TOLERANCE = 1e-6


class Whole:
    """One average of every frame in [t_min, t_max] (the steady state's)."""

    kind = "whole"
    derivative = False
    times = None

    def hits(self, t: float) -> list:
        return [(0, 1.0, 0.0)]

    def describe(self) -> dict:
        return {"kind": self.kind}


class Windows:
    """A field per window of time: [start + j length, start + (j + 1) length), the last
    one closed at ``end``.

    Parameters
    ----------
    start : float
        The first window's start (t_min).
    length : float
        Each window's length (> 0).
    end : float, optional
        The last frame time averaged (t_max); open-ended where None.
    frames : int, optional
        The windows were asked as this many frames each (for the sidecar).
    """

    kind = "windows"
    derivative = False

    def __init__(self, start: float, length: float, end: float | None = None,
                 frames: int | None = None):
        if not (math.isfinite(length) and length > 0):
            raise ParameterError("windows", f"{{param}} {length:g}: give a window length "
                                 "> 0 (in the frames' time unit)")
        self.start, self.length, self.end, self.frames = float(start), float(length), end, frames
        self.seen = -1                      # the last window a frame fell in

    def index(self, t: float) -> int:
        j = max(int(math.floor((t - self.start) / self.length + SLACK)), 0)   # (a frame
        # on the start within its rounding: the first window's)
        if self.end is not None and j > 0 and abs(t - self.end) <= SLACK * self.length \
                and abs(self.start + j * self.length - t) <= SLACK * self.length:
            j -= 1                           # t_max on an edge closes the last window
        return j

    def hits(self, t: float) -> list:
        j = self.index(t)
        self.seen = max(self.seen, j)
        return [(j, 1.0, 0.0)]

    def edges(self, n: int) -> np.ndarray:
        """The first ``n`` windows' edges, shape (n + 1,)."""
        return self.start + self.length * np.arange(n + 1)

    def times_of(self, slots) -> np.ndarray:
        """The windows' middles."""
        return self.start + self.length * (np.asarray(slots, float) + 0.5)

    def describe(self) -> dict:
        out = {"kind": self.kind, "start": self.start, "length": self.length}
        if self.frames:
            out["frames_each"] = self.frames
        return out


class Smoothed:
    """Fields at ``times`` smoothed by a time kernel (:mod:`granavg.engine.timing`):
    a frame at t_f weighs psi(t_j - t_f) in the field at t_j, and psi'(t_j - t_f) in its
    time derivative.

    Parameters
    ----------
    kernel : TimeKernel
    width : float
        The kernel's width (what it is: ``kernel.width_is``).
    times : array_like
        The times of the fields, increasing.
    interval : float, optional
        The frames' spacing (the quadrature's step): checked against the width.
    """

    kind = "smoothed"
    derivative = True

    def __init__(self, kernel, width: float, times, interval: float | None = None):
        self.kernel, self.width = kernel, float(width)
        self.times = np.asarray(times, float)
        self.cutoff = kernel.cutoff(self.width)
        self.interval = None
        #: a frame's time (the frames' grid: frame k is at origin + k interval)
        self.origin = None
        if interval is not None:
            self.fit(interval)

    def fit(self, interval: float) -> None:
        """Check the width against the frames' spacing ``interval``: a kernel narrower
        than it leaves single frames, not a quadrature."""
        if self.width < interval * (1 - SLACK):
            raise ParameterError("time_width", f"{{param}} {self.width:g}: below the "
                                 f"frames' interval {interval:g}, the kernel would weigh "
                                 "single frames; give a width of several frame intervals "
                                 f"(at least {interval:g}), or dump more often")
        self.interval = float(interval)

    def hits(self, t: float) -> list:
        lo, hi = np.searchsorted(self.times, [t - self.cutoff, t + self.cutoff])
        if hi <= lo:
            return []
        psi, dpsi = self.kernel.weights(self.times[lo:hi] - t, self.width)
        return [(int(lo + k), float(psi[k]), float(dpsi[k])) for k in range(hi - lo)
                if psi[k] > 0]

    def flux_hits(self, t0: float, t1: float) -> list:
        """The slots the interval between consecutive frames at ``t0`` and ``t1`` adds
        its displacements' flux to, with the weight u that makes the continuity equation
        hold by summation by parts: [(j, u)].

        The field at t_j is sum_g psi_g S_g / W (psi_g = psi(t_j - t_g), W = sum_g
        psi_g) and its derivative sum_g a_g S_g / W with a_g = psi'_g - psi_g A / W,
        A = sum_g psi'_g (:meth:`hits`, :meth:`~granavg.engine.cell_average.Slot.rates`):
        the a_g sum to zero. With rho_g+1 - rho_g = -dt div j_g for the interval g (the
        displacements' flux, exact), sum_g a_g rho_g = -dt sum_g U_g div j_g when U_f =
        -sum_{g <= f} a_g = sum_{g > f} a_g, over the frames of t_j's support on the
        frames' grid (each taken on the side of t_j away from the interval, for its
        round-off). u = dt U: about psi at the interval's middle."""
        dt = t1 - t0
        mid = 0.5 * (t0 + t1)
        lo, hi = np.searchsorted(self.times, [mid - self.cutoff - dt, mid + self.cutoff + dt])
        out = []
        for j in range(lo, hi):
            s0 = self.times[j] - t0                     # the lag of the interval's start
            back = int(math.ceil((self.cutoff - s0) / dt)) + 1    # frames before t0 ...
            ahead = int(math.ceil((self.cutoff + s0) / dt)) + 1   # ... and after it
            k = np.arange(-ahead, back + 1)             # t_g = t0 - k dt
            psi, dpsi = self.kernel.weights(s0 + dt * k, self.width)
            W = float(np.sum(psi))
            if W == 0.0:
                continue
            a = dpsi - psi * (float(np.sum(dpsi)) / W)
            u = -float(np.sum(a[k >= 0])) if self.times[j] >= mid else \
                float(np.sum(a[k < 0]))
            if u != 0.0:
                out.append((int(j), dt * u))
        return out

    def reach(self, first: float, last: float) -> None:
        """Refuse times whose kernel reaches beyond the frames [first, last] (half a
        frame interval of slack: the frames' quadrature covers it)."""
        slack = 0.5 * (self.interval or 0.0) + SLACK * self.cutoff
        lo = self.times - self.cutoff < first - slack
        hi = self.times + self.cutoff > last + slack
        bad = np.flatnonzero(lo | hi)
        if len(bad):
            t = self.times[bad[0]]
            ok = (first + self.cutoff - slack, last - self.cutoff + slack)
            span = (f"from {ok[0]:g} on" if math.isinf(last) else
                    f"from {ok[0]:g} to {ok[1]:g}" if ok[1] >= ok[0] else
                    "none: the frames span less than the kernel")
            raise ParameterError("times", f"{{param}}: at t = {t:g} the time kernel "
                                 f"reaches t = {t - self.cutoff:g} .. "
                                 f"{t + self.cutoff:g}, beyond the frames ({first:g} .. "
                                 f"{last:g}); the times it can give are {span}")

    def describe(self) -> dict:
        return {"kind": self.kind, "kernel": self.kernel.name, "width": self.width,
                "cutoff": self.cutoff, "interval": self.interval,
                "quadrature": "the frames as equally weighted nodes (evenly spaced)"}
