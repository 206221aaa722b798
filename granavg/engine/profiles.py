"""From time-averaged ring sums to ring profiles (Eqs. 2-7), with standard errors.

Values come from the sums averaged over all frames (:mod:`granavg.engine.accumulate`):
ratios such as v = <nu v>/<nu> and eps = <sum Delta l> <F>^-1 are taken of the averages,
not averaged per frame. The standard error of every value is the spread of the same
value computed per time block, by blocking analysis (:mod:`granavg.engine.uncertainty.blocking`): blocks
are merged until they are long against the correlation time, and where that is not
reached the error is flagged as a lower bound.

Columns (SI units; docs/profiles.md): ``nu`` (-), ``rho`` (kg/m^3), ``v_r``, ``v_phi``
(m/s), ``omega`` (rad/s), ``coordination`` (-), ``F_*`` (-), ``sigma_*`` (Pa),
``dsigma_*`` (Pa), ``dsigma_fluct_*`` (Pa), ``eps_*`` (-), ``boundary_r``,
``boundary_phi`` (the force density that walls exert on the packing, N/m^3),
``body_r``, ``body_phi`` (body forces: gravity, base-plate friction, ..., N/m^3), each
with ``<name>_sem``; tensor components ``rr, rphi, phir, phiphi`` in each particle's
polar basis.
"""

from __future__ import annotations

import numpy as np

from granavg.engine.channels import CONTACT_BLOCKS, Layout, stacked
from granavg.engine.quantities import QUANTITIES
from granavg.engine.uncertainty.blocking import Replicates, blocking_errors, jackknife_sums


def values(S: np.ndarray, V: np.ndarray, rho_p: float, groups, layout: Layout) -> dict:
    """Profile values from mean cell sums: each quantity's own
    (:attr:`~granavg.engine.quantities.Quantity.value`).

    Parameters
    ----------
    S : ndarray, shape (n_cells, layout.n)
        Cell sums averaged over frames.
    V : ndarray, shape (n_cells,)
        Cell volumes.
    rho_p : float
        Material density (the masses are in the sums already).
    groups : iterable of str
        Keys of :data:`granavg.engine.quantities.QUANTITIES`.
    layout : Layout
        The channels, in the cells' basis (:mod:`granavg.engine.channels`).

    Returns
    -------
    dict of str -> ndarray, shape (n_cells,)
        Named in the cells' basis (:func:`granavg.engine.quantities.columns`); NaN where
        a value is undefined (no particle in the cell; singular fabric).
    """
    out = {}
    with np.errstate(invalid="ignore", divide="ignore"):
        for g in groups:
            out.update(QUANTITIES[g].value(S, V, layout))
    return out


def flags(S: np.ndarray, groups, layout: Layout) -> np.ndarray:
    """Per-cell flags (';'-joined): ``empty`` (no particle), ``no_contacts``, and each
    quantity's own (``singular_fabric``: eps undefined);
    :class:`~granavg.engine.cell_average.CellAverage` adds ``one_block`` when the frames span a
    single time block (no standard errors)."""
    vol = S[:, layout.index["vol"]]
    contact = any(QUANTITIES[g].contacts and g != "boundary" for g in groups)
    contact_sums = stacked(S, layout, CONTACT_BLOCKS)
    empty = ~(vol > 0)
    named = [("empty", empty)]
    if contact:
        named.append(("no_contacts", ~empty & ~np.any(contact_sums != 0, axis=1)))
    named += [(QUANTITIES[g].flag_name, np.asarray(QUANTITIES[g].flag(S, layout), bool))
              for g in groups if QUANTITIES[g].flag is not None]
    out = np.full(S.shape[0], "", dtype=object)
    for name, flagged in named:
        where = np.flatnonzero(flagged)
        out[where] = [f"{o};{name}" if o else name for o in out[where]]
    return out


def block_values(mean_sums, V, rho_p, groups, layout: Layout) -> dict:
    """Profile values of many blocks at once.

    Parameters
    ----------
    mean_sums : ndarray, shape (m, n_cells, n_channels)
        Mean cell sums of m blocks (or replicates).

    Returns
    -------
    dict of name -> ndarray, shape (m, n_cells)
    """
    m, n = mean_sums.shape[:2]
    flat = values(mean_sums.reshape(m * n, -1), np.tile(V, m), rho_p, groups, layout)
    return {k: v.reshape(m, n) for k, v in flat.items()}


def standard_errors(counts, sums, V, rho_p, groups, layout: Layout):
    """Standard errors of every value by blocking analysis (:mod:`granavg.engine.uncertainty.blocking`).

    Parameters
    ----------
    counts : ndarray, shape (n_blocks,)
        Frames in each time block.
    sums : ndarray, shape (n_blocks, n_cells, n_channels)
        Summed cell sums of each block.

    Returns
    -------
    sem : dict of name -> ndarray (n_cells,)
        NaN with fewer than two blocks.
    lower_bound : dict of name -> ndarray of bool (n_cells,)
        True where the blocking analysis reached no plateau (the error is a lower bound).
    replicates : Replicates or None
        Delete-one-block jackknife profiles (None with fewer than two blocks).
    """
    evaluate = lambda m: block_values(m, V, rho_p, groups, layout)      # noqa: E731
    if len(counts) < 2:
        names = list(values(np.zeros((len(V), layout.n)), V, rho_p, groups, layout))
        nan = {n: np.full(len(V), np.nan) for n in names}
        return nan, {n: np.ones(len(V), bool) for n in names}, None
    sem, lower = blocking_errors(counts, sums, evaluate)
    return sem, lower, Replicates("jackknife", evaluate(jackknife_sums(counts, sums)))
