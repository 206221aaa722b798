"""Frames read ahead in a thread (granavg.io.prefetch): same frames, same order,
the reader's errors where the frame would have come, a clean stop."""

import threading
import time

import pytest

from granavg.errors import UserError
from granavg.io.prefetch import Prefetched


class Source:
    dropped = {"contacts_not_touching": 3}

    def __init__(self, n, fail_at=None):
        self.n, self.fail_at, self.read = n, fail_at, 0

    def __iter__(self):
        for k in range(self.n):
            if k == self.fail_at:
                raise UserError(f"atoms.dump:{100 + k}: damaged row")
            self.read += 1
            yield k


def test_frames_come_in_order_and_attributes_are_the_sources():
    src = Source(50)
    got = list(Prefetched(src, depth=3))
    assert got == list(range(50)) and Prefetched(src).dropped == src.dropped


def test_a_readers_error_is_raised_where_its_frame_would_come():
    seen = []
    with pytest.raises(UserError, match="atoms.dump:107"):
        for k in Prefetched(Source(20, fail_at=7)):
            seen.append(k)
    assert seen == list(range(7))


def test_stopping_early_stops_the_reader():
    src = Source(10_000)
    it = iter(Prefetched(src, depth=2))
    assert [next(it) for _ in range(3)] == [0, 1, 2]
    it.close()                                          # the consumer stops
    time.sleep(0.3)
    assert src.read < 20
    assert not [t for t in threading.enumerate() if t.name == "granavg-reader"]
