"""Errors that count the frozen structure of one packing, from each cell's sectors.

Time averaging cannot remove a packing's frozen density and contact structure, so the
spread of time blocks misses it. Where the cells have a symmetry direction - the
azimuth of rings about the Couette axis, the length of slabs - a cell's sectors along
it are independent samples of the same frozen disorder, once they are farther apart
than its correlation length. Each cell is split into ``K`` sectors, accumulated like a
cell (the same channels); the sectors of a cell add up to the cell exactly (their
shares: the geometries' ``sector_shares``, :mod:`granavg.engine.cells.sectors`).

The error of a cell's value (:func:`~granavg.engine.uncertainty.blocking.combine_errors`)
is that of the two-way random model x[s, b] = mu + F_s + T_b + e_sb over sectors s and
time blocks b: frozen structure F, a part common to all sectors T (the whole packing's
fluctuations), and a local, time-varying part e. The variance of the mean is

    Var = sigma_F^2 / K + sigma_T^2 / B + sigma_e^2 / (K B)
        = E_sectors + E_time - E_interaction,

with E_sectors the delete-one-sector jackknife variance (sectors' time means: F and e),
E_time the time blocking variance of the cell (T and e) and E_interaction the two-way
table's interaction mean square over K B (e alone), which both of the others count.
Derived numbers take the same three terms from replicate profiles
(:class:`~granavg.engine.uncertainty.blocking.Replicates` of kind ``structure``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from granavg.engine.profiles import block_values
from granavg.engine.quantities import balanced_names
from granavg.engine.uncertainty.blocking import (Replicates, combine_errors,
                                                 interaction_variance, jackknife_error,
                                                 merge_levels)
from granavg.errors import ParameterError

#: Sectors accumulated per cell when K is chosen from the data; every candidate K
#: divides it.
FINE_SECTORS = 24
#: Candidate numbers of sectors, most first; fewer than 4 replicas give an error whose
#: own relative error exceeds 40%.
CANDIDATES = (24, 12, 8, 6, 4)
MIN_REPLICAS = 4
#: Most sectors that may be pinned: the two-way table keeps at least 2 time blocks
#: (MAX_CELLS / MAX_SECTORS) for the interaction.
MAX_SECTORS = 48
#: Largest accepted correlation of adjacent sectors: with correlation rho the spread
#: of K sectors understates the error by about sqrt(1 + 2 rho), 10% at rho = 0.1.
RHO_MAX = 0.1
#: A quantity whose frozen part is at least this share of its sectors' variance is
#: dominated by structure: its sectors' correlation sets the replicas of derived numbers.
FROZEN_SHARE = 0.5
#: At most this many interaction replicates (sectors x time blocks) for derived numbers.
MAX_CELLS = 96
#: Time blocks the replica accumulator keeps at most (coarser blocks beyond).
REPLICA_BLOCKS = 32


def merge_sectors(sums, k):
    """Sums over ``k`` sectors from sums over finer ones (adjacent sectors added).

    Parameters
    ----------
    sums : ndarray, shape (..., n_cells, K_fine, n_channels)
    k : int
        A divisor of K_fine.
    """
    *lead, n, kf, c = sums.shape
    return sums.reshape(*lead, n, k, kf // k, c).sum(axis=-2)


def sector_values(sums, V, rho_p, groups, layout):
    """Profile values of every sector of every cell.

    Parameters
    ----------
    sums : ndarray, shape (m, n_cells, K, n_channels)
        Mean sums per frame.
    V : ndarray, shape (n_cells,)

    Returns
    -------
    dict of name -> ndarray, shape (m, K, n_cells)
        Each sector's value as if it were a cell of volume V / K.
    """
    m, n, k, c = sums.shape
    flat = np.moveaxis(sums, 2, 1).reshape(m * k, n, c) * k
    return {q: v.reshape(m, k, n)
            for q, v in block_values(flat, V, rho_p, groups, layout).items()}


def frozen_correlation(first, second, periodic=True):
    """Correlation of a quantity's frozen part between sectors ``lag`` apart.

    The sectors' deviations from their cell's mean in the two halves of the window
    share the frozen structure but not (for halves longer than the correlation time)
    the time-varying noise, so their cross products measure the frozen part alone.

    Parameters
    ----------
    first, second : ndarray, shape (K, n_cells)
        One quantity's value per (fine) sector and cell, averaged over each half.
    periodic : bool
        Sectors close on themselves (rings) or not (segments of a slab).

    Returns
    -------
    corr : ndarray, shape (K // 2 + 1,)
        corr[l]: the frozen cross-covariance at lag l over that at lag 0, corrected by
        1/(K-1) for the subtracted mean (0 for independent sectors, corr[0] = 1); NaN
        where the frozen part is not detected (lag-0 covariance below 3 se).
    se : float
        The standard error of corr[l] for independent sectors.
    frozen : float
        The frozen part's share of the sectors' variance (lag-0 covariance).
    """
    a, b = np.asarray(first, float), np.asarray(second, float)
    k = a.shape[0]
    lags = k // 2 + 1
    ok = np.all(np.isfinite(a) & np.isfinite(b), axis=0)
    da, db = a[:, ok] - a[:, ok].mean(axis=0), b[:, ok] - b[:, ok].mean(axis=0)
    scale = np.sqrt(np.sqrt(np.mean(da**2, axis=0) * np.mean(db**2, axis=0)))
    keep = scale > 0
    nan = np.full(lags, np.nan)
    if k < 3 or not np.any(keep):
        return nan, float("nan"), float("nan")
    da, db = da[:, keep] / scale[keep], db[:, keep] / scale[keep]
    cov = np.empty(lags)
    for lag in range(lags):
        if periodic:
            cov[lag] = 0.5 * np.mean(da * np.roll(db, -lag, 0) + db * np.roll(da, -lag, 0))
        else:
            cov[lag] = 0.5 * np.mean(da[:k - lag] * db[lag:] + db[:k - lag] * da[lag:])
    se = 1.0 / math.sqrt(da.size)
    if not cov[0] > 3 * se:
        return nan, float("nan"), float(cov[0])
    corr = cov / cov[0] + np.r_[0.0, np.full(lags - 1, 1.0 / (k - 1))]
    return corr, float(se / cov[0]), float(cov[0])


def adjacent_correlation(corr, se, m):
    """Correlation of adjacent sectors of ``m`` fine sectors each, predicted from the fine
    correlation (used up to the first lag where it is within 2 se of zero):
    sum_l min(l, 2m - l) c_l / (m + 2 sum_l (m - l) c_l)."""
    c = np.where(np.isfinite(corr), corr, 0.0)
    small = np.flatnonzero(c[1:] < 2 * se)
    window = int(small[0]) if len(small) else len(c) - 1      # lags 1..window count
    c = np.r_[c[:window + 1], np.zeros(max(0, 2 * m - window))]
    lags = np.arange(1, 2 * m)
    cov = np.sum(np.minimum(lags, 2 * m - lags) * c[lags])
    var = m + 2 * np.sum((m - lags[:m - 1]) * c[1:m])
    return float(cov / var)


def choose_sectors(first, second, V, rho_p, groups, layout, periodic=True,
                   fine=FINE_SECTORS, exclude=()):
    """How many sectors each quantity's frozen structure allows, from the data.

    The frozen part's correlation between fine sectors (:func:`frozen_correlation`)
    gives, for each candidate K, the correlation of adjacent sectors
    (:func:`adjacent_correlation`). A quantity takes the most sectors for which it stays
    below :data:`RHO_MAX`; one whose frozen part is not detected takes ``fine`` (its
    time-varying part is counted by the time blocking). The replicas of derived numbers
    take the fewest sectors among the quantities whose frozen part is at least half of
    the sectors' variance (:data:`FROZEN_SHARE`). The quantities named in ``exclude``
    (:func:`~granavg.engine.quantities.balanced_names`) take no part.

    Parameters
    ----------
    first, second : ndarray, shape (n_cells, K_fine, n_channels)
        Mean sector sums per frame over the two halves of the window.

    Returns
    -------
    per_quantity : dict of name -> int
        The sectors of each quantity's profile errors.
    common : int
        The sectors of the replicates (derived numbers).
    unresolved : list of str
        Quantities correlated even at :data:`MIN_REPLICAS` sectors (given that many;
        their errors may be too small).
    table : dict
        ``{K: {quantity: predicted adjacent correlation}}``; ``"fine"``: each quantity's
        frozen correlation at lags 1, 2, ... fine sectors; ``"frozen_share"``: its frozen
        part's share of the fine sectors' variance.
    """
    halves = [sector_values(h[None], V, rho_p, groups, layout) for h in (first, second)]
    measured = {q: frozen_correlation(halves[0][q][0], halves[1][q][0], periodic)
                for q in halves[0] if q not in exclude}
    share = {q: f for q, (_, _, f) in measured.items() if np.isfinite(f)}
    table = {"frozen_share": {q: round(f, 3) for q, f in share.items()},
             "fine": {q: [round(float(x), 3) for x in c[1:]]
                      for q, (c, _, _) in measured.items() if np.isfinite(c[1])}}
    candidates = [c for c in CANDIDATES if fine % c == 0 and c <= fine]
    per_quantity, unresolved = {q: fine for q in measured}, []
    for q, (c, se, _) in measured.items():
        if not np.isfinite(c[1]):
            continue
        rows = {k: adjacent_correlation(c, se, fine // k) for k in candidates}
        for k, r in rows.items():
            table.setdefault(k, {})[q] = round(r, 4)
        ok = [k for k, r in rows.items() if r < RHO_MAX]
        per_quantity[q] = max(ok) if ok else MIN_REPLICAS
        if not ok:
            unresolved.append(q)
    frozen = [per_quantity[q] for q, f in share.items() if f >= FROZEN_SHARE]
    return per_quantity, min(frozen, default=fine), unresolved, table


def structure_parts(counts, sums, V, rho_p, groups, layout, evaluate):
    """Replicate profiles of the sectors and of the sector x time-block interaction.

    Parameters
    ----------
    counts : ndarray, shape (B0,)
        Frames per time block of the replica accumulator.
    sums : ndarray, shape (B0, n_cells, K, n_channels)
        Summed sector sums per time block.
    evaluate : callable
        Mean cell sums (m, n_cells, n_channels) -> dict name -> (m, n_cells) values.

    Returns
    -------
    sectors : dict of name -> ndarray, shape (K, n_cells)
        Delete-one-sector profiles (the other sectors over the whole window).
    cells : dict of name -> ndarray, shape (K B, n_cells)
        The profile plus the interaction residual of one (sector, block) scaled by
        1/sqrt(K B) each; see :func:`interaction_variance`.
    shape : tuple
        (K, B): sectors and time blocks of the two-way table.
    """
    counts, sums = np.asarray(counts, float), np.asarray(sums, float)
    k = sums.shape[2]
    total = sums.sum(axis=0) / counts.sum()                       # (n, K, C)
    rest = (total.sum(axis=1)[None] - np.moveaxis(total, 1, 0)) * (k / (k - 1))
    sectors = evaluate(rest)
    levels = [(c, s) for c, s in merge_levels(counts, sums) if len(c) * k <= MAX_CELLS
              and len(c) >= 2]
    usable = [lv for lv in levels if len(lv[0]) >= 8] or levels
    if not usable:
        return sectors, {}, (k, 0)
    c, s = usable[0]
    b = len(c)
    x = sector_values(s / c[:, None, None, None], V, rho_p, groups, layout)   # (B, K, n)
    full = evaluate(total.sum(axis=1)[None])
    cells = {}
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN (empty) cells
        for q, v in x.items():
            r = (v - np.nanmean(v, axis=0, keepdims=True) - np.nanmean(v, axis=1, keepdims=True)
                 + np.nanmean(v, axis=(0, 1), keepdims=True))
            cells[q] = full[q] + r.reshape(b * k, -1) / math.sqrt(k * b)
    return sectors, cells, (k, b)


def structure_errors(counts, sums, V, rho_p, groups, layout, sem_time, jackknife, *,
                     sectors="auto", periodic=True, across="r", replicas=None):
    """Errors that count the frozen structure, from the sectors of every cell.

    Parameters
    ----------
    counts, sums : ndarray, shapes (B0,) and (B0, n_cells, K_fine, n_channels)
        The replica accumulator's blocks.
    sem_time : dict of name -> ndarray (n_cells,)
        The cells' time-blocking errors.
    jackknife : Replicates
        The cells' delete-one-block replicates (kind ``jackknife``).
    sectors : "auto" or int
        Choose K from the data (:func:`choose_sectors`: per quantity for its profile
        errors, one K for the replicates), or this K for all (a divisor of the K_fine
        accumulated).
    periodic : bool
        The sectors close on themselves (rings).
    layout : Layout
        The channels (:mod:`granavg.engine.channels`).
    across : str
        The direction across the cells, one of the layout's axes ("r" for rings, the
        slabs' axis), for :func:`~granavg.engine.quantities.balanced_names`.
    replicas : int, optional
        With ``sectors="auto"``: this K for the replicates (and the quantities without
        their own), not the one chosen from the data: another average's over the same
        frames (a mixture's species, whose replicates then pair with the whole's).

    Returns
    -------
    sem : dict of name -> ndarray (n_cells,)
        :func:`~granavg.engine.uncertainty.blocking.combine_errors` of the three parts; the time
        part alone for the components the balance of forces fixes in a whole cell.
    replicates : Replicates
        Kind ``structure``: the sectors, the time blocks, the interaction cells, for
        every quantity (a balance law's residual takes the time blocks alone:
        :meth:`~granavg.engine.uncertainty.blocking.Replicates.in_time`).
    info : dict
        For the sidecar: K (common and per quantity), how it was chosen, the frozen
        structure's correlations and share, the two-way table's shape, the unresolved
        and the time-only quantities.
    time_dominated : dict of name -> ndarray of bool (n_cells,)
        Where the time part is the larger (there a time lower bound still matters).
    """
    evaluate = lambda m: block_values(m, V, rho_p, groups, layout)          # noqa: E731
    fine = sums.shape[2]
    balanced = balanced_names(groups, layout.axes, across)
    if sectors == "auto":
        per_q, common, unresolved, table = choose_sectors(*halves(counts, sums), V, rho_p,
                                                          groups, layout, periodic, fine,
                                                          balanced)
        if replicas is not None and fine % int(replicas) == 0:
            common = int(replicas)
    elif fine % int(sectors) == 0:
        per_q, common, unresolved, table = {}, int(sectors), [], {}
    else:
        raise ParameterError("sectors", f"{{param}} {sectors}: must divide the "
                             f"{fine} sectors accumulated")
    parts = {common: structure_parts(counts, merge_sectors(sums, common), V, rho_p, groups,
                                     layout, evaluate)}
    sem, time_dominated, b = {}, {}, parts[common][2][1]
    for q in parts[common][0]:
        k = per_q.get(q, common)
        if k not in parts:
            parts[k] = structure_parts(counts, merge_sectors(sums, k), V, rho_p, groups,
                                       layout, evaluate)
        by_sector, cells, (_, bk) = parts[k]
        vs = np.array([jackknife_error(v) ** 2 for v in by_sector[q].T])
        vi = (np.array([interaction_variance(c, k, bk) for c in cells[q].T]) if cells
              else np.full(len(V), np.nan))
        sem[q] = sem_time[q] if q in balanced else combine_errors(vs, sem_time[q] ** 2, vi)
        time_dominated[q] = ~(vs >= sem_time[q] ** 2) | (q in balanced)
    by_sector, cells, _ = parts[common]
    # every quantity's sectors stay in the replicates, so that numbers of several
    # quantities that vary together in a packing (sigma / eps) vary together in them
    reps = Replicates("structure", {q: np.concatenate([by_sector[q], jackknife.values[q],
                                                       cells.get(q, np.zeros((0, len(V))))])
                                    for q in by_sector},
                      {"sectors": common, "blocks": jackknife.n, "cells": [common, b]})
    info = {"sectors": int(common), "chosen": "auto" if sectors == "auto" else "pinned",
            "resolved": not [q for q in unresolved
                             if table["frozen_share"].get(q, 0) >= FROZEN_SHARE],
            "two_way_blocks": int(b),
            "per_quantity": {q: int(k) for q, k in per_q.items() if q not in balanced},
            "unresolved": sorted(unresolved), "time_only": sorted(balanced & set(sem)),
            "neighbour_correlation_by_k": {str(k): t for k, t in table.items()
                                           if isinstance(k, int)},
            "fine_sector_correlation": table.get("fine", {}),
            "frozen_share": table.get("frozen_share", {})}
    return sem, reps, info, time_dominated


def halves(counts, sums):
    """Mean sums per frame over the first and the second half of the window's frames
    (whole blocks), shapes (n_cells, K, n_channels); the whole window twice if it holds
    a single block."""
    counts = np.asarray(counts, float)
    cut = int(np.searchsorted(np.cumsum(counts), counts.sum() / 2.0)) + 1
    cut = min(max(cut, 1), len(counts) - 1) if len(counts) > 1 else 1
    parts = [(counts[:cut], sums[:cut]), (counts[cut:], sums[cut:])] if len(counts) > 1 \
        else [(counts, sums)] * 2
    return tuple(s.sum(axis=0) / c.sum() for c, s in parts)

