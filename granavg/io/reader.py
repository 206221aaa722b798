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
from pathlib import Path

import numpy as np

from granavg.engine import threads
from granavg.errors import UserError
from granavg.io.prefetch import in_order
from granavg.io.text_scan import DumpFrame, TextScanner

log = logging.getLogger(__name__)

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
        scanners = [TextScanner(self, path, span) for span in pieces]
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
    return TextScanner(reader, path)


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


