"""Honest standard errors from correlated frames: blocking analysis and replicates.

Frames of a DEM run are correlated (a dense packing rearranges slowly), so the spread of
frame values over sqrt(frames) understates the error. :func:`blocking_errors` follows
Flyvbjerg and Petersen (J. Chem. Phys. 91, 461, 1989): base blocks (one time block of
the accumulator each) are merged pairwise, level after level; at each level the
standard error is the spread of the block values over sqrt(blocks). While the blocks
are shorter than the correlation time the estimate grows with the level; once they are
longer, it stays on a plateau. The level reported is chosen by the criterion of Lee
et al. (2011), which asks the blocks to be long against the correlation time that the
estimates themselves show; where no level with at least :data:`MIN_BLOCKS` blocks meets
it, the plateau was not reached and the error is only a **lower bound** (flagged).

Derived numbers (fits, exponents, maxima) get their errors from *replicates*: profiles
recomputed with one block of the coarsest usable level left out (delete-one jackknife)
for one run, or the profiles of each realisation for an ensemble
(:class:`Replicates`). Time alone misses the frozen structure of one packing: where the
cells have a symmetry direction their sectors are replicas of it
(:mod:`granavg.engine.uncertainty.structure`), and :func:`combine_errors` joins the sectors' spread
with the time blocking in a two-way analysis.

Block values are ratios of block sums (v = <nu v>/<nu> per block), as the profiles are;
a block in which a value is undefined (NaN) is left out of that value's spread, and the
standard error divides by the number of finite blocks.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

#: Fewest blocks a level needs to take part in the plateau search: with fewer, the
#: error of the error, 1/sqrt(2 (n - 1)), exceeds 27%.
MIN_BLOCKS = 8


def merge_levels(counts, sums) -> list:
    """Blocking levels of base blocks: level 0 is the base, level l + 1 merges pairs of
    consecutive blocks of level l (an odd last block is dropped, as in FP 1989).

    Parameters
    ----------
    counts : ndarray, shape (n_blocks,)
        Frames in each base block, in time order.
    sums : ndarray, shape (n_blocks, ...)
        Sum over each block's frames of the per-frame sums.

    Returns
    -------
    list of (counts, sums)
        One pair per level, down to two blocks.
    """
    counts, sums = np.asarray(counts, float), np.asarray(sums, float)
    levels = [(counts, sums)]
    while len(counts) >= 4:
        n = len(counts) // 2 * 2
        counts = counts[:n:2] + counts[1:n:2]
        sums = sums[:n:2] + sums[1:n:2]
        levels.append((counts, sums))
    return levels


def spread_error(per_block) -> np.ndarray:
    """Standard error of the mean from block values, NaN-aware.

    Parameters
    ----------
    per_block : ndarray, shape (n_blocks, ...)

    Returns
    -------
    ndarray, shape (...)
        std over the finite blocks (ddof 1) / sqrt(number of finite blocks); NaN where
        fewer than two blocks are finite.
    """
    x = np.asarray(per_block, float)
    n = np.sum(np.isfinite(x), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sd = np.nanstd(x, axis=0, ddof=1)
        return np.where(n >= 2, sd / np.sqrt(n), np.nan)


def plateau(errors, n_blocks):
    """Pick the blocking error from per-level estimates (Lee et al., Phys. Rev. B 83,
    066104, 2011): the first level whose block length B (in base blocks) is long
    enough for the correlation the estimates themselves show,
    B^3 > 2 N (e_B / e_0)^4, with N base blocks.

    Parameters
    ----------
    errors : ndarray, shape (n_levels, ...)
        Standard error estimated at each level (level l has blocks of 2^l base blocks).
    n_blocks : ndarray, shape (n_levels,)
        Blocks at each level.

    Returns
    -------
    error : ndarray, shape (...)
        The estimate at the chosen level; if no level with >= MIN_BLOCKS blocks meets the
        criterion, the coarsest such level's.
    lower_bound : ndarray of bool, shape (...)
        True where no level met the criterion: the error is then only a lower bound.
    level : ndarray of int, shape (...)
        The level chosen.
    """
    e = np.asarray(errors, float)
    n_blocks = np.asarray(n_blocks)
    usable = np.flatnonzero(n_blocks >= MIN_BLOCKS)
    last = int(usable[-1]) if len(usable) else 0
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(e[0] > 0, (e / e[0]) ** 2, 1.0)     # ~ 2 tau_int / base block
    shape = (-1,) + (1,) * (e.ndim - 1)
    B = (2.0 ** np.arange(len(e))).reshape(shape)
    meets = (B ** 3 > 2.0 * n_blocks[0] * ratio ** 2) & np.isfinite(e)
    meets[last + 1:] = False
    found = np.any(meets, axis=0)
    chosen = np.where(found, np.argmax(meets, axis=0), last)
    error = np.take_along_axis(e, chosen[None], axis=0)[0]
    return error, ~found, chosen


def blocking_errors(counts, sums, evaluate):
    """Blocking-analysis standard errors of every value computed from block sums.

    Parameters
    ----------
    counts : ndarray, shape (n_blocks,)
        Frames per base block.
    sums : ndarray, shape (n_blocks, n_rings, n_channels)
        Summed per-frame ring sums of each base block.
    evaluate : callable
        ``evaluate(mean_sums) -> dict name -> ndarray (m, n_rings)`` for mean ring sums of
        shape (m, n_rings, n_channels): the profile values of m blocks at once.

    Returns
    -------
    sem : dict of name -> ndarray (n_rings,)
    lower_bound : dict of name -> ndarray of bool (n_rings,)
    """
    levels = merge_levels(counts, sums)
    per_level, shapes = [], None
    for c, s in levels:
        vals = evaluate(s / c[:, None, None])
        if shapes is None:
            shapes = {k: np.shape(v)[1:] for k, v in vals.items()}
        # every value at once: a column's error does not depend on the others
        flat = [np.asarray(vals[k], float).reshape(len(c), -1) for k in shapes]
        per_level.append(spread_error(np.concatenate(flat, axis=1)))
    n_blocks = np.array([len(c) for c, _ in levels])
    e, lb, _ = plateau(np.stack(per_level), n_blocks)
    lb = lb | ~np.isfinite(e)
    sem, lower, start = {}, {}, 0
    for name, shape in shapes.items():
        size = int(np.prod(shape))
        sem[name] = e[start:start + size].reshape(shape)
        lower[name] = lb[start:start + size].reshape(shape)
        start += size
    return sem, lower


def jackknife_level(counts) -> int:
    """Blocking level of the jackknife: the coarsest with >= MIN_BLOCKS blocks (the
    most conservative; the same for every ring count of one run), else level 0."""
    n = np.array([len(c) for c, _ in merge_levels(counts, np.zeros(len(counts)))])
    ok = np.flatnonzero(n >= MIN_BLOCKS)
    return int(ok[-1]) if len(ok) else 0


def jackknife_sums(counts, sums):
    """Mean ring sums with one block of the jackknife level left out.

    Returns
    -------
    ndarray, shape (n_replicates, n_rings, n_channels)
    """
    c, s = merge_levels(counts, sums)[jackknife_level(counts)]
    total_c, total_s = np.sum(counts), np.sum(np.asarray(sums, float), axis=0)
    rest = total_c - c
    with np.errstate(invalid="ignore", divide="ignore"):
        return (total_s[None] - s) / rest[:, None, None]


@dataclass
class Replicates:
    """Fields recomputed on parts of the data, to give derived numbers their errors.

    Attributes
    ----------
    kind : {"jackknife", "runs", "structure"}
        ``jackknife``: one time block left out each (one run); ``runs``: one realisation
        each; ``structure``: one run's sectors and time blocks
        (:mod:`granavg.engine.uncertainty.structure`): delete-one-sector profiles, then the
        delete-one-block ones, then the sector x block interaction replicates.
    values : dict of name -> ndarray, shape (n_replicates, n_rings)
    parts : dict, optional
        ``structure`` only: ``{"sectors": K, "blocks": J, "cells": [K, B]}``, the
        lengths of the three parts in that order.
    """

    kind: str
    values: dict
    parts: dict | None = None

    @property
    def n(self) -> int:
        return len(next(iter(self.values.values()))) if self.values else 0

    def in_time(self) -> "Replicates":
        """The time blocks alone (kind ``jackknife``) of ``structure`` replicates; other
        kinds unchanged. For numbers that hold in every packing but not in a sector - a
        balance law's residual: a sector's balance misses the tractions on its cuts."""
        if self.kind != "structure":
            return self
        return Replicates("jackknife", {q: self.split(v)[1] for q, v in self.values.items()})

    def split(self, estimates):
        """(sectors, blocks, cells) parts of per-replicate estimates (structure kind)."""
        k, j = self.parts["sectors"], self.parts["blocks"]
        x = np.asarray(estimates, float)
        return x[:k], x[k:k + j], x[k + j:]

    def error(self, estimates) -> float:
        """Standard error of a number from its value on each replicate (NaN-aware):
        jackknife sqrt((n-1)/n sum (x_i - mean)^2), between runs std/sqrt(n), or for
        ``structure`` the two-way combination of the sector jackknife, the time
        jackknife and the interaction (:func:`combine_errors`)."""
        if self.kind == "structure":
            sectors, blocks, cells = self.split(estimates)
            return float(combine_errors(jackknife_error(sectors) ** 2, jackknife_error(blocks) ** 2,
                                        interaction_variance(cells, *self.parts["cells"])))
        x = np.asarray(estimates, float)
        x = x[np.isfinite(x)]
        if len(x) < 2:
            return float("nan")
        if self.kind == "jackknife":
            return jackknife_error(x)
        return float(np.std(x, ddof=1) / np.sqrt(len(x)))

    def profile_errors(self) -> dict:
        """Per-ring standard errors of every value from the replicates."""
        return {k: np.array([self.error(v[:, j]) for j in range(v.shape[1])])
                for k, v in self.values.items()}


def jackknife_error(estimates) -> float:
    """Delete-one jackknife error sqrt((n-1)/n sum (x_i - mean)^2) over the finite ones."""
    x = np.asarray(estimates, float)
    x = x[np.isfinite(x)]
    n = len(x)
    return float(np.sqrt((n - 1) / n * np.sum((x - x.mean()) ** 2))) if n >= 2 else float("nan")


def interaction_variance(estimates, k, b):
    """The two-way interaction mean square over K B from the interaction replicates
    (each the profile shifted by its residual / sqrt(K B)): sum (x - mean)^2 /
    ((K-1)(B-1)), scaled up for replicates that are not finite."""
    x = np.asarray(estimates, float)
    x = x[np.isfinite(x)]
    if len(x) < 2 or k < 2 or b < 2:
        return float("nan")
    return float(np.sum((x - x.mean()) ** 2)) * (k * b / len(x)) / ((k - 1) * (b - 1))


def combine_errors(var_sectors, var_time, var_interaction):
    """Standard error of the two-way model: sqrt(E_s + E_t - E_i), never below either
    of E_s and E_t (each a variance of the same mean); the time part alone where the
    sectors give none. Arrays or floats."""
    vs, vt, vi = (np.asarray(v, float) for v in (var_sectors, var_time, var_interaction))
    vi = np.where(np.isfinite(vi), vi, 0.0)
    both = np.fmax(np.fmax(vs + vt - vi, vs), vt)
    out = np.where(np.isfinite(vs), both, vt)
    return np.sqrt(out) if out.ndim else float(np.sqrt(out))
