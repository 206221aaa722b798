"""Frames read ahead in a thread while the engine averages the previous ones.

Reading is decompression (zlib/isal) and parsing (a compiled kernel), which both release
the GIL, so on two cores the reading of frame n + 1 overlaps the averaging of frame n.
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
