"""From time-averaged ring sums to ring profiles (Eqs. 2-7), with standard errors.

Values come from the sums averaged over all frames (:mod:`granavg.engine.accumulate`):
ratios such as v = <nu v>/<nu> and eps = <sum Delta l> <F>^-1 are taken of the averages,
not averaged per frame. The standard error of every value is the spread of the same
value computed per time block, by blocking analysis (:mod:`granavg.engine.uncertainty`): blocks
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

from dataclasses import dataclass, field

from typing import TYPE_CHECKING

import numpy as np

from granavg.engine.kernels import INDEX
from granavg.engine.quantities import TENSOR
from granavg.engine.geometry import Rings
from granavg.engine.uncertainty import Replicates, blocking_errors, jackknife_sums

if TYPE_CHECKING:
    import pandas as pd


@dataclass
class Profiles:
    """Time-averaged profiles over cells (rings, slabs or a grid) and their standard errors,
    in the frames' units (SI for granavg's runs).

    Attributes
    ----------
    rings : Rings, Slabs or Grid
        The cells (:mod:`granavg.engine.geometry`).
    values, sem : dict of name -> ndarray, shape (n_rings,)
        Values and standard errors (blocking analysis for one run, between-run for an
        ensemble).
    flags : ndarray of str, shape (n_rings,)
    n_frames : int
    meta : dict
        The JSON sidecar (``meta["errors"]`` says how the errors were made and where
        they are only lower bounds).
    replicates : Replicates, optional
        Profiles on parts of the data (jackknife blocks, or one per realisation): the
        errors of derived numbers (fits, maxima) come from them.
    n_runs : ndarray, optional
        Realisations with a finite value per ring (ensembles only), shape (n_rings,).
    timeseries : DataFrame, optional
        The state of every frame read (:mod:`granavg.engine.timeseries`), written as
        ``<path>.timeseries.csv``; ``meta["stationarity"]`` judges the averaging window.
    """

    rings: Rings
    values: dict
    sem: dict
    flags: np.ndarray
    n_frames: int
    meta: dict = field(default_factory=dict)
    replicates: Replicates | None = None
    n_runs: np.ndarray | None = None
    timeseries: pd.DataFrame | None = None

    def to_frame(self) -> pd.DataFrame:
        """One row per cell: its coordinates (r_lo, r_hi, r for rings), V, n_frames, each
        value and ``<name>_sem``, flags."""
        import pandas as pd

        cols = {**self.rings.coordinates(), "V": self.rings.volume,
                "n_frames": np.full(self.rings.n, self.n_frames)}
        if self.n_runs is not None:
            cols["n_runs"] = self.n_runs
        for name, v in self.values.items():
            cols[name], cols[f"{name}_sem"] = v, self.sem[name]
        cols["flags"] = self.flags
        return pd.DataFrame(cols)


def values(S: np.ndarray, V: np.ndarray, rho_p: float, groups) -> dict:
    """Profile values from mean ring sums.

    Parameters
    ----------
    S : ndarray, shape (n_rings, n_channels)
        Ring sums averaged over frames.
    V : ndarray, shape (n_rings,)
        Ring volumes pi h (r_hi^2 - r_lo^2), m^3.
    rho_p : float
        Material density, kg/m^3.
    groups : iterable of str
        Keys of :data:`QUANTITIES`.

    Returns
    -------
    dict of str -> ndarray, shape (n_rings,)
        NaN where a value is undefined (no disk in the ring; singular fabric).
    """
    col = {name: S[:, k] for name, k in INDEX.items()}
    vol = col["vol"]
    with np.errstate(invalid="ignore", divide="ignore"):
        inv_vol = np.where(vol > 0, 1.0 / vol, np.nan)
        out = {}
        for g in groups:
            if g == "nu":
                out["nu"] = vol / V
            elif g == "rho":
                out["rho"] = col["mass"] / V
            elif g == "v":
                out["v_r"], out["v_phi"] = col["mom_r"] * inv_vol, col["mom_phi"] * inv_vol
            elif g == "omega":
                out["omega"] = col["spin"] * inv_vol
            elif g == "coordination":
                out["coordination"] = col["ncontact"] * inv_vol
            elif g in ("F", "sigma", "dsigma"):
                first = {"F": "fab_rr", "sigma": "sig_rr", "dsigma": "kin_rr"}[g]
                for c in TENSOR:
                    out[f"{g}_{c}"] = S[:, INDEX[first] + TENSOR.index(c)] / V
            elif g == "dsigma_fluct":
                mean = (col["mom_r"], col["mom_phi"])
                for i, c in enumerate(TENSOR):
                    a, b = mean[i // 2], mean[i % 2]
                    mean_flow = col["mass"] * a * b * inv_vol * inv_vol   # rho v v
                    out[f"dsigma_fluct_{c}"] = (S[:, INDEX["kin_rr"] + i] - mean_flow) / V
            elif g == "eps":
                out.update(_eps(S))
            elif g in ("boundary", "body"):
                first = "wall_r" if g == "boundary" else "body_r"
                out[f"{g}_r"] = S[:, INDEX[first]] / V
                out[f"{g}_phi"] = S[:, INDEX[first] + 1] / V
    return out


def _eps(S):
    """eps = (pi h sum Delta (x) l) . (V^-1 sum V^p n (x) n)^-1 ... per ring (Eq. 7)."""
    fab = S[:, INDEX["fab_rr"]:INDEX["fab_rr"] + 4].reshape(-1, 2, 2)
    dfm = S[:, INDEX["def_rr"]:INDEX["def_rr"] + 4].reshape(-1, 2, 2)
    det = np.linalg.det(fab)
    scale = np.einsum("kij,kij->k", fab, fab)
    ok = np.abs(det) > 1e-12 * scale
    eps = np.full(dfm.shape, np.nan)
    if np.any(ok):
        eps[ok] = dfm[ok] @ np.linalg.inv(fab[ok])
    return {f"eps_{c}": eps.reshape(-1, 4)[:, k] for k, c in enumerate(TENSOR)}


def flags(S: np.ndarray, groups) -> np.ndarray:
    """Per-ring flags (';'-joined): ``empty`` (no disk), ``no_contacts``,
    ``singular_fabric`` (eps undefined); :class:`~granavg.engine.average.CellAverage` adds
    ``one_block`` when the frames span a single time block (no standard errors)."""
    out = [[] for _ in range(S.shape[0])]
    vol = S[:, INDEX["vol"]]
    contact = {"coordination", "F", "sigma", "eps"} & set(groups)
    fab = S[:, INDEX["fab_rr"]:INDEX["fab_rr"] + 4].reshape(-1, 2, 2)
    contact_channels = [INDEX["ncontact"], *(INDEX[p] + i for p in ("fab_rr", "sig_rr", "def_rr")
                                              for i in range(4))]
    for k in range(S.shape[0]):
        if not vol[k] > 0:
            out[k].append("empty")
        if contact and vol[k] > 0 and not np.any(S[k, contact_channels] != 0):
            out[k].append("no_contacts")
        if "eps" in groups:
            det, scale = np.linalg.det(fab[k]), np.sum(fab[k] ** 2)
            if not abs(det) > 1e-12 * scale:
                out[k].append("singular_fabric")
    return np.array([";".join(f) for f in out], dtype=object)


def block_values(mean_sums, V, rho_p, groups) -> dict:
    """Profile values of many blocks at once.

    Parameters
    ----------
    mean_sums : ndarray, shape (m, n_rings, n_channels)
        Mean ring sums of m blocks (or replicates).

    Returns
    -------
    dict of name -> ndarray, shape (m, n_rings)
    """
    m, n = mean_sums.shape[:2]
    flat = values(mean_sums.reshape(m * n, -1), np.tile(V, m), rho_p, groups)
    return {k: v.reshape(m, n) for k, v in flat.items()}


def standard_errors(counts, sums, V, rho_p, groups):
    """Standard errors of every value by blocking analysis (:mod:`granavg.engine.uncertainty`).

    Parameters
    ----------
    counts : ndarray, shape (n_blocks,)
        Frames in each time block.
    sums : ndarray, shape (n_blocks, n_rings, n_channels)
        Summed ring sums of each block.

    Returns
    -------
    sem : dict of name -> ndarray (n_rings,)
        NaN with fewer than two blocks.
    lower_bound : dict of name -> ndarray of bool (n_rings,)
        True where the blocking analysis reached no plateau (the error is a lower bound).
    replicates : Replicates or None
        Delete-one-block jackknife profiles (None with fewer than two blocks).
    """
    evaluate = lambda m: block_values(m, V, rho_p, groups)      # noqa: E731
    if len(counts) < 2:
        names = list(values(np.zeros((len(V), len(INDEX))), V, rho_p, groups))
        nan = {n: np.full(len(V), np.nan) for n in names}
        return nan, {n: np.ones(len(V), bool) for n in names}, None
    sem, lower = blocking_errors(counts, sums, evaluate)
    return sem, lower, Replicates("jackknife", evaluate(jackknife_sums(counts, sums)))
