"""One immutable spec for an average: what is averaged (the source), over what (the
cells, a smoothing kernel), which quantities, along which time axis, for which species,
with which errors, and where it runs (the execution). The command line, ``granavg.average``,
dask, in situ and Yade build it here (:meth:`Spec.of`), once, validated as it is made;
the functions below take it, or the one part of it they need. It is written whole into
the sidecar (``meta["spec"]``), so that an output says exactly how it was made, and
``granavg average --spec FILE`` remakes it (:meth:`Spec.load`).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from granavg.engine.spec import Averaging, positive
from granavg.errors import ParameterError, UserError, literal

#: The version of the spec's plain form (``to_dict``).
SPEC_VERSION = 1
#: The time axis' fields that the data resolve (a client for its workers), not options.
RESOLVED = ("interval", "window_start", "origin")


@dataclass(frozen=True)
class Source:
    """What is averaged.

    Attributes
    ----------
    runs : tuple of str
        Run directories of ``granavg simulate`` (several: an ensemble).
    atoms, contacts : str or None
        Per-atom and per-contact files (with a run directory: others than its own).
    fmt : str or None
        The files' format (None: the one that claims them).
    density : float or None
        Material density of anyone's files (masses), unless the atoms carry masses.
    gravity : tuple of float or None
        A body force m g on every particle.
    options : dict
        The format's own options (:func:`granavg.io.formats.options`), parsed.
    frames : optional
        Frames in this process (a :class:`~granavg.io.trajectory.Trajectory` selection,
        or frames in memory; a str names them: ``LAMMPS, in situ``) instead of files;
        written as what they were.
    """

    runs: tuple = ()
    atoms: str | None = None
    contacts: str | None = None
    fmt: str | None = None
    density: float | None = None
    gravity: tuple | None = None
    options: dict = field(default_factory=dict)
    frames: object = field(default=None, compare=False)

    def __post_init__(self):
        positive("density", self.density)
        positive("dt", self.options.get("dt"))
        if self.gravity is not None:
            object.__setattr__(self, "gravity", tuple(float(g) for g in self.gravity))

    def given(self) -> list:
        """The names of anyone's files' options given (not for a run directory)."""
        return [k for k, v in (("density", self.density), ("gravity", self.gravity),
                               ("fmt", self.fmt), *self.options.items())
                if v not in (None, (), [])]


@dataclass(frozen=True)
class Execution:
    """Where and how an average runs: the same fields whatever it says.

    Attributes
    ----------
    workers : int or None
        A local dask cluster of this many processes (None: this process).
    scheduler : str or None
        A dask scheduler's address.
    progress : bool or None
        A progress bar (None: on a terminal); not written.
    check_cells : callable, optional
        Called with the cells before any frame is read (that an output can hold them);
        not written.
    """

    workers: int | None = None
    scheduler: str | None = None
    progress: bool | None = field(default=False, compare=False)
    check_cells: object = field(default=None, compare=False)

    def __post_init__(self):
        if self.workers is not None and self.workers < 1:
            raise ParameterError("workers", f"{{param}} {self.workers}: must be >= 1 (or "
                                 "leave it out)")

    @property
    def on_dask(self) -> bool:
        return self.workers is not None or bool(self.scheduler)


@dataclass(frozen=True)
class Spec:
    """An average, whole (the module docstring).

    Attributes
    ----------
    source : Source
    cells : Cells, dict or None
        The cells (:mod:`granavg.cells`), or their options as the command line takes
        them (:func:`granavg.engine.cells.from_options`), lengths defaulting to the
        data's box (a run's: 20 rings from R_i to R_o).
    kernel, width : optional
        A smoothing kernel (:func:`granavg.engine.smoothing.registry`) and its width in
        the data's length unit; None or ``exact``: the cells' exact averages.
    averaging : Averaging
        The engine's part: quantities, time axis, species, branch, sectors.
    execution : Execution
    """

    source: Source = field(default_factory=Source)
    cells: object = None
    kernel: str | None = None
    width: float | None = None
    averaging: Averaging = field(default_factory=Averaging)
    execution: Execution = field(default_factory=Execution)

    def __post_init__(self):
        positive("width", self.width)
        if self.source.runs and self.source.given():
            raise ParameterError(self.source.given()[0], "{param} is for plain dumps; a "
                                 "run directory's manifest already says it (drop the "
                                 "option or the run directory)")
        if self.source.runs and self.averaging.species is not None and \
                self.execution.on_dask:
            raise ParameterError("species", "{param} on run directories averages in one "
                                 "process: leave out {workers} (on dask the species of a "
                                 "mixture are built for anyone's dumps)")
        if self.source.options.get("contact_map") and self.source.contacts is None and \
                self.source.frames is None and not self.source.runs:
            raise ParameterError("contact_map", "{param} maps the columns of a contact "
                                 "dump: give it ({contacts}), or leave the map out")

    @classmethod
    def of(cls, source=None, **options) -> "Spec":
        """The spec of flat options, as the command line and ``granavg.average`` name
        them, each sorted into its part by the part's own declaration: the source's
        (``atoms``, ``contacts``, ``fmt``, ``density``, ``gravity`` and a format's own,
        :func:`granavg.io.formats.options`), the cells' (``cells``, or the options that
        build them: ``bins=8``, :func:`granavg.engine.cells.option_specs`), ``kernel``
        and ``width``, the engine part's (:meth:`granavg.engine.spec.Averaging.of`:
        ``quantities``, ``species``, ``branch``, ``sectors``, ``t_min``, ``windows``,
        ...) and the execution's (``workers``, ``scheduler``, ``progress``,
        ``check_cells``); anything else is refused in one line.

        ``source``: a run directory, several (a list), a dump file or series, frames of
        :func:`granavg.open` or frames in memory."""
        from dataclasses import fields as fields_of

        from granavg.engine.cells import option_specs
        from granavg.engine.spec import TimeAxis
        from granavg.io import formats

        def part(names):
            return {k: options.pop(k) for k in list(options) if k in names}
        of_source = part({"atoms", "contacts", "fmt", "density", "gravity"})
        of_format = {k: v for k, v in part(formats.options()).items()
                     if v not in (None, (), [])}
        of_cells = {k: v for k, v in part(option_specs()).items() if v is not None}
        cells, kernel, width = (options.pop(k, None) for k in ("cells", "kernel", "width"))
        of_execution = part({f.name for f in fields_of(Execution)})
        of_engine = part({"quantities", "species", "branch", "sectors",
                          *(f.name for f in fields_of(TimeAxis) if f.name not in RESOLVED)})
        if options:
            raise ParameterError(sorted(options)[0], "{param}: not an option of "
                                 "granavg.average")
        if of_cells:
            if cells is not None and not isinstance(cells, dict):
                raise ParameterError(next(iter(of_cells)), "{param} builds cells; the "
                                     "cells are given whole: leave it out")
            cells = {**(cells or {}), **of_cells}
        runs, frames = _runs_or_frames(source)
        atoms = source if frames is None and not runs and source is not None else \
            of_source.pop("atoms", None)
        of_source.pop("atoms", None)
        return cls(Source(tuple(str(r) for r in runs), _path(atoms),
                          _path(of_source.pop("contacts", None)), options=of_format,
                          frames=frames, **of_source),
                   cells, kernel, width, Averaging.of(**of_engine), Execution(**of_execution))

    def with_averaging(self, averaging: Averaging) -> "Spec":
        """This spec with another engine part (resolved for a dask worker)."""
        return replace(self, averaging=averaging)

    def to_dict(self) -> dict:
        """The spec as plain values (JSON): every part named, what it cannot hold said."""
        from granavg.engine.cells.base import Cells

        src = self.source
        cells = {"described": self.cells.describe()} if isinstance(self.cells, Cells) \
            else dict(self.cells or {})
        return _plain({"version": SPEC_VERSION,
                "source": {"runs": list(src.runs), "atoms": src.atoms,
                           "contacts": src.contacts, "fmt": src.fmt,
                           "density": src.density,
                           "gravity": list(src.gravity) if src.gravity else None,
                           "options": dict(src.options),
                           **({"frames": _frames_said(src.frames)}
                              if src.frames is not None else {})},
                "cells": cells, "kernel": {"name": self.kernel, "width": self.width},
                **self.averaging.to_dict(),
                "execution": {"workers": self.execution.workers,
                              "scheduler": self.execution.scheduler}})

    @classmethod
    def from_dict(cls, data: dict, where: str = "the spec") -> "Spec":
        """The spec :meth:`to_dict` wrote (``where``: its file, for the refusals)."""
        from granavg.engine.cells import restore

        if not isinstance(data, dict) or data.get("version") != SPEC_VERSION:
            raise UserError(f"{where}: not a granavg spec of version {SPEC_VERSION} (the "
                            "'spec' of a sidecar written by 'granavg average'); average "
                            "with the options instead")
        src = data.get("source") or {}
        if src.get("frames"):
            raise UserError(f"{where}: averaged from {src['frames']}, which a spec cannot "
                            "hold; average its files again with the options")
        cells = data.get("cells") or None
        if isinstance(cells, dict) and "described" in cells:
            cells = restore(cells["described"])
        kernel, execution = data.get("kernel") or {}, data.get("execution") or {}
        try:
            return cls(Source(tuple(src.get("runs") or ()), src.get("atoms"),
                              src.get("contacts"), src.get("fmt"), src.get("density"),
                              src.get("gravity"), _tuples(src.get("options") or {})),
                       _tuples(cells) if isinstance(cells, dict) else cells,
                       kernel.get("name"), kernel.get("width"),
                       Averaging.from_dict(data),
                       Execution(execution.get("workers"), execution.get("scheduler")))
        except (TypeError, ValueError, KeyError) as exc:
            raise UserError(f"{where}: a damaged spec ({literal(str(exc))}); take it from "
                            "a sidecar 'granavg average' wrote") from None

    @classmethod
    def load(cls, path) -> "Spec":
        """The spec of a file: a sidecar's (``<out>.json``, its ``spec``) or a spec's own
        JSON (:meth:`to_dict`)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ParameterError("spec", f"{{param}} {literal(str(path))}: no such file") \
                from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ParameterError("spec", f"{{param}} {literal(str(path))}: not JSON "
                                 f"({literal(str(exc))}); give a sidecar written by "
                                 "'granavg average'") from None
        if isinstance(data, dict) and "spec" in data:
            data = data["spec"]
        return cls.from_dict(data, str(path))


def _runs_or_frames(source) -> tuple:
    """(run directories, frames in this process) of a source."""
    from granavg.io.trajectory import Trajectory

    if source is None:
        return [], None
    if isinstance(source, Trajectory):
        return [], source
    if isinstance(source, (str, os.PathLike)):
        return ([source], None) if Path(source).is_dir() else ([], None)
    if isinstance(source, (list, tuple)):
        if source and not isinstance(source[0], (str, os.PathLike)):
            return [], source
        return list(source), None
    return [], source


def _path(p):
    return None if p is None else str(p)


def _frames_said(frames) -> str:
    from granavg.io.trajectory import Trajectory

    if isinstance(frames, str):
        return frames
    return "a selection of granavg.open's frames" if isinstance(frames, Trajectory) \
        else "frames in memory"


def _plain(data):
    """JSON's own values (lists for tuples, numbers for numpy's)."""
    return json.loads(json.dumps(data, default=lambda x: x.tolist() if hasattr(x, "tolist")
                                 else str(x)))


def _tuples(options: dict) -> dict:
    """JSON's lists back as tuples (the values options parse to)."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in options.items()}
