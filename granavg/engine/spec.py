"""What an average of frames is, as one immutable value: the engine's part of an
average's spec (:class:`Averaging`: the quantities, the time axis, the species of a
mixture, the branch vectors' convention and the errors' sectors), validated once when
it is made. The pipeline's spec (:class:`granavg.pipeline.spec.Spec`) adds the source,
the cells, the kernel and the execution; every function below the pipeline takes this
part, or the one part of it it needs (:class:`TimeAxis`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, field, fields, replace

from granavg.engine import timing
from granavg.engine.kernels import BRANCHES
from granavg.engine.uncertainty import structure
from granavg.errors import ParameterError


def positive(name: str, value):
    """A finite number > 0 (or None), else a one-line refusal naming the parameter
    ``name``."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ParameterError(name, f"{{param}} {float(value):g}: must be a finite number > 0")
    return value


def finite(name: str, value):
    """A finite number (or None), else a one-line refusal naming the parameter ``name``."""
    if value is not None and not math.isfinite(value):
        raise ParameterError(name, f"{{param}} {float(value):g}: must be a finite number")
    return value


@dataclass(frozen=True)
class TimeAxis:
    """Which frames are averaged, and how time is resolved (:func:`granavg.engine.timing.axis`).

    Attributes
    ----------
    t_min, t_max : float or None
        The frames averaged: t_min <= t <= t_max (None: from the first, to the last).
    block_time : float or None
        The base block of the errors' blocking analysis (None: the frames' spacing).
    windows : float or None
        A field per window of this length.
    window_frames : int or None
        A field per this many frames.
    time_kernel, time_width, times : optional
        Fields at ``times`` (START, STOP, STEP) smoothed by a time kernel of this width.
    interval, window_start, origin : float or None
        Resolved from the data by a client for its workers: the frames' spacing, the
        first window's start and a frame's time on the frames' grid (the phases of a
        time kernel's quadrature error count frames from it; None: from the first
        frames).
    """

    t_min: float | None = None
    t_max: float | None = None
    block_time: float | None = None
    windows: float | None = None
    window_frames: int | None = None
    time_kernel: str | None = None
    time_width: float | None = None
    times: tuple | None = None
    interval: float | None = None
    window_start: float | None = None
    origin: float | None = None

    def __post_init__(self):
        finite("t_min", self.t_min)
        finite("t_max", self.t_max)
        positive("block_time", self.block_time)
        if self.times is not None and not isinstance(self.times, tuple):
            object.__setattr__(self, "times", tuple(self.times))
        self.axis(interval=1.0 if self.window_frames is not None else None)

    @property
    def in_time(self) -> bool:
        """Whether the fields are resolved in time (windows, or smoothed in time)."""
        return any(getattr(self, k) is not None for k in timing.OPTIONS if k != "t_max")

    def axis(self, interval: float | None = None, window_start: float | None = None):
        """The time axis (:mod:`granavg.engine.timing`), given the frames' spacing and
        the first window's start where the data fix them (this spec's own first)."""
        axis = timing.axis(self, self.interval if self.interval is not None else interval,
                           self.window_start if self.window_start is not None
                           else window_start)
        if self.origin is not None and axis.kind == "smoothed":
            axis.origin = float(self.origin)
        return axis


@dataclass(frozen=True)
class Averaging:
    """The engine's part of an average's spec.

    Attributes
    ----------
    quantities : tuple of str or None
        Keys of :data:`granavg.engine.quantities.QUANTITIES`; None: all the frames allow.
    time : TimeAxis
        The frames averaged and the time axis.
    species : str, dict, Classes or None
        A mixture's species (:mod:`granavg.engine.species`).
    branch : {"contact", "paper"}
        Where the branch vectors of Eqs. 5 and 7 end (:data:`granavg.engine.kernels.BRANCHES`).
    sectors : "auto", int or None
        Spatial replicas for the errors (:mod:`granavg.engine.uncertainty.structure`);
        ``off`` and 0 are None.
    """

    quantities: tuple | None = None
    time: TimeAxis = field(default_factory=TimeAxis)
    species: object = None
    branch: str = "contact"
    sectors: object = "auto"

    def __post_init__(self):
        if self.quantities is not None and not isinstance(self.quantities, tuple):
            object.__setattr__(self, "quantities", tuple(self.quantities))
        if self.branch not in BRANCHES:
            raise ParameterError("branch", f"{{param}} {self.branch!r}: choose from "
                                 f"{', '.join(BRANCHES)}")
        sectors = None if self.sectors in ("off", 0) else self.sectors
        if sectors not in ("auto", None) and not (
                isinstance(sectors, numbers.Integral) and
                structure.MIN_REPLICAS <= sectors <= structure.MAX_SECTORS):
            raise ParameterError("sectors", f"{{param}} {sectors!r}: give auto, off or a "
                                 f"number of sectors from {structure.MIN_REPLICAS} to "
                                 f"{structure.MAX_SECTORS}")
        object.__setattr__(self, "sectors", int(sectors)
                           if isinstance(sectors, numbers.Integral) else sectors)

    @property
    def reach(self) -> float:
        """The overlap fraction the branch vectors give up (:data:`BRANCHES`)."""
        return BRANCHES[self.branch]

    @classmethod
    def of(cls, *, quantities=None, species=None, branch: str = "contact", sectors="auto",
           **time) -> "Averaging":
        """The part built from flat options, as the command line and the Python API
        name them (``t_min``, ``windows``, ...: :class:`TimeAxis`'s fields)."""
        unknown = sorted(set(time) - {f.name for f in fields(TimeAxis)})
        if unknown:
            raise ParameterError(unknown[0], "{param}: not an option of an average")
        return cls(quantities, TimeAxis(**{k: v for k, v in time.items() if v is not None}),
                   species, branch, sectors)

    def with_time(self, **changes) -> "Averaging":
        """This averaging with the time axis' fields changed (resolved ones)."""
        return replace(self, time=replace(self.time, **changes))

    def to_dict(self) -> dict:
        """The plain values (JSON), every field named."""
        out = asdict(self)
        out["quantities"] = list(self.quantities) if self.quantities is not None else None
        out["time"]["times"] = list(self.time.times) if self.time.times is not None else None
        if self.species is not None and not isinstance(self.species, (str, dict)):
            out["species"] = self.species.describe() if hasattr(self.species, "describe") \
                else str(self.species)
        return out

    @classmethod
    def from_dict(cls, data: dict) -> "Averaging":
        """The part :meth:`to_dict` wrote."""
        return cls(data.get("quantities"), TimeAxis(**(data.get("time") or {})),
                   data.get("species"), data.get("branch", "contact"),
                   data.get("sectors", "auto"))
