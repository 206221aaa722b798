"""SIGINT and SIGTERM held back over a section that must not be cut in two.

A Python signal handler runs in the main thread between two bytecodes, whichever thread
the signal was delivered to, so blocking the signal in the main thread
(``pthread_sigmask``) does not keep it out while other threads (a reader, the engine's,
dask's event loop) leave it unblocked. :func:`deferred` instead puts a handler in place that
only records the signal, and after the section hands each recorded signal to the handler
that was there before: the command's (which raises and reports it), or the default.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def deferred():
    """Within the block SIGINT and SIGTERM are recorded, not acted on; the list of those
    received is what the block sees (to stop early, e.g. while waiting). After the block
    the first of them goes to the previous handler. Outside the main thread (where
    handlers cannot be set) nothing is held back."""
    received: list[int] = []
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for signum in HELD:
            handler = signal.getsignal(signum)
            if handler not in (signal.SIG_IGN, None):
                previous[signum] = signal.signal(signum, lambda s, f: received.append(s))
    try:
        yield received
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if received and received[0] in previous:
            handler = previous[received[0]]
            if callable(handler):
                handler(received[0], None)
            else:
                signal.raise_signal(received[0])
