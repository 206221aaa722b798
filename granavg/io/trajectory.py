"""Frames a user can hold: :func:`open` any supported source as a lazy sequence.

::

    import granavg
    frames = granavg.open("atoms.dump", contacts="contacts.dump", contact_map={...})
    len(frames), frames.times               # one pass over the headers, kept
    frame = frames[100]                     # read now: .atoms, .contacts, .box, .time
    frame.to_pandas("atoms")                # a DataFrame of the atoms' columns
    every_tenth = frames[::10]              # still lazy
    settled = frames.between(0.5, 0.8)      # the frames with 0.5 <= t <= 0.8
    fields = granavg.average(settled, cells={"slabs": "z", "bins": 12})

A :class:`Trajectory` reads nothing but the files' headers (where the format can: LAMMPS
and LIGGGHTS dumps; other formats' frames are read once) until a frame is asked for.
Indexing and slicing select frames; iterating reads the selected frames in one pass.
Every frame it gives has passed the gate (:mod:`granavg.engine.gate`) as an average's
frames do: one frame on its own, frames in a sequence after those before them.
"""

from __future__ import annotations

import builtins
import logging
from collections.abc import Sequence

import numpy as np

from granavg.engine import gate
from granavg.engine.timing.axes import TIME_TOLERANCE
from granavg.errors import ParameterError, UserError, literal
from granavg.io import formats, validate

log = logging.getLogger(__name__)


def open(atoms, contacts=None, *, fmt=None, **options) -> "Trajectory":  # noqa: A001
    """The frames of a dump, a ``dump.*`` series, or another engine's files, as a lazy
    sequence.

    Parameters
    ----------
    atoms : path
        The per-atom file or series (a ``*`` for the step), in any format of
        :func:`granavg.io.formats.available`.
    contacts : path, optional
        The per-contact file or series.
    fmt : str, optional
        The format (default: the one the file looks like).
    **options
        The format's options, as for :func:`granavg.average` (``contact_map``,
        ``atom_map``, ``dt``, ``units``, ``liggghts``, ...).

    Returns
    -------
    Trajectory
    """
    atoms = validate.existing_file("atoms", atoms)
    contacts = validate.existing_file("contacts", contacts)
    return Trajectory(atoms, contacts, fmt, options)


