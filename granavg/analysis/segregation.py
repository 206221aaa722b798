"""The paper's mixture in the shear cell: where the large disks are and how each species
shears (docs/species.md).

From ring fields split by species (``species="type"``: type 1 the small disks, type 2
the large ones in granavg's Couette runs):

- the large disks' concentration c = nu_large / nu across the cell;
- their share of the disks' area in the shear band (r - R_i < :data:`BAND_WIDTHS`
  times the mixture's band width s) and beyond it, sum V nu_large / sum V nu over those
  rings, and the band's excess over the rest: the band **segregates** where the excess
  exceeds :data:`SIGNIFICANCE` standard errors (more large disks in the band), is
  **depleted** where it falls below minus that, and no segregation is resolved
  otherwise - a claim that can fail either way;
- each species' shear band: granavg's estimator (:mod:`granavg.analysis.shear_band`) on
  its own v_phi, with its error from the same fit on every replicate.

Every error comes from the replicates of the species and of the whole on the same parts
of the data (the realisations of an ensemble, or one run's sectors and time blocks), so
the covariance of a share and its whole counts.
"""

from __future__ import annotations

import numpy as np

from granavg.analysis import shear_band as sb
from granavg.errors import ParameterError, UserError

#: The band region: rings with r - R_i below this many band widths s.
BAND_WIDTHS = 2.0
#: The excess must exceed this many standard errors to be a verdict.
SIGNIFICANCE = 2.0
#: granavg's Couette runs: the atom types of the small and the large disks.
SMALL, LARGE = "type1", "type2"


def _share(nu_large, nu, V, where):
    """sum V nu_large / sum V nu over the rings ``where`` (last axis), per replicate."""
    return np.nansum(V[where] * nu_large[..., where], axis=-1) / \
        np.nansum(V[where] * nu[..., where], axis=-1)


def _replicated(part, whole, names):
    """The replicates of ``part`` and ``whole`` (the same parts of the data), or None."""
    r, w = part.replicates, whole.replicates
    if r is None or w is None or isinstance(r, list) or r.kind != w.kind or r.n != w.n \
            or not all(n in r.values and n in w.values for n in names):
        return None
    return r, w


def segregation(fields, R_i: float, d_layer: float, Omega: float, s_band: float) -> dict:
    """The mixture's segregation and each species' band (module docstring).

    Parameters
    ----------
    fields : Fields
        Ring fields with a species axis holding :data:`SMALL` and :data:`LARGE`.
    R_i, d_layer, Omega : float
        The inner wall's radius (m), the mean diameter (m), its angular velocity (rad/s).
    s_band : float
        The mixture's band width s (m).
    """
    if fields.species is None or not {SMALL, LARGE} <= set(fields.species):
        raise ParameterError("species", f"the mixture's analysis needs ring fields split "
                             f"by type ({SMALL}, {LARGE}): average with {{param}} type")
    whole, large = fields.of("all"), fields.of(LARGE)
    r = np.asarray(fields.cells.coordinates()["r"], float)
    V = np.asarray(fields.cells.volume, float)
    band = (r - R_i) < BAND_WIDTHS * s_band
    rest = ~band
    if band.sum() < 1 or rest.sum() < 1:
        raise UserError("the rings do not reach both into the band and beyond it")
    nu_l, nu = np.asarray(large.values["nu"]), np.asarray(whole.values["nu"])
    c_band, c_rest = float(_share(nu_l, nu, V, band)), float(_share(nu_l, nu, V, rest))
    err = {k: float("nan") for k in ("band", "rest", "excess")}
    reps = _replicated(large, whole, ("nu",))
    if reps is not None:
        rl, rw = reps
        b = _share(rl.values["nu"], rw.values["nu"], V, band)
        o = _share(rl.values["nu"], rw.values["nu"], V, rest)
        err = {"band": rl.error(b), "rest": rl.error(o), "excess": rl.error(b - o)}
    excess = c_band - c_rest
    if not np.isfinite(err["excess"]) or err["excess"] <= 0:
        verdict = "inconclusive"
    elif excess > SIGNIFICANCE * err["excess"]:
        verdict = "segregates"
    elif excess < -SIGNIFICANCE * err["excess"]:
        verdict = "depleted"
    else:
        verdict = "no segregation resolved"
    bands = {s: _band(fields.of(s), r, R_i, d_layer, Omega) for s in (SMALL, LARGE)}
    return {"r_m": r.tolist(), "band_rings": int(band.sum()), "s_band_m": s_band,
            "c_large": np.asarray(large.values["c"], float).tolist(),
            "c_large_err": np.asarray(large.sem["c"], float).tolist(),
            "v_phi": {s: np.asarray(fields.of(s).values["v_phi"], float).tolist()
                      for s in (SMALL, LARGE, "all")},
            "v_phi_err": {s: np.asarray(fields.of(s).sem["v_phi"], float).tolist()
                          for s in (SMALL, LARGE, "all")},
            "c_band": c_band, "c_rest": c_rest, "excess": excess, "errors": err,
            "verdict": verdict, "bands": bands,
            "claim": {"claim": "the shear band segregates: more large disks in the band "
                               f"(r - R_i < {BAND_WIDTHS:g} s) than beyond it",
                      "kind": "measured", "verdict": verdict,
                      "tolerance": f"{SIGNIFICANCE:g} standard errors of the excess",
                      "evidence": f"large disks' area share {c_band:.3f} +- "
                                  f"{err['band']:.3f} in the band, {c_rest:.3f} +- "
                                  f"{err['rest']:.3f} beyond; excess {excess:+.3f} +- "
                                  f"{err['excess']:.3f}"}}


