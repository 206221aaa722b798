"""Frames read ahead in a thread while the engine averages the previous ones (and a
contact dump's frames beside its atom dump's: :class:`granavg.io.frames.PairedDumps`).

Reading is decompression (zlib/isal) and parsing (a compiled kernel), which both release
the GIL, so the reading of frame n + 1 overlaps the averaging of frame n.
The frames come in their order, unchanged; an error in the reader (a damaged file:line)
is raised where the frame would have come, and stopping early stops the thread.
"""

from __future__ import annotations

import itertools
import queue
import threading
from collections import deque

from granavg.engine import threads

#: Frames read ahead at most (memory: this many frames beyond the one averaged; a
#: million-sphere frame is about 100 MB).
DEPTH = 2
_END = object()


class Prefetched:
    """``frames`` read ahead in a background thread (none where granavg is given one
    thread: :func:`granavg.engine.threads.count`); every other attribute (``dropped``,
    ``box``, ``units``, ...) is the source's."""

    def __init__(self, frames, depth: int = DEPTH):
        self.frames, self.depth = frames, depth

    def __getattr__(self, name):
        return getattr(self.frames, name)

    def __iter__(self):
        if threads.count() <= 1:                  # one core: read where averaged
            yield from self.frames
            return
        ahead = Ahead(self.frames, self.depth)
        try:
            yield from ahead
        finally:
            ahead.close()


class Ahead:
    """The frames of ``frames``, read on a thread started at once, at most ``depth``
    ahead of the consumer; iterate once, then (or to stop early) ``close()``."""

    def __init__(self, frames, depth: int = DEPTH, name: str = "granavg-reader"):
        self._q: queue.Queue = queue.Queue(depth)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, args=(frames,), name=name,
                                        daemon=True)
        self._thread.start()

    def _put(self, item) -> bool:
        while not self._stop.is_set():
            try:
                self._q.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _read(self, frames):
        try:
            for frame in frames:
                if not self._put((frame, None)):
                    return
            self._put((_END, None))
        except BaseException as exc:          # handed to the consumer, raised there
            self._put((None, exc))

    def __iter__(self):
        while True:
            frame, error = self._q.get()
            if error is not None:
                raise error
            if frame is _END:
                return
            yield frame

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)


def in_order(sources, width: int, depth: int = DEPTH):
    """(key, frames) of each ``(key, iterable)`` in ``sources``, in order, with up to
    ``width`` of them read at once, each on a thread of its own (:class:`Ahead`, at most
    ``depth`` frames ahead): the files of a series, or the pieces of one file, parsed on
    several cores (the parser releases the GIL), memory bounded by ``width`` x ``depth``
    frames, and the frames in the order one thread would read them, so that everything
    downstream is the same."""
    sources = iter(sources)
    if width <= 1:
        yield from sources
        return
    started: deque = deque()

    def start():
        for key, frames in itertools.islice(sources, 1):
            started.append((key, Ahead(frames, depth, name="granavg-read")))
    for _ in range(width):
        start()
    try:
        while started:
            yield started[0]
            started.popleft()[1].close()
            start()
    finally:
        for _, ahead in started:
            ahead.close()


class ReadAhead:
    """A binary file's ``read`` with the next chunks read on a thread of their own: a
    gzip stream is decompressed (GIL-free in ISA-L) while the chunk before is parsed.

    ``read(n)`` returns at least ``n`` bytes (fewer only at the end; whole chunks, so often
    more, never copied when one suffices), in the file's order;
    an error of the underlying read is raised after the data that came before it, where
    a plain read would have raised it. ``close()`` stops the thread.
    """

    def __init__(self, fh, chunk: int, depth: int = 2):
        self._q: queue.Queue = queue.Queue(depth)
        self._stop = threading.Event()
        self._done = False
        self._error = None

        def run():
            try:
                while not self._stop.is_set():
                    data = fh.read(chunk)
                    self._put((data, None))
                    if not data:
                        return
            except BaseException as exc:          # raised in the reading thread, in order
                self._put((b"", exc))

        self._thread = threading.Thread(target=run, name="granavg-inflate", daemon=True)
        self._thread.start()

    def _put(self, item) -> None:
        while not self._stop.is_set():
            try:
                self._q.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def read(self, n: int) -> bytes:
        parts, size = [], 0
        while size < n and not self._done:
            data, error = self._q.get()
            if error is not None:
                self._done = True
                if size:                     # the data before the error first
                    self._error = error
                    return b"".join(parts)
                raise error
            if not data:
                self._done = True
                break
            parts.append(data)
            size += len(data)
        if not parts and self._error is not None:
            error, self._error = self._error, None
            raise error
        # whole chunks, not cut to n: one chunk is handed on as it came, uncopied
        return parts[0] if len(parts) == 1 else b"".join(parts)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
