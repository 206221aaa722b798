"""Time blocks that merge exactly: however the frames are split into accumulators over
whole base blocks, and in whatever order those merge, the blocks' sums are the one-pass
sums bit for bit, also where the blocks were coarsened (granavg.engine.accumulate)."""

import numpy as np
import pytest

from granavg.engine.accumulate import CellAccumulator

SHAPE = (3, 2)


def frames(rng, n):
    """Frame times with gaps of several empty base blocks and blocks of many frames."""
    steps = rng.choice([0.05, 0.1, 0.3, 0.9, 2.7], size=n, p=[0.4, 0.3, 0.15, 0.1, 0.05])
    t = 0.4 + np.cumsum(steps)
    return [(k, float(t[k]), rng.normal(size=SHAPE) * 10.0 ** rng.integers(-3, 4),
             float(rng.choice([1.0, rng.uniform(0.1, 2)]))) for k in range(n)]


def accumulate(chunk, max_blocks):
    acc = CellAccumulator(SHAPE, 0.25, 0.2, max_blocks)
    for step, t, s, w in chunk:
        acc.add(step, t, s, w)
    return acc


def whole_block_chunks(rng, fr, acc, k):
    """``fr`` cut into ``k`` runs of frames at base-block boundaries (some chunks may
    hold a single base block)."""
    blocks = np.array([acc.block_of(t) for _, t, _, _ in fr])
    starts = np.flatnonzero(np.r_[True, blocks[1:] != blocks[:-1]])
    cuts = sorted(set(rng.choice(starts[1:], size=min(k - 1, len(starts) - 1), replace=False)))
    bounds = [0, *cuts, len(fr)]
    return [fr[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def merged_in_random_order(rng, accs):
    """Merge neighbours picked at random until one is left (any tree of merges)."""
    accs = list(accs)
    while len(accs) > 1:
        i = int(rng.integers(len(accs) - 1))
        a, b = accs[i], accs[i + 1]
        accs[i:i + 2] = [a.merge(b) if rng.random() < 0.5 else b.merge(a)]
    return accs[0]


def same(a, b):
    ca, sa = a.block_sums()
    cb, sb = b.block_sums()
    return (np.array_equal(ca, cb) and np.array_equal(sa, sb) and
            np.array_equal(a.mean(), b.mean()) and a.weight == b.weight and
            a.n_frames == b.n_frames and a.level == b.level and a.first == b.first and
            a.last == b.last)


@pytest.mark.parametrize("max_blocks", [None, 2, 3, 4, 7, 16])
@pytest.mark.parametrize("seed", range(6))
def test_any_split_into_whole_blocks_merges_into_the_one_pass_sums_bit_for_bit(seed,
                                                                              max_blocks):
    rng = np.random.default_rng(seed)
    fr = frames(rng, int(rng.integers(20, 400)))
    one = accumulate(fr, max_blocks)
    assert max_blocks is None or one.n_blocks <= max_blocks
    for k in (2, 3, 5, 11):
        parts = [accumulate(c, max_blocks) for c in whole_block_chunks(rng, fr, one, k)]
        assert same(merged_in_random_order(rng, parts), one), k


def test_a_coarsened_tree_differs_from_sequential_addition_the_test_can_fail():
    """The sums the test above compares are sensitive to the order of additions: the
    one-pass blocks of a coarsened accumulator differ from adding a block's frames in
    sequence (so equality above is not trivial)."""
    rng = np.random.default_rng(1)
    fr = frames(rng, 300)
    one = accumulate(fr, 4)
    counts, sums = one.block_sums()
    size = one.block_time * 2 ** one.level
    plain = {}
    for _, t, s, w in fr:
        j = int(np.floor((t - one.start) / size + 1e-9))
        plain[j] = plain.get(j, 0) + w * s
    seq = np.stack([plain[j] for j in sorted(plain)])
    assert np.allclose(seq, sums, rtol=1e-12, atol=1e-9)
    assert not np.array_equal(seq, sums)


def test_memory_stays_bounded_on_a_long_run():
    rng = np.random.default_rng(3)
    acc = CellAccumulator(SHAPE, 0.0, 0.1, 8)
    for k in range(20_000):
        acc.add(k, 0.1 * k + 0.03 * rng.random(), np.ones(SHAPE))
        assert len(acc._parts) <= 2 * acc.level + 2
    assert acc.n_blocks <= 8 and acc.weight == acc.n_frames == 20_000


@pytest.mark.parametrize("max_blocks", [None, 2, 4, 16])
@pytest.mark.parametrize("seed", range(4))
def test_base_blocks_split_between_accumulators_merge_to_round_off(seed, max_blocks):
    """Cuts anywhere (a base block's frames in two accumulators): no frame lost or
    counted twice, the sums to round-off, whatever the merge order."""
    rng = np.random.default_rng(10 + seed)
    fr = [(k, t, s, 1.0) for k, t, s, _ in frames(rng, int(rng.integers(50, 400)))]
    one = accumulate(fr, max_blocks)
    for k in (2, 5, 13):
        cuts = sorted(set(rng.integers(1, len(fr), size=k - 1)))
        bounds = [0, *cuts, len(fr)]
        ragged = merged_in_random_order(
            rng, [accumulate(fr[a:b], max_blocks) for a, b in zip(bounds[:-1], bounds[1:])])
        counts, sums = ragged.block_sums()
        want_counts, want_sums = one.block_sums()
        assert ragged.n_frames == one.n_frames and ragged.level == one.level
        assert np.array_equal(counts, want_counts), k
        assert np.allclose(sums, want_sums, rtol=1e-12, atol=1e-9 * np.abs(want_sums).max())


def test_frames_out_of_time_order_are_refused():
    acc = CellAccumulator(SHAPE, 0.0, 0.1)
    acc.add(0, 0.55, np.ones(SHAPE))
    with pytest.raises(ValueError, match="time order"):
        acc.add(1, 0.25, np.ones(SHAPE))
