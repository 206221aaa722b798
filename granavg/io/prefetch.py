"""Frames read ahead in a thread while the engine averages the previous ones (and a
contact dump's frames beside its atom dump's: :class:`granavg.io.frames.PairedDumps`).

Reading is decompression (zlib/isal) and parsing (a compiled kernel), which both release
the GIL, so the reading of frame n + 1 overlaps the averaging of frame n.
The frames come in their order, unchanged; an error in the reader (a damaged file:line)
is raised where the frame would have come, and stopping early stops the thread.
"""

from __future__ import annotations

import queue
import threading

#: Frames read ahead at most (memory: this many frames beyond the one averaged; a
#: million-sphere frame is about 100 MB).
DEPTH = 2
_END = object()


class Prefetched:
    """``frames`` read ahead in a background thread; every other attribute (``dropped``,
    ``box``, ``units``, ...) is the source's."""

    def __init__(self, frames, depth: int = DEPTH):
        self.frames, self.depth = frames, depth

    def __getattr__(self, name):
        return getattr(self.frames, name)

    def __iter__(self):
        q: queue.Queue = queue.Queue(self.depth)
        stop = threading.Event()

        def put(item) -> bool:
            while not stop.is_set():
                try:
                    q.put(item, timeout=0.1)
                    return True
                except queue.Full:
                    continue
            return False

        def read():
            try:
                for frame in self.frames:
                    if not put((frame, None)):
                        return
                put((_END, None))
            except BaseException as exc:          # handed to the consumer, raised there
                put((None, exc))

        worker = threading.Thread(target=read, name="granavg-reader", daemon=True)
        worker.start()
        try:
            while True:
                frame, error = q.get()
                if error is not None:
                    raise error
                if frame is _END:
                    return
                yield frame
        finally:
            stop.set()
            worker.join(timeout=1.0)


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
