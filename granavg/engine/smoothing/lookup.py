"""The (item, node) pairs within a kernel's reach: from the nodes' own lattice (a cell
list of the nodes: the index ranges within the reach along each axis), never from all
items against all nodes."""

from __future__ import annotations

import numpy as np


def lattice_pairs(coords, axes, reach):
    """(item, node) pairs of items at ``coords`` (tuple of D arrays, shape (n,)) and the
    nodes of a rectilinear lattice (``axes``: D sorted arrays of node coordinates, node
    k the C-order index) within ``reach`` of each other along every axis; ``reach`` is
    a number or an array (n,) (a segment's own extent plus the support)."""
    n = len(coords[0])
    reach = np.broadcast_to(np.asarray(reach, float), (n,))
    lo = [np.searchsorted(a, u - reach, "left") for a, u in zip(axes, coords)]
    hi = [np.searchsorted(a, u + reach, "right") for a, u in zip(axes, coords)]
    sizes = [h - l for h, l in zip(hi, lo)]
    count = np.prod(np.maximum(np.stack(sizes), 0), axis=0)
    item = np.repeat(np.arange(n), count)
    if not len(item):
        return item, item.copy()
    rank = np.arange(len(item)) - np.repeat(np.cumsum(count) - count, count)
    node = np.zeros(len(item), np.int64)
    stride = 1
    for d in reversed(range(len(axes))):
        size = np.repeat(sizes[d], count)
        node += (np.repeat(lo[d], count) + rank % size) * stride
        rank //= size
        stride *= len(axes[d])
    return item, node
