"""Time accumulation of per-frame cell sums, in blocks that merge exactly.

Frames at times t >= start fall in base blocks of length ``block_time``:
b = floor((t - start) / block_time). A base block keeps the sum of its frames' weights
and of their (weighted) sums, added in time order. With ``max_blocks``, blocks are
coarsened by pairs (level L: blocks of 2**L base blocks), and a coarse block's sum is
defined as a binary tree over its base blocks: T(l, i) = T(l-1, 2i) + T(l-1, 2i+1),
a child without frames left out. That sum does not depend on when the level was raised
nor on how the frames were split into accumulators over disjoint spans of whole base
blocks (dask's chunks, threads): merged, they give the one-pass sums bit for bit. A base
block split between accumulators is added once more, so only to round-off.

An accumulator keeps its finished coarse blocks and, below them, the tree's parts that
still wait for a neighbour: a part is added to its sibling when both exist, and moves up
alone when the sibling's span is known to hold no frame (inside the spans this
accumulator has seen whole). Parts wait only at the edges of its spans: memory is
``max_blocks`` blocks plus a few per edge, whatever the frame count.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from granavg.engine.timing.axes import TIME_TOLERANCE


class CellAccumulator:
    """Sums of frames' cell sums, per time block.

    Parameters
    ----------
    shape : tuple
        Shape of one frame's sums, (n_cells, n_channels) (or with sectors).
    start : float
        Frames before this time (s) are rejected by :meth:`add`.
    block_time : float
        Base block length (s) for the standard errors.
    max_blocks : int, optional
        Keep at most this many blocks: blocks of ``block_time * 2**level`` s, the level
        raised (pairs of blocks added) when a frame falls beyond them.
    """

    def __init__(self, shape, start: float, block_time: float, max_blocks: int | None = None):
        if not block_time > 0:
            raise ValueError("block_time must be > 0")
        self.shape, self.start, self.block_time = tuple(shape), float(start), float(block_time)
        self.max_blocks, self.level = max_blocks, 0
        self.origin = None                  # the first frame's base block
        #: finished blocks of the current level: index -> [weight, sums]
        self._blocks: dict[int, list] = {}
        #: tree parts below the level waiting for a neighbour: (level, index) -> [w, sums]
        self._parts: dict[tuple, list] = {}
        #: the base block frames are being added to: [index, weight, sums]
        self._open: list | None = None
        #: base blocks seen whole (closed): sorted disjoint [first, last] spans
        self._seen: list[list[int]] = []
        self.first = self.last = None
        self.n_frames = 0                   # frames added (their weights: the counts)

    def block_of(self, time: float) -> int:
        """Index of the (base) block holding time ``time`` (s)."""
        return max(0, int(math.floor((time - self.start) / self.block_time + 1e-9)))

    def add(self, timestep: int, time: float, sums: np.ndarray, weight: float = 1.0) -> None:
        """Add one frame's sums, shape ``shape``, with a weight (a time kernel's; a
        block's count is the sum of its frames' weights). Frames come in time order."""
        if time < self.start - TIME_TOLERANCE * self.block_time:      # (its rounding)
            raise ValueError(f"frame at t={time} s is before the start {self.start} s")
        base = self.block_of(time)
        if self._open is not None and base != self._open[0]:
            if base < self._open[0]:
                raise ValueError(f"frame at t={time} s comes after a later block's frames: "
                                 "add frames in time order")
            self._close(upto=base - 1)
        self.origin = base if self.origin is None else min(self.origin, base)
        self._fit(base)
        if self._open is None:
            self._open = [base, 0, np.zeros(self.shape)]
        if weight == 1.0:
            self._open[1] += 1
            self._open[2] += sums
        else:
            self._open[1] += weight
            self._open[2] += weight * sums
        self.n_frames += 1
        self._span(timestep, time, timestep, time)

    def _close(self, upto: int) -> None:
        """The open base block is whole, and so are the blocks after it up to ``upto``
        (no frame in them)."""
        base, n, s = self._open
        self._open = None
        self._see(base, max(base, upto))
        self._put(0, base, n, s)

    def _see(self, first: int, last: int) -> None:
        """Base blocks ``first`` .. ``last`` are seen whole."""
        spans = sorted(self._seen + [[first, last]])
        out = [spans[0]]
        for a, b in spans[1:]:
            if a <= out[-1][1] + 1:
                out[-1][1] = max(out[-1][1], b)
            else:
                out.append([a, b])
        self._seen = out

    def _empty(self, level: int, index: int) -> bool:
        """Whether the span of tree node (level, index) is known to hold no frame."""
        a, b = index << level, ((index + 1) << level) - 1
        k = bisect.bisect_right(self._seen, [a, math.inf]) - 1
        if k < 0 or self._seen[k][1] < b:
            return False
        if self._open is not None and a <= self._open[0] <= b:
            return False
        return not any(a <= i << lv <= b for lv, i in self._parts if lv < level)

    def _put(self, level: int, index: int, n, s) -> None:
        """Place the finished tree node (level, index): up the tree while its sibling
        exists (added, lower index first) or holds no frame; kept as a part where the
        sibling may still come; a block at the accumulator's level. A node sharing a
        base block with one held (two accumulators added frames of it) is added to that
        one: to round-off only."""
        for up in range(level + 1, self.level + 1):        # held inside a larger node
            key = (up, index >> (up - level))
            host = self._parts.get(key) if up < self.level else self._blocks.get(key[1])
            if host is not None:
                host[0], host[1] = host[0] + n, host[1] + s
                return
        for key in [k for k in self._parts if k[0] < level and
                    k[1] >> (level - k[0]) == index]:      # larger than nodes held
            inner = self._parts.pop(key)
            n, s = n + inner[0], s + inner[1]
        while level < self.level:
            same = self._parts.pop((level, index), None)
            if same is not None:
                n, s = same[0] + n, same[1] + s
            sib = index ^ 1
            other = self._parts.pop((level, sib), None)
            if other is not None:
                lo, hi = ((n, s), other) if index < sib else (other, (n, s))
                n, s = lo[0] + hi[0], lo[1] + hi[1]
            elif not self._empty(level, sib):
                self._parts[(level, index)] = [n, s]
                return
            level, index = level + 1, index >> 1
        held = self._blocks.get(index)
        # a block already there: the same base block added by two accumulators
        self._blocks[index] = [n, s] if held is None else [held[0] + n, held[1] + s]

    def _settle(self) -> None:
        """Move every part up as far as it goes (after a merge or a coarsening)."""
        for level in range(self.level):
            for key in sorted(k for k in self._parts if k[0] == level):
                if key in self._parts:                 # not taken by its sibling yet
                    self._put(*key, *self._parts.pop(key))

    def _fit(self, base) -> None:
        """Coarsen until the blocks from the first frame's to ``base``'s are at most
        ``max_blocks`` (blocks stay on the grid of the start, so accumulators merge)."""
        while self.max_blocks and (base >> self.level) - (self.origin >> self.level) \
                >= self.max_blocks:
            self.coarsen()

    def coarsen(self) -> None:
        """Double the block length: blocks 2i and 2i + 1 added."""
        self.level += 1
        for index, (n, s) in self._blocks.items():
            self._parts[(self.level - 1, index)] = [n, s]
        self._blocks = {}
        self._settle()

    def merge(self, other: "CellAccumulator") -> "CellAccumulator":
        """A new accumulator holding the frames of both (same cells, start, blocks;
        disjoint spans of whole base blocks for bit-exact sums)."""
        if (other.shape, other.start, other.block_time, other.max_blocks) != (
                self.shape, self.start, self.block_time, self.max_blocks):
            raise ValueError("can only merge accumulators of the same rings and blocks")
        out = CellAccumulator(self.shape, self.start, self.block_time, self.max_blocks)
        out.level = max(self.level, other.level)
        nodes = []
        for src in (self, other):
            nodes += [(k, n, s) for k, (n, s) in src._parts.items()]
            nodes += [((src.level, i), n, s) for i, (n, s) in src._blocks.items()]
            if src._open is not None:
                nodes.append(((0, src._open[0]), src._open[1], src._open[2]))
                out._see(src._open[0], src._open[0])
            for a, b in src._seen:
                out._see(a, b)
            if src.first is not None:
                out._span(*src.first, *src.last)
            out.n_frames += src.n_frames
        for (level, index), n, s in nodes:
            if level == out.level:
                out._put(level, index, n, s.copy())
            elif (level, index) in out._parts:     # a base block in both: added again
                held = out._parts[(level, index)]
                out._parts[(level, index)] = [held[0] + n, held[1] + s]
            else:
                out._parts[(level, index)] = [n, s.copy()]
        out._settle()
        origins = [o for o in (self.origin, other.origin) if o is not None]
        if origins:
            out.origin = min(origins)
            last = max((i + 1 << lv) - 1 for lv, i in out._nodes())
            out._fit(last)
        return out

    def _nodes(self):
        """(level, index) of every node held: blocks, parts, the open base block."""
        yield from ((self.level, i) for i in self._blocks)
        yield from self._parts
        if self._open is not None:
            yield (0, self._open[0])

    def _span(self, step0, t0, step1, t1):
        if self.first is None or t0 < self.first[1]:
            self.first = (step0, t0)
        if self.last is None or t1 > self.last[1]:
            self.last = (step1, t1)

    def _finished(self) -> list:
        """(index, weight, sums) of the blocks at this level in time order, those still
        in parts (or open) added up the tree, a missing child left out."""
        nodes = {k: (n, s) for k, (n, s) in self._parts.items()}
        if self._open is not None:
            key = (0, self._open[0])
            held = nodes.get(key)
            nodes[key] = (self._open[1], self._open[2]) if held is None else \
                (held[0] + self._open[1], held[1] + self._open[2])
        above = {(lv, i >> (lv - level)) for level, i in nodes
                 for lv in range(level, self.level + 1)}

        def tree(level, index):
            if (level, index) in nodes:
                return nodes[(level, index)]
            if (level, index) not in above or level == 0:
                return None
            lo, hi = tree(level - 1, 2 * index), tree(level - 1, 2 * index + 1)
            return lo if hi is None else hi if lo is None else (lo[0] + hi[0], lo[1] + hi[1])

        out = dict(self._blocks)
        for index in sorted({i for lv, i in above if lv == self.level}):
            n, s = tree(self.level, index)
            held = out.get(index)
            out[index] = (n, s) if held is None else (held[0] + n, held[1] + s)
        return [(i, *out[i]) for i in sorted(out)]

    @property
    def n_blocks(self) -> int:
        """The number of blocks (at this level) holding frames."""
        return len(self._finished())

    @property
    def weight(self) -> float:
        """The frames' summed weights (their number, unweighted)."""
        return sum(n for _, n, _ in self._finished())

    def mean(self) -> np.ndarray:
        """Weighted mean sums over all frames, shape ``shape`` (NaN without frames)."""
        blocks = self._finished()
        n = sum(n for _, n, _ in blocks)
        if n == 0:
            return np.full(self.shape, np.nan)
        total = np.zeros(self.shape)
        for _, _, s in blocks:
            total += s
        return total / n

    def block_sums(self):
        """Frame counts (weights) and summed sums of the blocks, in time order.

        Returns
        -------
        counts : ndarray, shape (n_blocks,)
        sums : ndarray, shape (n_blocks, *shape)
        """
        blocks = self._finished()
        if not blocks:
            return np.zeros(0), np.zeros((0, *self.shape))
        return (np.array([n for _, n, _ in blocks], float),
                np.stack([s for _, _, s in blocks]))
