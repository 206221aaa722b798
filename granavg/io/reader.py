"""Streaming readers of LAMMPS text dumps (per-atom ``dump custom``, per-contact ``dump local``).

Frames are found by their ``ITEM:`` headers, never by a fixed line count (contact dumps
change their row count every frame). The file is read in chunks of bytes, so memory
stays flat whatever the number of frames; each frame's rows are parsed as one block by
:mod:`granavg.io.parse`, converting only the columns asked for.

A path with a ``*`` is a series of files, one or more frames each, as ``dump custom N
dump.*.txt`` writes them: they are read in the order of the number that stands for the
``*`` (LAMMPS' time step), as one dump.

Bad input: a truncated last frame is skipped with a warning naming it; a malformed row,
a non-finite value, or a missing column is a :class:`~granavg.errors.UserError` naming
the file and line (and, for a missing column, what needs it).
"""

from __future__ import annotations

import itertools

import logging
import mmap
import re
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from isal import igzip, isal_zlib

from granavg.engine import threads
from granavg.errors import UserError
from granavg.io.dumpfile import gzip_chunks
from granavg.io.parse import MALFORMED, NOT_FINITE, OK, count_newlines, joined, \
    parse_block, skip_rows
from granavg.io.prefetch import ReadAhead, in_order

log = logging.getLogger(__name__)

CHUNK = 8 << 20
_SKIPPED = object()     # a frame outside the requested steps


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


