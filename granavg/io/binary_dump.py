"""LAMMPS' binary dumps: ``dump custom`` to a file LAMMPS writes in binary (a name ending
in ``.bin``), read as :class:`~granavg.io.reader.DumpReader` reads text dumps - the same
frames, the same columns by name, the same windows of steps and times.

The layout is LAMMPS' own (tools/binary2txt.cpp; the default build, 64-bit time steps
and atom counts): each frame opens with a format header - minus the length of a magic
string (``DUMPCUSTOM``), the string, an endianness flag and a revision - then the time
step, the number of atoms, the box (its boundary flags, bounds and, for a tilted box,
its tilt factors), the values per atom and, from revision 2, the units, the time (if
``dump_modify time yes``) and the columns' names; then the rows in one chunk per
processor that wrote them. Revision 1 (no column names) and the old layout without the
magic string carry no names: refused in one line.
"""

from __future__ import annotations

import logging
import mmap
import struct
import sys
from pathlib import Path

import numpy as np

from granavg.errors import UserError
from granavg.io.selection import skipped, wanted

#: The magic strings LAMMPS writes before each binary frame.
MAGICS = (b"DUMPCUSTOM", b"DUMPATOM")
#: LAMMPS' boundary codes.
_BOUNDARY = "pfsm"
log = logging.getLogger(__name__)


def is_binary(path) -> bool:
    """Whether ``path`` starts as a LAMMPS binary dump with a format header."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8 + max(len(m) for m in MAGICS))
    except OSError:
        return False
    if len(head) < 8:
        return False
    n = -struct.unpack_from("<q", head)[0]
    return 0 < n <= 32 and head[8:8 + n] in MAGICS


class _Cursor:
    """A position in a mapped file, with little readers of LAMMPS' binary types."""

    def __init__(self, buf, path):
        self.buf, self.pos, self.path = buf, 0, path

    def take(self, fmt):
        size = struct.calcsize(fmt)
        if self.pos + size > len(self.buf):
            raise EOFError
        out = struct.unpack_from(fmt, self.buf, self.pos)
        self.pos += size
        return out

    def text(self, n) -> str:
        if self.pos + n > len(self.buf):
            raise EOFError
        out = bytes(self.buf[self.pos:self.pos + n]).decode("ascii", "replace")
        self.pos += n
        return out


def _header(cur: _Cursor) -> dict:
    """One frame's header (the cursor at its start); EOFError where the file ends."""
    (step,) = cur.take("<q")
    revision = None
    if step < 0:
        magic = cur.text(-step).encode()
        if magic not in MAGICS:
            raise UserError(f"{cur.path}: byte {cur.pos}: not a LAMMPS dump custom frame "
                            f"(magic {magic!r}); the file is damaged")
        _, revision = cur.take("<ii")
        (step,) = cur.take("<q")
    natoms, triclinic = cur.take("<qi")
    flags = cur.take("<6i")
    bounds = cur.take("<6d")
    tilt = cur.take("<3d") if triclinic else (0.0, 0.0, 0.0)
    (size_one,) = cur.take("<i")
    if revision is None or revision < 2:
        raise UserError(f"{cur.path}: a binary dump without column names (LAMMPS before "
                        "the format revision 2, 2022); convert it with LAMMPS' "
                        "tools/binary2txt and name the columns, or dump it again")
    (n,) = cur.take("<i")
    units = cur.text(n) if n > 0 else None
    (has_time,) = cur.take("<b")
    time = cur.take("<d")[0] if has_time else None
    (n,) = cur.take("<i")
    names = cur.text(n).split()
    if len(names) != size_one:
        raise UserError(f"{cur.path}: frame at timestep {step} names {len(names)} columns "
                        f"for {size_one} values per atom; the file is damaged")
    boundary = tuple(_BOUNDARY[flags[2 * k]] + _BOUNDARY[flags[2 * k + 1]]
                     for k in range(3))
    return {"timestep": int(step), "n": int(natoms), "names": names, "units": units,
            "time": time, "box": np.array(bounds, float).reshape(3, 2),
            "boundary": boundary, "triclinic": bool(triclinic), "tilt": tuple(tilt)}


