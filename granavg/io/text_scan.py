"""One file of a LAMMPS text dump walked frame by frame: :class:`TextScanner` keeps a
byte buffer refilled in chunks (plain, gzip, a memory map, or a piece of a plain file
read on its own thread) and a running line count, finds each frame by its ``ITEM:``
headers and parses the rows asked for (:mod:`granavg.io.parse`) into a
:class:`DumpFrame`. :class:`~granavg.io.reader.DumpReader` drives it."""

from __future__ import annotations

import logging
import mmap
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from isal import igzip, isal_zlib

from granavg.errors import UserError
from granavg.io.dumpfile import gzip_chunks
from granavg.io.parse import MALFORMED, NOT_FINITE, OK, count_newlines, joined, \
    parse_block, skip_rows
from granavg.io.prefetch import ReadAhead

log = logging.getLogger(__name__)

CHUNK = 8 << 20
SKIPPED = object()     # a frame outside the requested steps


@dataclass
class DumpFrame:
    """One frame of a dump (SI units for a ``units si`` run).

    Attributes
    ----------
    timestep : int
    time : float or None
        Simulated time (s) from ``ITEM: TIME``, if present.
    columns : list of str
        Names of the columns in ``data`` (the requested ones, in the requested order).
    data : ndarray, shape (n_rows, len(columns))
    box : ndarray, shape (3, 2)
    line : int or None
        1-based line number of the frame's first row in its file (None where its rows
        are no lines of one file: a binary file, the processors' files of one frame).
    boundary : tuple of str
        The box's boundary flags per axis (``pp`` periodic, ``ff``, ``fs``, ...), as
        ``ITEM: BOX BOUNDS`` gives them; ``("", "", "")`` if it gives none.
    triclinic : bool
        The box is tilted (``ITEM: BOX BOUNDS xy xz yz ...``): ``box`` holds the bounds
        of its bounding box, ``tilt`` the tilt factors.
    tilt : tuple of float
        ``(xy, xz, yz)``; zeros for an orthogonal box.
    path : Path or None
        The file the frame is in (one file of a series).
    """

    timestep: int
    time: float | None
    columns: list
    data: np.ndarray
    box: np.ndarray = field(repr=False)
    line: int | None = 0
    boundary: tuple = ("", "", "")
    triclinic: bool = False
    tilt: tuple = (0.0, 0.0, 0.0)
    path: Path | None = None
    #: what the reader's ``prepare`` made of the frame (None: not done)
    prepared: object = field(default=None, repr=False)

    def column(self, name: str) -> np.ndarray:
        """The column called ``name``, shape (n_rows,)."""
        return self.data[:, self.columns.index(name)]

    def as_dict(self) -> dict:
        """Columns by name (views into ``data``)."""
        return {name: self.data[:, k] for k, name in enumerate(self.columns)}