def _band(part, r, R_i, d_layer, Omega) -> dict:
    """One species' band by granavg's estimator, with the error of the same fit on its
    replicates (NaN where it cannot fit)."""
    v, sem = np.asarray(part.values["v_phi"], float), np.asarray(part.sem["v_phi"], float)
    try:
        fit = sb.fit_band(r, v, sem, R_i, d_layer, Omega)
    except UserError as exc:
        return {"s_m": float("nan"), "v0": float("nan"), "why": str(exc)}
    out = {"s_m": fit.s, "v0": fit.v0, "s_err": float("nan"), "v0_err": float("nan")}
    reps = part.replicates
    if reps is not None and not isinstance(reps, list) and "v_phi" in reps.values:
        s, v0 = [], []
        for row in reps.values["v_phi"]:
            try:
                one = sb.refit(fit, r, row, R_i, Omega)
            except UserError:
                one = None
            s.append(one.s if one else np.nan)
            v0.append(one.v0 if one else np.nan)
        out.update(s_err=reps.error(np.array(s)), v0_err=reps.error(np.array(v0)))
    return out


def segregation_panels(result: dict, R_i: float, ax=None):
    """The large disks' concentration across the cell, the band region shaded, and each
    species' v_phi (log scale), with error bars. Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(1, 2, figsize=(9.6, 3.6), constrained_layout=True)
    x = (np.asarray(result["r_m"]) - R_i) * 1e3
    ax[0].errorbar(x, result["c_large"], yerr=result["c_large_err"], marker="o", ms=3)
    ax[0].axvspan(0, BAND_WIDTHS * result["s_band_m"] * 1e3, color="0.9", zorder=0,
                  label=f"band: r - R_i < {BAND_WIDTHS:g} s")
    ax[0].axhline(result["c_rest"], ls=":", color="0.4", label="beyond the band")
    ax[0].set(xlabel="r - R_i (mm)", ylabel="c of the large disks (nu_large / nu)")
    ax[0].legend(fontsize=8)
    for s, label in ((SMALL, "small"), (LARGE, "large"), ("all", "all")):
        v = np.asarray(result["v_phi"][s])
        ok = v > 0
        ax[1].errorbar(x[ok], v[ok], yerr=np.asarray(result["v_phi_err"][s])[ok], marker="o",
                       ms=3, label=label)
    ax[1].set(xlabel="r - R_i (mm)", ylabel="v_phi (m/s)", yscale="log")
    ax[1].legend(fontsize=8)
    return ax