def header(path) -> tuple:
    """The column names of a binary dump's first frame and its units as ``(style,
    "file")`` (None if it does not say): :func:`granavg.io.dump_columns.dump_header`."""
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        try:
            head = _header(_Cursor(buf, path))
        except EOFError:
            raise UserError(f"{path}: a binary dump cut inside its first header; the file is "
                            "damaged") from None
    return head["names"], ((head["units"], str(path)) if head["units"] else None)


class BinaryScanner:
    """Walks one binary dump for a :class:`~granavg.io.reader.DumpReader` (its columns,
    ``steps`` window, ``from_time``, ``headers_only``), yielding ``frame_type`` objects
    (its :class:`~granavg.io.reader.DumpFrame`)."""

    def __init__(self, reader, path, frame_type):
        self.reader, self.path, self.frame_type = reader, Path(path), frame_type
        self.seen = 0

    def frames(self, must_hold=True):
        reader, DumpFrame = self.reader, self.frame_type
        with open(self.path, "rb") as fh:
            if self.path.stat().st_size == 0:
                buf = b""
            else:
                buf = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
            cur, previous = _Cursor(buf, self.path), None
            try:
                while cur.pos < len(buf):
                    start = cur.pos
                    try:
                        head = _header(cur)
                        rows = self._rows(cur, head)
                    except EOFError:
                        log.warning("%s: byte %d: the last frame is cut; skipped", self.path,
                                    start)
                        break
                    step = head["timestep"]
                    if previous is not None and step <= previous:
                        raise UserError(f"{self.path}: byte {start}: timestep {step} does "
                                        f"not follow timestep {previous}; time steps must "
                                        "increase (remove the repeated frames)")
                    previous = step
                    self.seen += 1
                    if skipped(reader, step, head["time"]):
                        if reader.steps and step > reader.steps[1]:
                            return
                        continue
                    columns, data = self._columns(head, rows)
                    yield DumpFrame(step, head["time"], columns, data, head["box"], None,
                                    head["boundary"], head["triclinic"], head["tilt"],
                                    self.path)
                    if reader._first_only:
                        return
            finally:
                if isinstance(buf, mmap.mmap):
                    try:
                        buf.close()
                    except BufferError:
                        pass
        if self.seen == 0 and must_hold and (reader.steps is None or
                                             reader.steps[1] == sys.maxsize):
            raise UserError(f"{self.path}: holds no complete frame (the file is empty or "
                            "damaged); give a dump written by LAMMPS' dump command")

    def _rows(self, cur, head):
        """The frame's rows, shape (n, columns), as a view of the file (chunks joined);
        a chunk count or length that does not fit the header's rows is a one-line
        refusal, a file that ends inside them an EOFError (the last frame cut)."""
        (nchunk,) = cur.take("<i")
        width, parts = len(head["names"]), []
        left = head["n"] * width                # the values the chunks must still hold
        for k in range(nchunk):
            at = cur.pos
            if left == 0 and cur.pos + 4 > len(cur.buf):
                n = None                        # a chunk past the rows, at the file's end
            else:
                (n,) = cur.take("<i")
                if cur.pos + 8 * min(max(n, 0), left) > len(cur.buf):
                    raise EOFError
            if n is None or not 0 <= n <= left or (n % max(width, 1)):
                raise UserError(
                    f"{self.path}: byte {at}: chunk {k + 1} of {nchunk} of the frame at "
                    f"timestep {head['timestep']} says {n} values, where {left} of the "
                    f"header's {head['n']} rows x {width} columns are left; the chunk count "
                    "or a chunk length is damaged: dump again, or cut the file before this "
                    "frame")
            parts.append(np.frombuffer(cur.buf, "<f8", n, cur.pos))
            cur.pos += 8 * n
            left -= n
        flat = parts[0] if len(parts) == 1 else np.concatenate(parts) if parts else \
            np.empty(0)
        if flat.size != head["n"] * width:
            raise UserError(f"{self.path}: frame at timestep {head['timestep']} holds "
                            f"{flat.size // max(width, 1)} rows, its header says "
                            f"{head['n']}; the file is damaged (its chunk count too low)")
        return flat.reshape(head["n"], width)

    def _columns(self, head, rows):
        """The requested columns (all if none were), copied out of the file."""
        names = head["names"]
        if self.reader.headers_only or self.reader._first_only:
            return [], np.empty((head["n"], 0))
        want = wanted(self.reader, self.path, names)
        return want, np.ascontiguousarray(rows[:, [names.index(c) for c in want]])