class DumpReader:
    """Lazy reader of one LAMMPS dump, text (plain or gzip), binary
    (:mod:`granavg.io.binary_dump`) or ``dump yaml`` (:mod:`granavg.io.yaml_dump`);
    iterate to get frames.

    Parameters
    ----------
    path : path-like
    columns : sequence of str, optional
        Columns to convert (others are skipped while parsing); all if None.
    needed_by : dict, optional
        For each column, what needs it: named in the error if it is missing.
    steps : (int, int) or (int, int, int), optional
        Only frames with first <= timestep <= last (and, with a third number ``every``,
        timestep - first a multiple of it) are parsed and yielded; the others are skipped
        by scanning for their end (how a dask worker reads its chunk, or a study thins
        the frames).
    headers_only : bool, optional
        List the frames without parsing their rows: each frame's header (timestep,
        time, box) and an empty ``data`` of shape (n_rows, 0); the rows are only counted
        (a newline scan), so a frame cut or short of rows is found as in a full read.
        What a dask client needs to cut a dump into chunks.
    named_steps : bool, optional
        With ``steps``, on a ``dump.*`` series: open only the files whose frames can lie
        in the window, the number in each file's name being its first time step (as
        LAMMPS names them; a dask client checks it against each file's first header,
        :meth:`first_header`), so that a worker reads its own files alone.
    readers : int, optional
        Reader threads (the files of a series, or the pieces of one plain file, parsed at
        once); default granavg's thread count (:func:`granavg.engine.threads.count`). One
        where only the first frames are wanted: a frame read ahead on another thread
        would be parsed for nothing, and closing the reader waits for it.
    prepare : callable, optional
        ``prepare(frame)``, run on the thread that parsed the frame (so on every reader
        thread at once), its result kept as ``frame.prepared``: a format's per-frame
        work (units, wrapping, checks) off the consumer's thread. A ``UserError`` it
        raises leaves ``prepared`` None, for the consumer to do it again where the
        frame's file:line is final (a piece of a file counts its lines from its own
        start) and raise it there.
    """

    def __init__(self, path, columns=None, needed_by=None, steps=None, headers_only=False,
                 named_steps=False, readers=None, prepare=None):
        self.path = Path(path)
        self.numbered = numbered_series(self.path)
        self.files = [p for _, p in self.numbered]
        self.columns = list(columns) if columns is not None else None
        self.needed_by = dict(needed_by or {})
        self.steps = steps
        self.headers_only = headers_only
        self.named_steps = named_steps
        self.readers = readers
        self.prepare = prepare
        #: frames whose ``ITEM: TIME`` is below this are scanned past, their rows not parsed
        self.from_time = None
        self._first_only = False

    def first_header(self, path=None):
        """The first frame of ``path`` (default the first file) with its header alone and
        an empty ``data`` of shape (n_rows, 0): its rows neither parsed nor counted (what
        a dask client needs of each file of a ``dump.*`` series); None if it holds none."""
        reader = DumpReader.__new__(DumpReader)
        reader.__dict__.update(self.__dict__, _first_only=True, steps=None, from_time=None)
        path = Path(path) if path is not None else self.files[0]
        scanner = _scanner(reader, first_file(path) if "%" in path.name else path)
        return next(iter(scanner.frames(must_hold=False)), None)

    def _own_files(self) -> list:
        """The files to open: all; or, with ``named_steps`` and a ``steps`` window, only
        those whose frames can lie in it, the number in each name being its first time
        step (as LAMMPS writes ``dump.*``; the caller has checked it)."""
        if not (self.named_steps and self.steps is not None):
            return self.files
        lo, hi = self.steps[0], self.steps[1]
        numbers = [n for n, _ in self.numbered]
        return [p for k, (n, p) in enumerate(self.numbered)
                if n <= hi and (k + 1 == len(numbers) or numbers[k + 1] > lo)]

    def __iter__(self):
        if len(self.files) == 1 and "%" in self.files[0].name:
            yield from self._processor_frames(self.files[0])
            return
        if len(self.files) == 1:
            pieces = self._pieces(self.files[0])
            if not pieces[0]:
                yield from self._ready(_scanner(self, self.files[0]).frames())
                return
            yield from self._piece_frames(self.files[0], *pieces)
            return
        last = None
        files = self._own_files()
        width = min(self._width(), len(files)) if not self._first_only else 1
        for path, frames in in_order(((p, self._ready(_scanner(self, p).frames(
                must_hold=False))) for p in files), width):
            any_frame = False
            for frame in frames:
                any_frame = True
                if last is not None and frame.timestep <= last[0]:
                    raise UserError(
                        f"{path}:{frame.line}: timestep {frame.timestep} does not follow "
                        f"timestep {last[0]} of {last[1]}; the files of a series must hold "
                        "increasing time steps (remove the repeated or stray file)")
                last = (frame.timestep, path)
                yield frame
            if not any_frame:
                log.warning("%s: holds no complete frame (empty or cut); skipped, the other "
                            "files of %s are used", path, self.path)


    def _ready(self, frames):
        """``frames`` with the ``prepare`` given run on each (on the thread iterating them)."""
        if self.prepare is None:
            yield from frames
            return
        for frame in frames:
            try:
                frame.prepared = self.prepare(frame)
            except UserError:
                frame.prepared = None             # raised by the consumer, lines final
            yield frame

    def _width(self) -> int:
        """The reader threads: ``readers``, else granavg's thread count."""
        return self.readers or threads.count()

    def _piece_frames(self, path, pieces, depth):
        """The frames of a plain file read in ``pieces`` (:meth:`_pieces`), each on a
        thread of its own, handed on in order. A piece counts its lines from its own
        start; its frames' lines (and a damage's file:line) are set absolute here, the
        lines of the pieces before it being known by then."""
        scanners = [_Scanner(self, path, span) for span in pieces]
        last, offset = None, 0
        for k, (scanner, frames) in enumerate(in_order(
                ((s, self._ready(s.frames(must_hold=False))) for s in scanners),
                len(scanners), depth)):
            if k:
                offset += scanners[k - 1].line - 1
            try:
                for frame in frames:
                    frame.line += offset
                    if last is not None and frame.timestep <= last:
                        raise UserError(f"{path}:{frame.line}: timestep {frame.timestep} "
                                        f"does not follow timestep {last}; time steps must "
                                        "increase (remove the repeated frames)")
                    last = frame.timestep
                    yield frame
            except UserError as exc:
                if not k:
                    raise
                where = re.escape(f"{path}:")
                text = re.sub(where + r"(\d+)", lambda m: f"{path}:{int(m.group(1)) + offset}",
                              str(exc), count=1)
                raise UserError(text) from None

    def _pieces(self, path) -> tuple:
        """A plain text file of :data:`PIECE` bytes or more cut into one piece per
        reader thread at frame starts: ((first byte, end byte, its line) of each piece,
        the frames each may read ahead: :data:`AHEAD` bytes over the pieces, as the first
        frame's size gives it); ([], 0) where it is read whole (gzip, binary, yaml,
        small, one thread, headers only)."""
        width = self._width()
        size = path.stat().st_size if path.is_file() else 0
        if width <= 1 or size < PIECE or path.suffix == ".gz" or self.headers_only or \
                self._first_only:
            return [], 0
        with open(path, "rb") as fh:
            if fh.read(5) != b"ITEM:":
                return [], 0
            buf = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            frame = _frame_start(buf, buf.find(b"ITEM: TIMESTEP") + 1) or size
            starts = [0]
            for k in range(1, width):
                at = _frame_start(buf, k * size // width)
                if at is not None and at > starts[-1]:
                    starts.append(at)
            # each piece numbers its lines from its own start (1): its reader does not
            # wait for the lines before it to be counted (:meth:`_piece_frames`)
            pieces = [(a, b, 1) for a, b in zip(starts, starts[1:] + [size])]
        finally:
            buf.close()
        if len(pieces) <= 1:
            return [], 0
        return pieces, max(2, AHEAD // (len(pieces) * frame))

    def _processor_frames(self, path):
        """The frames of a dump written one file per processor (a ``%`` in its name):
        each frame's rows from every file, in the processors' order."""
        found = processor_files(path)
        parts = [p for _, p in found]
        for part in parts[1:]:
            with open(part, "rb") as fh:
                start = fh.read(5)
            if start and start != b"ITEM:" and not part.suffix == ".bin":
                raise UserError(f"{part}: rows without frame headers (LAMMPS writes the "
                                "headers of a dump local split over processors to the first "
                                "file alone, so the frames of the others cannot be told "
                                "apart); dump the contacts to one file (no % in its name)")
        _whole_rank_set(path, found)
        walks = [_scanner(self, p).frames() for p in parts]
        for pieces in itertools.zip_longest(*walks):
            if any(f is None for f in pieces):
                short = parts[pieces.index(None)]
                held = next(f for f in pieces if f is not None)
                raise UserError(f"{short}: ends before timestep {held.timestep}, which "
                                f"{held.path} holds; every processor's file holds its share "
                                "of every frame: the file is cut, or of another run (copy "
                                "the whole set again)")
            first = pieces[0]
            other = next((f for f in pieces[1:] if f.timestep != first.timestep), None)
            if other is not None:
                raise UserError(f"{other.path}: timestep {other.timestep} where "
                                f"{first.path} has {first.timestep}; the files of one "
                                "dump's processors must hold the same frames")
            data = first.data if len(pieces) == 1 else np.concatenate([f.data for f in pieces])
            whole = DumpFrame(first.timestep, first.time, first.columns, data, first.box,
                              None, first.boundary, first.triclinic, first.tilt, path)
            yield from self._ready([whole])


#: Plain text dumps of this many bytes or more are read in pieces, one per reader thread.
PIECE = 64 << 20
#: The text bytes of the frames the pieces of one file read ahead of the one averaged,
#: together (about their parsed size): the memory that buys their parallel reading.
AHEAD = 1 << 30


def _frame_start(buf, at: int):
    """The first byte of the first frame that starts at or after byte ``at``: its
    ``ITEM: TIMESTEP`` line, or the ``ITEM: UNITS`` / ``ITEM: TIME`` header lines (each
    with its value line) just before it; None if no frame starts there."""
    k = buf.find(b"\nITEM: TIMESTEP\n", max(at - 1, 0))
    if k < 0:
        return None
    start = k + 1
    while start > at:
        value = buf.rfind(b"\n", 0, start - 1) + 1              # the value line's start
        head = buf.rfind(b"\n", 0, max(value - 1, 0)) + 1       # the header line's start
        if value <= 0 or not buf[head:value].startswith((b"ITEM: TIME\n", b"ITEM: UNITS\n")):
            break
        start = head
    return start


def processor_files(path) -> list:
    """(processor, file) of a dump written one file per processor: the files matching
    ``path`` with a number where its ``%`` is (as LAMMPS names them), in order; a
    one-line refusal if there is none."""
    path = Path(path)
    head, tail = path.name.split("%", 1)
    pattern = re.compile(re.escape(head) + r"(\d+)" + re.escape(tail) + "$")
    found = sorted((int(m.group(1)), p) for p in path.parent.glob(head + "*" + tail)
                   if (m := pattern.match(p.name)) and p.is_file())
    if not found:
        raise UserError(f"{path}: no file matches (the % stands for the processor, as in "
                        "LAMMPS' dump atoms.%.txt); give an existing file or pattern")
    return found


def _whole_rank_set(path, found) -> None:
    """Refuse a set of processor files that is not whole: ranks from 0 without a gap,
    none empty (LAMMPS writes every processor's headers, also of one without atoms); a
    missing share would average the others as the whole (density too low)."""
    ranks = [r for r, _ in found]
    gap = next((r for r in range(ranks[-1] + 1) if r not in ranks), None)
    if gap is not None:
        name = str(path).replace("%", str(gap))
        raise UserError(f"{name}: missing, while the files of processors "
                        f"{', '.join(map(str, ranks))} are there; a dump split over "
                        "processors needs every processor's file, from 0 on (copy the "
                        "whole set)")
    empty = next((p for _, p in found if p.stat().st_size == 0), None)
    if empty is not None:
        raise UserError(f"{empty}: empty, while {found[0][1].name} holds frames; every "
                        "processor's file holds its share of every frame (copy the whole "
                        "set again, or dump to one file: no % in its name)")


def first_file(path) -> Path:
    """The first file holding ``path``'s frames: of a ``dump.*`` series the first, of a
    ``%`` dump the first processor's."""
    first = series(path)[0]
    return processor_files(first)[0][1] if "%" in first.name else first


def _scanner(reader, path):
    """The walker of one file: LAMMPS' binary layout (:mod:`granavg.io.binary_dump`) or
    ``dump yaml`` (:mod:`granavg.io.yaml_dump`) where the file starts as one, else
    text."""
    from granavg.io import binary_dump, yaml_dump

    if binary_dump.is_binary(path):
        return binary_dump.BinaryScanner(reader, path, DumpFrame)
    if yaml_dump.is_yaml(path):
        return yaml_dump.YamlScanner(reader, path, DumpFrame)
    return _Scanner(reader, path)


def series(path) -> list:
    """The files of ``path``: itself, or for a name with a ``*`` every file matching it,
    ordered by the number that stands for the ``*`` (one-line refusal if none)."""
    return [p for _, p in numbered_series(path)]


def numbered_series(path) -> list:
    """(number, file) of :func:`series`: the number that stands for the ``*`` (-1 for a
    single file)."""
    path = Path(path)
    if "*" not in path.name and "%" in path.name:
        processor_files(path)                   # one dump in a file per processor
        return [(-1, path)]
    if "*" not in path.name:
        if not path.exists():
            raise UserError(f"{path}: no such file")
        return [(-1, path)]
    head, tail = path.name.split("*", 1)
    pattern = re.compile(re.escape(head) + r"(\d+)" + re.escape(tail).replace(r"\*", r"\d+") + "$")
    found = []
    for p in path.parent.glob(path.name):
        m = pattern.match(p.name)
        if m and p.is_file():
            found.append((int(m.group(1)), p))
    if not found:
        raise UserError(f"{path}: no file matches (the * stands for the time step, as in "
                        "LAMMPS' dump.*.txt); give an existing file or pattern")
    return sorted(found)


class _Scanner:
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
            if frame is not _SKIPPED:
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
            return _SKIPPED if skip else self._made(head, [], np.empty((n, 0)), first)
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
            return _SKIPPED
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
