"""LAMMPS' ``dump yaml``: one YAML document per frame, read as
:class:`~granavg.io.reader.DumpReader` reads text dumps - the same frames, the same
columns by name, the same windows of steps and times.

LAMMPS writes each document in a fixed shape (its dump_yaml.cpp): ``---``, then
``timestep:``, ``units:``, ``time:`` (with ``dump_modify time yes``), ``natoms:``,
``boundary: [ p, p, p, p, f, f, ]``, optionally ``thermo:``, ``box:`` (three ``- [ lo,
hi ]`` lines, a fourth with the tilt factors for a tilted box), ``keywords: [ ... ]``,
``data:`` with one ``- [ v , v , ... ]`` line per atom, and ``...``. That shape is read
line by line, without a YAML library.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np

from granavg.errors import UserError
from granavg.io.selection import skipped, wanted

log = logging.getLogger(__name__)


def is_yaml(path) -> bool:
    """Whether ``path`` starts as a LAMMPS ``dump yaml``."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(64)
    except OSError:
        return False
    return head.startswith(b"---") and b"creator: LAMMPS" in head


def _items(text) -> list:
    """``[ a, b, ]`` -> ['a', 'b']."""
    inner = text.strip()
    if not (inner.startswith("[") and inner.endswith("]")):
        raise ValueError(text)
    return [w.strip() for w in inner[1:-1].split(",") if w.strip()]


def _documents(path):
    """(first line number, header dict, data lines) of each document; a document cut
    by the end of the file is yielded with ``complete`` False. A document without its
    ``...`` or ``---`` is a one-line refusal (its frame would be lost or merged)."""
    with open(path, encoding="ascii", errors="replace") as fh:
        head, rows, start, in_data = None, [], 0, False
        for k, line in enumerate(fh, 1):
            if line.startswith("---"):
                if head is not None:
                    raise UserError(f"{path}:{k}: a document starts ('---') while the one "
                                    f"from line {start} has no end ('...'); the file is "
                                    "damaged: mend or remove that frame")
                head, rows, start, in_data = {"box": []}, [], k, False
                continue
            if head is None:
                if line.strip():
                    raise UserError(f"{path}:{k}: a line outside every document (its "
                                    "'---' is missing); the file is damaged: mend or "
                                    "remove that frame")
                continue
            if line.startswith("..."):
                yield start, head, rows, True
                head = None
                continue
            if in_data:
                rows.append(line)
                continue
            if line.startswith("  - [") and "keywords" not in head:
                head["box"].append(line[3:])
                continue
            key, _, value = line.partition(":")
            if key == "data":
                in_data = True
                head["data"] = k + 1            # the line of its first row
            elif not line.startswith(" ") and key.strip() != "box":
                head[key.strip()] = value.strip()
        if head is not None:
            yield start, head, rows, False


class YamlScanner:
    """Walks one ``dump yaml`` for a :class:`~granavg.io.reader.DumpReader` (its
    columns, ``steps`` window, ``from_time``, ``headers_only``), yielding
    ``frame_type`` objects (its :class:`~granavg.io.reader.DumpFrame`)."""

    def __init__(self, reader, path, frame_type):
        self.reader, self.path, self.frame_type = reader, Path(path), frame_type
        self.seen = 0

    def frames(self, must_hold=True):
        reader, previous = self.reader, None
        for line, head, rows, complete in _documents(self.path):
            if not complete:
                log.warning("%s:%d: the last frame is cut; skipped", self.path, line)
                break
            frame = self._frame(line, head, rows)
            if previous is not None and frame.timestep <= previous:
                raise UserError(f"{self.path}:{line}: timestep {frame.timestep} does not "
                                f"follow timestep {previous}; time steps must increase "
                                "(remove the repeated frames)")
            previous = frame.timestep
            self.seen += 1
            if skipped(reader, frame.timestep, frame.time):
                if reader.steps and frame.timestep > reader.steps[1]:
                    return
                continue
            yield self._columns(frame, line, head, rows)
            if reader._first_only:
                return
        if self.seen == 0 and must_hold and (reader.steps is None or
                                             reader.steps[1] == sys.maxsize):
            raise UserError(f"{self.path}: holds no complete frame (the file is empty or "
                            "damaged); give a dump written by LAMMPS' dump command")

    def _frame(self, line, head, rows):
        """The frame's header as a frame without rows (its ``names`` kept aside)."""
        try:
            step = int(head["timestep"])
            n = int(head["natoms"])
            names = _items(head["keywords"])
            flags = _items(head["boundary"])
            box = [[float(v) for v in _items(b)] for b in head["box"]]
            time = float(head["time"]) if "time" in head else None
        except (KeyError, ValueError) as exc:
            raise UserError(f"{self.path}:{line}: a frame whose header LAMMPS did not write "
                            f"({exc}); the file is damaged") from None
        if len(flags) != 6 or not set(flags) <= set("pfsm"):
            raise UserError(f"{self.path}:{line}: frame at timestep {step} has boundary "
                            f"{head['boundary']}, not six flags p, f, s or m; the file is "
                            "damaged")
        if len(box) not in (3, 4) or any(len(b) != 2 for b in box[:3]) or \
                (len(box) == 4 and len(box[3]) != 3):
            raise UserError(f"{self.path}:{line}: frame at timestep {step} has a box of "
                            f"{len(box)} lines, not three (lo, hi) lines and, for a tilted "
                            "box, one of the tilt factors; the file is damaged")
        if "data" not in head:
            raise UserError(f"{self.path}:{line}: frame at timestep {step} has no 'data:' "
                            "line before its rows; the file is damaged")
        if len(rows) != n:
            raise UserError(f"{self.path}:{line}: frame at timestep {step} has {len(rows)} "
                            f"rows, its header says {n}; the file is damaged")
        tilt = tuple(box[3]) if len(box) > 3 else (0.0, 0.0, 0.0)
        self._names = names
        return self.frame_type(step, time, names, np.empty((n, 0)),
                               np.array(box[:3], float), head["data"],
                               tuple(flags[2 * k] + flags[2 * k + 1] for k in range(3)),
                               len(box) > 3, tilt, self.path)

    def _columns(self, frame, line, head, rows):
        """The frame with the requested columns (all if none were) parsed."""
        names = self._names
        if self.reader.headers_only or self.reader._first_only:
            frame.columns = []
            return frame
        want = wanted(self.reader, self.path, names)
        text = " ".join(r.strip()[1:].strip().strip("[]") for r in rows).replace(",", " ")
        try:
            values = np.array(text.split(), float).reshape(len(rows), len(names))
        except ValueError:
            raise UserError(f"{self.path}:{line}: frame at timestep {frame.timestep} has a "
                            "row that is not numbers, one per keyword; the file is "
                            "damaged") from None
        frame.columns = want
        frame.data = np.ascontiguousarray(values[:, [names.index(c) for c in want]])
        return frame


def header(path) -> tuple:
    """The column names of a ``dump yaml``'s first frame and its units as ``(style,
    "file:line")`` (None if it does not say)."""
    for line, head, _, _ in _documents(path):
        try:
            names = _items(head["keywords"])
        except (KeyError, ValueError):
            break
        units = head.get("units")
        return names, ((units, f"{path}:{line + 3}") if units else None)
    raise UserError(f"{path}: no frame with keywords; give a LAMMPS dump yaml")