class TextScanner:
    """Walks one file: a byte buffer refilled in chunks, a running line count."""

    def __init__(self, reader: DumpReader, path, span=None):
        self.reader = reader
        self.path = path
        #: (first byte, end byte, line of the first byte) of a plain file's piece
        self.span = span
        self.buf = b""
        self.pos = 0
        self.line = 1
        self.eof = False
        self._layout = None
        self.delivered = 0              # decompressed bytes read so far
        self.previous = None            # (timestep, line) of the last frame header
        self.complete = None            # timestep of the last complete frame
        self.seen = 0

    def frames(self, must_hold=True):
        if self.path.is_dir():
            raise UserError(f"{self.path}: is a directory; give the dump file")
        self.gzip = self.path.suffix == ".gz"
        opener = igzip.open if self.gzip else open  # ISA-L: 3x zlib
        with opener(self.path, "rb") as self.fh:
            if self.span is not None:
                # a piece of a plain file, read on one of several threads: its own
                # range mapped on its own
                first, end, self.line = self.span
                at = first // mmap.ALLOCATIONGRANULARITY * mmap.ALLOCATIONGRANULARITY
                self.buf = mmap.mmap(self.fh.fileno(), end - at, offset=at,
                                     access=mmap.ACCESS_READ)
                self.pos, self.delivered, self.eof = first - at, len(self.buf), True
            elif not self.gzip and self.path.stat().st_size > 0:
                # a plain file is mapped, not read: the parser reads the page cache
                # directly, with no copy into a buffer of its own
                self.buf = mmap.mmap(self.fh.fileno(), 0, access=mmap.ACCESS_READ)
                self.delivered, self.eof = len(self.buf), True
            elif self.gzip:
                # the next chunks are decompressed while this one is parsed
                self.fh = ReadAhead(self.fh, CHUNK)
            try:
                yield from self._frames()
            finally:
                if isinstance(self.fh, ReadAhead):
                    self.fh.close()
                if isinstance(self.buf, mmap.mmap):
                    try:
                        self.buf.close()
                    except BufferError:   # a view in an error's traceback: closed with it
                        pass
        # a window open to the end (frames skipped up to a step) still needs a frame
        if self.seen == 0 and must_hold and (self.reader.steps is None or
                                             self.reader.steps[1] == sys.maxsize):
            raise UserError(f"{self.path}: holds no complete frame (the file is empty or "
                            "damaged); give a dump written by LAMMPS' dump command")

    def _frames(self):
        released = 0
        while self._skip_blank():
            frame = self._frame()
            if frame is None:
                break
            if isinstance(self.buf, mmap.mmap):
                # the mapped pages behind us are not needed again: let them go, so that
                # memory stays flat however long the file (a piece's own mapping: no
                # other reader waits on it)
                done = self.pos // mmap.PAGESIZE * mmap.PAGESIZE
                if done > released:
                    self.buf.madvise(mmap.MADV_DONTNEED, released, done - released)
                    released = done
            self.seen += 1
            if frame is not SKIPPED:
                self.complete = frame.timestep
                yield frame
            elif self.reader.steps and self.last_step > self.reader.steps[1]:
                return

    # -- buffer -------------------------------------------------------------------------
    def _fill(self) -> bool:
        """Read another chunk; False at end of file. A damaged gzip stream is an error
        before any data; after some, what can be decompressed up to the damage is kept
        (read again in small pieces) and the damage reported."""
        if self.eof:
            return False
        try:
            # at least as much as is buffered: a frame larger than a chunk is read in
            # doubling pieces, so its bytes are copied O(1) times, not once per chunk
            more = self.fh.read(max(CHUNK, len(self.buf) - self.pos))
        except (EOFError, OSError, zlib.error, isal_zlib.error) as exc:
            if self.delivered == 0 and not self.gzip_salvage_possible():
                raise UserError(f"{self.path}: not a readable gzip file ({exc}); give an "
                                "intact .gz dump, or a plain one without the .gz name") from None
            more = self._salvage(exc)
            self.eof = True
        if not more:
            self.eof = True
            return False
        self.delivered += len(more)
        # the unread rest and the chunk copied with the GIL released (the engine runs on)
        self.buf = more if self.pos >= len(self.buf) else joined(self.buf, self.pos, more)
        self.pos = 0
        return True

    def gzip_salvage_possible(self) -> bool:
        """Whether the damaged stream yields any data when read in small pieces."""
        return bool(self._pieces(limit=1))

    def _pieces(self, limit=None) -> bytes:
        """Decompressed bytes after ``delivered``, up to the damage (at most ``limit``
        bytes if given); see :func:`granavg.io.dumpfile.gzip_chunks`."""
        out, total, skip = [], 0, self.delivered
        for data in gzip_chunks(self.path):
            if skip:
                cut = min(skip, len(data))
                data, skip = data[cut:], skip - cut
            out.append(data)
            total += len(data)
            if limit is not None and total >= limit:
                break
        return b"".join(out)

    def _salvage(self, exc) -> bytes:
        more = self._pieces()
        log.warning("%s: the gzip stream is damaged after %d bytes of data (%s); the "
                    "complete frames before the damage are used", self.path,
                    self.delivered + len(more), exc)
        self.damaged = True
        return more

    def _skip_blank(self) -> bool:
        while True:
            while self.pos < len(self.buf) and self.buf[self.pos] in b" \t\r\n":
                self.line += self.buf[self.pos] == 10
                self.pos += 1
            if self.pos < len(self.buf):
                return True
            if not self._fill():
                return False

    def _readline(self):
        """Next line as str, or None at the end of the file."""
        while (nl := self.buf.find(b"\n", self.pos)) < 0:
            if not self._fill():
                return None
        text = self.buf[self.pos:nl].decode("ascii", "replace")
        self.pos = nl + 1
        self.line += 1
        return text

    # -- one frame ----------------------------------------------------------------------
    def _frame(self):
        head = {"time": None, "box": np.zeros((3, 2)), "boundary": ("", "", ""),
                "triclinic": False, "tilt": (0.0, 0.0, 0.0)}
        start_line = self.line
        while True:
            text = self._readline()
            if text is None:
                self._truncated(head.get("timestep"), start_line)
                return None
            if not text.startswith("ITEM:"):
                raise UserError(f"{self.path}:{self.line - 1}: expected an 'ITEM:' header, "
                                f"found {text[:40]!r}; the file is damaged")
            item = text[5:].strip()
            if item.startswith(("ATOMS", "ENTRIES")):
                names = item.split()[1:]
                break
            value = self._readline()
            if value is None:
                self._truncated(head.get("timestep"), start_line)
                return None
            try:
                if item.startswith("TIMESTEP"):
                    head["timestep"] = int(value)
                elif item.startswith("TIME"):
                    head["time"] = float(value)
                elif item.startswith("NUMBER OF"):
                    head["n"] = int(value)
                    if head["n"] < 0:
                        raise ValueError
                elif item.startswith("BOX BOUNDS"):
                    lines = [value, self._readline(), self._readline()]
                    if None in lines:
                        self._truncated(head.get("timestep"), start_line)
                        return None
                    head["box"] = np.array([ln.split()[:2] for ln in lines], dtype=float)
                    flags = item.split()[2:]
                    head["triclinic"] = flags[:3] == ["xy", "xz", "yz"]
                    if head["triclinic"]:
                        head["tilt"] = tuple(float(ln.split()[2]) for ln in lines)
                    flags = flags[3:] if head["triclinic"] else flags
                    if len(flags) == 3:
                        head["boundary"] = tuple(flags)
            except (ValueError, IndexError):
                raise UserError(f"{self.path}:{self.line - 1}: cannot read the {item!r} "
                                f"header value {value!r}; the file is damaged") from None
        if "timestep" not in head or "n" not in head:
            raise UserError(f"{self.path}:{start_line}: frame without TIMESTEP or NUMBER OF "
                            "header; the file is damaged")
        if self.previous is not None and head["timestep"] <= self.previous[0]:
            raise UserError(
                f"{self.path}:{start_line}: timestep {head['timestep']} does not follow "
                f"timestep {self.previous[0]} (line {self.previous[1]}); time steps must "
                "increase - a frame was written twice, or a resumed run appended frames "
                "without its dumps being cut back; remove the repeated frames")
        self.previous = (head["timestep"], start_line)
        return self._rows(head, names)

    def _rows(self, head, names):
        n, step = head["n"], head["timestep"]
        if self.reader._first_only:
            return self._made(head, [], np.empty((n, 0)), self.line)
        want, target = self._targets(names)
        self.last_step = step
        window = self.reader.steps
        skip = window is not None and not (
            window[0] <= step <= window[1]
            and (len(window) < 3 or (step - window[0]) % window[2] == 0)) or (
            self.reader.from_time is not None and head["time"] is not None
            and head["time"] < self.reader.from_time)
        if not skip and not self.reader.headers_only and n:
            data = self._rows_to_header(n, len(names), target)
            if data is not None:
                first = self.line
                self.line += n
                return self._made(head, want, data, first)
        elif (skip or self.reader.headers_only) and self._past_rows(n):
            first = self.line - n
            return SKIPPED if skip else self._made(head, [], np.empty((n, 0)), first)
        end = self._block_end()
        if end < len(self.buf) and not skip and not self.reader.headers_only and \
                (n == 0 or self.buf[end - 1] == 10):
            # a complete block (another header follows): parse it, and count its rows
            # only if it does not hold exactly n (the kernel stops at the first non-number)
            arr = np.frombuffer(self.buf, dtype=np.uint8)
            data, status, row, col = parse_block(arr, self.pos, n, len(names), target, end)
            if status == OK and col == end:
                self.pos, first = end, self.line
                self.line += n
                return self._made(head, want, data, first)
        rows = self._lines(self.pos, end)
        if skip and rows >= n:
            self.pos, self.line = end, self.line + rows
            return SKIPPED
        if self.reader.headers_only and rows == n and (n == 0 or self.buf[end - 1] == 10):
            first = self.line
            self.pos, self.line = end, self.line + rows
            return self._made(head, [], np.empty((n, 0)), first)
        if rows < n or (n and self.buf[end - 1] != 10):
            if end >= len(self.buf) and self.eof:
                self._truncated(step, self.line)
                return None
            raise UserError(f"{self.path}:{self.line + rows}: frame at timestep {step} has "
                            f"{rows} rows, its header says {n}; the file is damaged")
        arr = np.frombuffer(self.buf, dtype=np.uint8)
        data, status, row, col = parse_block(arr, self.pos, n, len(names), target)
        if status != OK:
            self._bad_value(status, step, row, col, names)
        if rows > n and self.buf[col:end].strip():
            raise UserError(f"{self.path}:{self.line + n}: frame at timestep {step} has more "
                            f"rows than its header's {n}; the file is damaged")
        self.pos = end
        first = self.line
        self.line += rows
        return self._made(head, want, data, first)

    def _rows_to_header(self, n, ncol, target):
        """The block's n rows parsed in one pass, without searching for its end first:
        taken when they end exactly where the next header starts (or at the end of the
        file), else None (and nothing consumed): the careful path then finds the
        block's end, counts its rows and says what is wrong."""
        limit = self.buf.rfind(b"\n") + 1              # the rows the buffer holds whole
        if limit <= self.pos:
            return None
        arr = np.frombuffer(self.buf, dtype=np.uint8)
        data, status, _, end = parse_block(arr, self.pos, n, ncol, target, limit)
        if status != OK:
            return None
        if end >= len(self.buf):
            if not (isinstance(self.buf, mmap.mmap) or self.eof):
                return None                     # more rows may follow in the next chunk
        elif self.buf[end:end + 5] != b"ITEM:":
            return None
        self.pos = end
        return data

    def _past_rows(self, n) -> bool:
        """Pass over the block's n rows in one walk, nothing parsed, when they end exactly
        where the next header starts (or at the end of the file); else False (nothing
        consumed: the careful path finds the block's end and counts its rows)."""
        limit = len(self.buf)
        end = skip_rows(np.frombuffer(self.buf, dtype=np.uint8), self.pos, n, limit)
        if end < 0:
            return False
        if end >= limit:
            if not (isinstance(self.buf, mmap.mmap) or self.eof):
                return False                    # more rows may follow in the next chunk
        elif self.buf[end:end + 5] != b"ITEM:":
            return False
        self.pos, self.line = end, self.line + n
        return True

    def _made(self, head, columns, data, line):
        return DumpFrame(head["timestep"], head["time"], columns, data, head["box"], line,
                         head["boundary"], head["triclinic"], head["tilt"], self.path)

    def _lines(self, start, end) -> int:
        """Newlines in buf[start:end] (a mapped file has no count of its own)."""
        if isinstance(self.buf, mmap.mmap):
            return count_newlines(np.frombuffer(self.buf, dtype=np.uint8), start, end)
        return self.buf.count(b"\n", start, end)

    def _block_end(self) -> int:
        """Offset of the next ``ITEM:`` header (or of the end of the file); each byte is
        searched once, however many chunks the block spans."""
        start = self.pos
        while (end := self.buf.find(b"ITEM:", start)) < 0:
            searched = len(self.buf) - self.pos - 4          # a header may straddle
            if not self._fill():
                return len(self.buf)
            start = self.pos + max(searched, 0)
        return end

    def _targets(self, names):
        if self._layout is not None and self._layout[0] == names:
            return self._layout[1], self._layout[2]
        want = self.reader.columns if self.reader.columns is not None else names
        missing = [c for c in want if c not in names]
        if missing:
            col = missing[0]
            need = self.reader.needed_by.get(col)
            raise UserError(f"{self.path}: column '{col}' is missing (columns: {' '.join(names)})"
                            + (f"; {need} needs it" if need else "")
                            + "; write it in the dump or do not ask for what needs it")
        target = np.full(len(names), -1, dtype=np.int64)
        for k, c in enumerate(want):
            target[names.index(c)] = k
        self._layout = (names, list(want), target)
        return list(want), target

    def _bad_value(self, status, step, row, col, names):
        line = self.line + row
        if status == NOT_FINITE:
            raise UserError(f"{self.path}:{line}: NaN or inf in column '{names[col]}' "
                            f"(timestep {step}); the run blew up or the file is damaged")
        words = self._row_text(row).split()
        if col >= len(names):
            what = "too many values"
        elif col < len(words):
            what = f"{words[col][:20]!r} is not a number, in column '{names[col]}'"
        else:
            what = f"no value in column '{names[col]}'"
        assert status == MALFORMED
        raise UserError(f"{self.path}:{line}: malformed row ({what}; expected "
                        f"{len(names)} numbers, timestep {step}); the file is damaged")

    def _row_text(self, row) -> str:
        """The text of the frame's ``row``-th row (0-based; the block starts at pos)."""
        start = self.pos
        for _ in range(row):
            start = self.buf.find(b"\n", start) + 1
            if start == 0:
                return ""
        end = self.buf.find(b"\n", start)
        return bytes(self.buf[start:end if end >= 0 else len(self.buf)]).decode("ascii",
                                                                               "replace")

    def _truncated(self, step, line):
        log.warning("%s:%d: last frame (timestep %s) is truncated; skipped; the last complete "
                    "frame used is timestep %s", self.path, line, step, self.complete)
