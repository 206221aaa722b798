"""Time accumulation of per-frame ring sums, in blocks that merge exactly.

Frames at times t >= t_min fall in blocks of length ``block_time``:
block b = floor((t - t_min) / block_time). A block keeps the number of frames and the
sum of their ring sums. Two accumulators over disjoint sets of frames merge by adding
matching blocks, so splitting frames into chunks (dask workers) and merging gives the
one-pass result: bit for bit when chunks hold whole blocks (the order of additions is
the same), to round-off otherwise. Memory is one array per block, whatever the frame
count.
"""

from __future__ import annotations

import math

import numpy as np


class CellAccumulator:
    """Sums of frames' ring sums, per time block.

    Parameters
    ----------
    shape : tuple
        Shape of one frame's sums, (n_rings, n_channels).
    t_min : float
        Frames before this time (s) are rejected by :meth:`add`.
    block_time : float
        Block length (s) for the standard errors.
    max_blocks : int, optional
        Keep at most this many blocks: blocks of ``block_time * 2**level`` s, the level
        raised (pairs of blocks merged) when a frame falls beyond them.
    """

    def __init__(self, shape, t_min: float, block_time: float, max_blocks: int | None = None):
        if not block_time > 0:
            raise ValueError("block_time must be > 0")
        self.shape, self.t_min, self.block_time = tuple(shape), float(t_min), float(block_time)
        self.max_blocks, self.level = max_blocks, 0
        self.origin = None                  # the first frame's base block
        self.blocks: dict[int, list] = {}
        self.first = self.last = None
        self.n_frames = 0                   # frames added (their weights: the counts)

    def block_of(self, time: float) -> int:
        """Index of the (base) block holding time ``time`` (s)."""
        return int(math.floor((time - self.t_min) / self.block_time + 1e-9))

    def add(self, timestep: int, time: float, sums: np.ndarray, weight: float = 1.0) -> None:
        """Add one frame's ring sums, shape ``shape``, with a weight (a time kernel's;
        a block's count is the sum of its frames' weights)."""
        if time < self.t_min:
            raise ValueError(f"frame at t={time} s is before t_min={self.t_min} s")
        base = self.block_of(time)
        self.origin = base if self.origin is None else min(self.origin, base)
        self._fit(base)
        entry = self.blocks.setdefault(base >> self.level, [0, np.zeros(self.shape)])
        if weight == 1.0:
            entry[0] += 1
            entry[1] += sums
        else:
            entry[0] += weight
            entry[1] += weight * sums
        self.n_frames += 1
        self._span(timestep, time, timestep, time)

    def _fit(self, base) -> None:
        """Coarsen until the blocks from the first frame's to ``base``'s are at most
        ``max_blocks`` (blocks stay on the grid of t_min, so accumulators merge)."""
        while self.max_blocks and (base >> self.level) - (self.origin >> self.level) \
                >= self.max_blocks:
            self.coarsen()

    def coarsen(self) -> None:
        """Double the block length: merge blocks 2i and 2i + 1."""
        merged: dict[int, list] = {}
        for b, (n, s) in sorted(self.blocks.items()):
            entry = merged.setdefault(b >> 1, [0, np.zeros(self.shape)])
            entry[0] += n
            entry[1] += s
        self.blocks, self.level = merged, self.level + 1

    def merge(self, other: "CellAccumulator") -> "CellAccumulator":
        """A new accumulator holding the frames of both (same rings, t_min, blocks)."""
        if (other.shape, other.t_min, other.block_time, other.max_blocks) != (
                self.shape, self.t_min, self.block_time, self.max_blocks):
            raise ValueError("can only merge accumulators of the same rings and blocks")
        out = CellAccumulator(self.shape, self.t_min, self.block_time, self.max_blocks)
        out.level = max(self.level, other.level)
        for src in (self, other):
            for b, (n, s) in sorted(src.blocks.items()):
                b >>= out.level - src.level
                entry = out.blocks.setdefault(b, [0, np.zeros(self.shape)])
                entry[0] += n
                entry[1] = entry[1] + s if entry[0] > n else s.copy()
            if src.first is not None:
                out._span(*src.first, *src.last)
            out.n_frames += src.n_frames
        origins = [o for o in (self.origin, other.origin) if o is not None]
        if origins:
            out.origin = min(origins)
            out._fit(max(b << out.level for b in out.blocks))
        return out

    def _span(self, step0, t0, step1, t1):
        if self.first is None or t0 < self.first[1]:
            self.first = (step0, t0)
        if self.last is None or t1 > self.last[1]:
            self.last = (step1, t1)

    @property
    def weight(self) -> float:
        """The frames' summed weights (their number, unweighted)."""
        return sum(n for n, _ in self.blocks.values())

    def mean(self) -> np.ndarray:
        """Weighted mean ring sums over all frames, shape ``shape`` (NaN without
        frames)."""
        n = self.weight
        if n == 0:
            return np.full(self.shape, np.nan)
        total = np.zeros(self.shape)
        for _, (_, s) in sorted(self.blocks.items()):
            total += s
        return total / n

    def block_sums(self):
        """Frame counts and summed ring sums of the blocks, in time order.

        Returns
        -------
        counts : ndarray, shape (n_blocks,)
        sums : ndarray, shape (n_blocks, *shape)
        """
        items = sorted(self.blocks.items())
        if not items:
            return np.zeros(0), np.zeros((0, *self.shape))
        return (np.array([n for _, (n, _) in items], float),
                np.stack([s for _, (_, s) in items]))