class Trajectory(Sequence):
    """A lazy sequence of frames (:class:`~granavg.io.frames.Frame`) of one source.

    Made by :func:`open`. ``len``, ``t[i]`` (a frame, read then), ``t[a:b:c]`` and
    :meth:`between` (a Trajectory of the frames selected), iteration (the selected
    frames, read in one pass). :func:`granavg.average` takes a Trajectory in place of
    files: it averages the selected frames.

    Attributes
    ----------
    atoms, contacts : Path
    fmt : str
        The format's name.
    options : dict
        The format's options given.
    """

    def __init__(self, atoms, contacts, fmt, options, index=None, chosen=None):
        self.atoms, self.contacts, self.options = atoms, contacts, dict(options)
        self._opened = None
        self.fmt = fmt if fmt is not None else self.source_of_all().format_name
        self._index = index               # shared by every selection: (timesteps, times)
        self._chosen = chosen             # positions in the index; None: every frame

    def source_of_all(self):
        """A fresh frame source of every frame of the files (the format's own)."""
        source = formats.open_frames(self.atoms, self.contacts,
                                     fmt=getattr(self, "fmt", None), **self.options)
        if self._opened is None:
            self._opened = source
        return source

    @property
    def dim(self) -> int:
        return getattr(self._first_source(), "dim", 2)

    @property
    def units(self):
        """The data's units (:class:`~granavg.engine.unit_system.UnitSystem`)."""
        return self._first_source().units

    def _first_source(self):
        return self._opened if self._opened is not None else self.source_of_all()

    def _all(self) -> tuple:
        """(timesteps, times) of every frame of the files, found once."""
        if self._index is None:
            source = self.source_of_all()
            heads = source.headers() if hasattr(source, "headers") else \
                [(f.timestep, f.time) for f in source]
            steps = np.array([s for s, _ in heads], dtype=np.int64)
            times = np.array([t for _, t in heads], dtype=float)
            self._index = (steps, times)
        return self._index

    def _positions(self) -> np.ndarray:
        n = len(self._all()[0])
        return np.arange(n) if self._chosen is None else self._chosen

    @property
    def timesteps(self) -> np.ndarray:
        """The selected frames' time steps, shape (N,)."""
        return self._all()[0][self._positions()]

    @property
    def times(self) -> np.ndarray:
        """The selected frames' times, shape (N,), in the data's time unit."""
        return self._all()[1][self._positions()]

    def __len__(self) -> int:
        return len(self._positions())

    def __getitem__(self, key):
        chosen = self._positions()
        if isinstance(key, slice):
            if key.step is not None and key.step < 0:
                raise ParameterError("frames", f"{literal(self.atoms)}: a slice with a "
                                     "negative step; frames go forward in time (take "
                                     "frames[::k], or index one frame)")
            return self._select(chosen[key])
        if isinstance(key, (int, np.integer)):
            k = builtins.range(len(chosen))[key] if -len(chosen) <= key < len(chosen) \
                else None
            if k is None:
                raise IndexError(f"frame {key} of {len(chosen)}")
            frame = next(iter(self._select(chosen[k:k + 1])))
            return frame
        raise TypeError(f"frames are indexed by an integer or a slice, not {key!r}")

    def between(self, t0=None, t1=None) -> "Trajectory":
        """The selected frames with t0 <= t <= t1 (each bound within
        :data:`~granavg.engine.timing.axes.TIME_TOLERANCE` of the frames' spacing, as
        :func:`granavg.average`'s ``t_min`` and ``t_max``; None: no bound)."""
        times = self.times
        spacing = np.min(np.diff(self._all()[1])) if len(self._all()[1]) > 1 else 0.0
        slack = TIME_TOLERANCE * spacing
        keep = np.ones(len(times), bool)
        if t0 is not None:
            keep &= times >= t0 - slack
        if t1 is not None:
            keep &= times <= t1 + slack
        return self._select(self._positions()[keep])

    def _select(self, positions) -> "Trajectory":
        picked = Trajectory.__new__(Trajectory)
        picked.__dict__.update(self.__dict__)
        picked._chosen = np.asarray(positions, dtype=np.int64)
        return picked

    def __iter__(self):
        return iter(self.source())

    def source(self, checked: bool = True) -> "Selected":
        """A frame source of the selected frames (:func:`granavg.average` reads it with
        ``checked`` False: its own gate checks them)."""
        return Selected(self, checked)

    def __repr__(self) -> str:
        n = len(self) if self._index is not None else "?"
        return f"<Trajectory {self.fmt} {self.atoms} ({n} frames)>"


class Selected:
    """The frame source of a Trajectory's selected frames: the format's own source with
    the frames not selected left out (the format scans past those before the first
    where it can), each frame through the gate. Its other attributes (``units``,
    ``box()``, ``describe()``, ``dropped``: the rows left out of the frames read) are
    the format's source's."""

    def __init__(self, trajectory: Trajectory, checked: bool = True):
        self.checked = checked
        steps = trajectory.timesteps
        self.wanted = set(steps.tolist())
        options = dict(trajectory.options)
        if len(steps) and "steps" in formats.choose(trajectory.atoms, trajectory.fmt).accepts:
            options["steps"] = (int(steps.min()), int(steps.max()))
        self.inner = formats.open_frames(trajectory.atoms, trajectory.contacts,
                                         fmt=trajectory.fmt, **options)
        self.where, self.contacts_path = trajectory.atoms, trajectory.contacts
        self.selected = "all" if trajectory._chosen is None or not len(steps) else {
            "frames": len(steps), "first_timestep": int(steps[0]),
            "last_timestep": int(steps[-1])}

    def __getattr__(self, name):
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    @property
    def files(self) -> dict:
        """The files the frames are of, and which were selected (for the sidecar)."""
        return {"atoms": str(self.where), "contacts": None if self.contacts_path is None
                else str(self.contacts_path), "selected": self.selected}

    def __iter__(self):
        check = gate.Gate(getattr(self.inner, "dim", 2))
        left = set(self.wanted)
        for frame in self.inner:
            if frame.timestep in left:
                if self.checked:
                    check.admit(frame)
                left.discard(frame.timestep)
                yield frame
                if not left:
                    return
        if left:
            raise UserError(f"{self.where}: the frame of time step {min(left)} is no longer "
                            "there (the files changed since they were opened); open them "
                            "again")
