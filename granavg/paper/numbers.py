"""The numbers the paper's claims decide on, from coarse and fine ring profiles (Figs.
2-9), each a plain function of the profiles (a replicate's view too, for its error):
the shear band, the density, the fabric, the stresses' exponents, the stiffnesses, the
master curve, the orientations, the equations of motion, the spins' and the power
balance; and the per-ring profiles the figures derive from them."""

from __future__ import annotations

import logging
import os

import numpy as np

from granavg.analysis import continuum as c
from granavg.analysis import shear_band as sb_fit
from granavg.analysis.continuum import angle_diff, tensor
from granavg.analysis.rheology import scene_diameter
from granavg.analysis.balance import FORCE_DENSITIES, residuals, stress_scale
from granavg.analysis.rounding import plain, pm
from granavg.analysis.spin_balance import (ARMS, branch_reach, moment_density,
                                           spin_balance, spin_residuals)
from granavg.engine.kernels import BRANCHES
from granavg.errors import UserError
from granavg.engine.quantities import TENSOR
from granavg.engine.stationarity import ensemble_stationarity
from granavg.paper.verdicts import ESTIMATOR_TEXT, PAPER, both, bulk, verdict

log = logging.getLogger(__name__)

def derived_profiles(p, k_n) -> dict:
    """The per-ring profiles the figures derive from a profile (or a replicate's view):
    tr F, the anisotropy, the stiffnesses 2 pi E / k_n and pi G / k_n (``k_n`` the
    normal spring), the major axes' orientations (deg), the residuals of the equations
    of motion over the stress scale, D_rphi, W_rphi and omega*."""
    F = tensor(p, "F")
    B, G = c.stiffness(tensor(p, "sigma"), tensor(p, "eps"), k_n)
    out = {"trF": c.trace(F), "anisotropy": c.deviator_norm(F) / c.trace(F), "B": B, "G": G}
    for q in ("F", "sigma", "eps"):
        out[f"orientation_{q}"] = np.degrees(c.orientation(tensor(p, q)))
    st, tot, scale = eom(p)
    for j, comp in enumerate(("r", "phi")):
        out[f"eom_static_{comp}"], out[f"eom_total_{comp}"] = st[j] / scale, tot[j] / scale
    D, W = c.deformation_rate_and_spin(p.cells.centre, p.values["v_phi"])
    out.update({"D": D, "W": W, "omega_star": c.eigen_rotation(p.values["omega"], W)})
    return out


def derived_errors(est, k_n) -> list:
    """Per-ring errors of :func:`derived_profiles` of the coarse and the fine profile,
    from the replicates (empty dicts without); orientations as the replicates' turns
    from the profile's own axes (wrapped into +-90 deg)."""
    if not est.views:
        return [{}, {}]
    out = []
    for i, p in enumerate((est.p20, est.p60)):
        own = derived_profiles(p, k_n)
        reps = []
        for views in est.views:
            with np.errstate(invalid="ignore", divide="ignore"):
                reps.append(derived_profiles(views[i], k_n))
        errs = {}
        for k, v in own.items():
            x = np.array([r[k] for r in reps])
            if k.startswith("orientation_"):
                x = angle_diff(x, v[None])
            errs[k] = np.array([est.replicates.error(x[:, j]) for j in range(x.shape[1])])
        out.append(errs)
    return out


def runs_by_name(runs):
    """An ensemble's runs named relative to the directory that holds them all (the
    summary names no path of the machine that made it)."""
    if not runs:
        return runs
    paths = [os.path.abspath(r["run"]) for r in runs]
    root = os.path.dirname(os.path.commonpath(paths)) if len(paths) == 1 else \
        os.path.commonpath(paths)
    return [{**r, "run": os.path.relpath(p, root)} for r, p in zip(runs, paths)]


class SceneNumbers:
    """The scene's numbers the analysis needs (SI units)."""

    def __init__(self, scene):
        self.R_i, self.R_o, self.Omega = scene["R_i"], scene["R_o"], scene["Omega"]
        self.k_n, self.h = scene["k_n"], scene["h"]
        self.d_mean = scene_diameter(scene)
        self.identity_slope = 1.0 / (2.0 * np.pi * self.h)


def shear_band(p20, p60, geo, est):
    """The band's numbers (statistical errors from the replicates, systematic from the
    estimator's variants), its fit (None where it cannot be fitted: NaN numbers, a
    warning) and the index ending the band region."""
    r, v, sem = p60.cells.centre, p60.values["v_phi"], p60.sem["v_phi"]
    noise, end = sb_fit.noise_level(v, sem), sb_fit.decay_end(v, sem)
    num = est(lambda a, b: {"decades": decades(b, noise)})
    num.update({"estimator": ESTIMATOR_TEXT, "decay_range_end_m": float(r[max(end, 1) - 1]),
                "noise_m_per_s": noise, "ring_count": p60.cells.n,
                "paper_v0_over_omega_Ri": PAPER["v0_over_omega_Ri"], "paper_s_m": PAPER["s_m"]})
    try:
        band = sb_fit.fit_band(r, v, sem, geo.R_i, geo.d_mean, geo.Omega)
    except UserError as exc:
        log.warning("the shear band is not fitted: %s", exc)
        band, nan = None, float("nan")
        num.update({k: nan for k in ("v0_over_omega_Ri", "s_m", "s_over_d_mean")})
        num.update({f"{k}_{e}": nan for k in ("v0_over_omega_Ri", "s_m", "s_over_d_mean")
                    for e in ("err", "sys")})
        num.update({"rings_fitted": 0, "variants": {}})
    if band is not None:
        num.update(est(lambda a, b: band_numbers(b, geo, band)))
        sens = sb_fit.sensitivity(*((p.cells.centre, p.values["v_phi"], p.sem["v_phi"])
                                    for p in (p60, p20)), geo.R_i, geo.d_mean, geo.Omega, band)
        shift = sens.pop("largest shift")
        num.update({
            "v0_over_omega_Ri_sys": shift["v0"] / (geo.Omega * geo.R_i), "s_m_sys": shift["s"],
            "s_over_d_mean_sys": shift["s"] / geo.d_mean,
            "first_ring_m": float(r[band.start]), "decay_range_end_m": band.r_max,
            "scatter_beyond_errors": band.tau, "rings_fitted": band.n_rings,
            "variants": {k: {"v0_over_omega_Ri": x["v0"] / (geo.Omega * geo.R_i),
                             "s_m": x["s"]} for k, x in sens.items()}})
    return num, band, end


def decades(p, noise):
    """Decades of decay of v_phi from the wall ring to the noise level."""
    with np.errstate(invalid="ignore", divide="ignore"):   # a wall ring <= 0, or no noise
        return float(np.log10(p.values["v_phi"][0] / noise))


def band_numbers(p, geo, band):
    """v0/(Omega R_i) and s of ``band``'s fit on profile ``p``."""
    fit = sb_fit.refit(band, p.cells.centre, p.values["v_phi"], geo.R_i, geo.Omega)
    return {"v0_over_omega_Ri": fit.v0 / (geo.Omega * geo.R_i), "s_m": fit.s,
            "s_over_d_mean": fit.s / geo.d_mean}


def window(r, lo, hi):
    return (r >= lo) & (r <= hi)


def rms_about_line(r, y):
    ok = np.isfinite(y)
    if ok.sum() < 3:
        return float("nan")
    coef = np.polyfit(r[ok], y[ok], 1)
    return float(np.sqrt(np.mean((y[ok] - np.polyval(coef, r[ok])) ** 2)))


def density_numbers(a, b, geo):
    """nu at the walls and in the bulk; dilation and layering outside the first layer
    (1 to 3 mean diameters from each wall, where excluded volume no longer sets nu)."""
    nu = a.values["nu"]
    nu_bulk = float(np.nanmean(nu[bulk(len(nu))]))
    r, nu60 = b.cells.centre, b.values["nu"]
    d = geo.d_mean
    inner = window(r, geo.R_i + d, geo.R_i + 3 * d)
    outer = window(r, geo.R_o - 3 * d, geo.R_o - d)
    mid = 0.5 * (geo.R_i + geo.R_o)
    middle = window(r, mid - d, mid + d)
    bulk60 = float(np.nanmean(nu60[bulk(len(nu60))]))
    walls = np.nanmean([rms_about_line(r[w], nu60[w]) for w in (inner, outer)])
    mid_rms = rms_about_line(r[middle], nu60[middle])
    return {"nu_inner": nu[0], "nu_bulk": nu_bulk, "nu_outer": nu[-1],
            "dilation_inner": bulk60 - float(np.nanmean(nu60[inner])),
            "dilation_outer": bulk60 - float(np.nanmean(nu60[outer])),
            "layering_walls": walls, "layering_bulk": mid_rms,
            "layering_excess": walls - mid_rms}


def fabric_numbers(p):
    F = tensor(p, "F")
    aniso = c.deviator_norm(F) / c.trace(F)
    return {"trF_min": np.nanmin(c.trace(F)), "trF_max": np.nanmax(c.trace(F)),
            "anisotropy_max": np.nanmax(aniso)}


def exponent(p, comp):
    b = bulk(p.cells.n)
    return {f"sigma_{comp}": c.power_law(p.cells.centre[b], p.values[f"sigma_{comp}"][b])[0]}


def stiffness_numbers(a, b, geo):
    trF, bulk_mod, shear_mod = [], [], []
    for p in (a, b):
        B, G = c.stiffness(tensor(p, "sigma"), tensor(p, "eps"), geo.k_n)
        bb = bulk(p.cells.n)
        trF.append(c.trace(tensor(p, "F"))[bb])
        bulk_mod.append(B[bb])
        shear_mod.append(G[bb])
    trF, bulk_mod, shear_mod = (np.concatenate(x) for x in (trF, bulk_mod, shear_mod))
    good = np.isfinite(trF) & np.isfinite(bulk_mod)
    if good.sum() < 3:
        raise UserError("fewer than three bulk rings with a stiffness")
    slope, intercept = np.polyfit(trF[good], bulk_mod[good], 1)
    ratio = bulk_mod[good] / trF[good]          # the identity: B = tr F / (2 pi h)
    return {"bulk_slope_per_m": slope, "bulk_intercept_per_m": intercept,
            "bulk_pearson_r": float(np.corrcoef(trF[good], bulk_mod[good])[0, 1]),
            "identity_deviation": float(np.mean(ratio)) / geo.identity_slope - 1.0,
            "shear_relative_scatter": float(np.nanstd(shear_mod) / np.nanmean(shear_mod))}


#: Largest relative offset of one run's bulk stiffness from the pooled master curve
#: that still counts as collapsed.
COLLAPSE_TOLERANCE = 0.05


def master_curve(profiles, geo) -> dict:
    """One straight line 2 pi E / k_n = a tr F + b through the bulk rings of runs at
    several area fractions; each run's mean relative offset from it, with its error
    from that run's replicates. Collapse is reproduced when every offset is within
    COLLAPSE_TOLERANCE + 2 errors, not reproduced when one lies beyond it by 2 errors."""
    pts = []
    for p in profiles:
        B, G = c.stiffness(tensor(p, "sigma"), tensor(p, "eps"), geo.k_n)
        b = bulk(p.cells.n)
        pts.append((c.trace(tensor(p, "F"))[b], B[b], G[b], p))
    x = np.concatenate([t for t, _, _, _ in pts])
    y = np.concatenate([B for _, B, _, _ in pts])
    ok = np.isfinite(x) & np.isfinite(y)
    a, b0 = np.polyfit(x[ok], y[ok], 1)
    offsets, errors, fractions, labels = [], [], [], []
    for trF, B, _, p in pts:
        offsets.append(float(np.nanmean(B / (a * trF + b0) - 1)))
        reps = p.replicates
        if reps is not None and reps.n >= 2:
            bb = bulk(p.cells.n)
            vals = []
            for i in range(reps.n):
                v = {k: reps.values[k][i] for k in reps.values}
                Bi = c.stiffness(tuple(v[f"sigma_{k}"] for k in TENSOR),
                                 tuple(v[f"eps_{k}"] for k in TENSOR), geo.k_n)[0][bb]
                Fi = v["F_rr"][bb] + v["F_phiphi"][bb]
                vals.append(np.nanmean(Bi / (a * Fi + b0) - 1))
            errors.append(reps.error(vals))
        else:
            errors.append(float("nan"))
        derived = (p.meta.get("run_manifest") or {}).get("derived", {})
        fractions.append(float(derived.get("area_fraction", float("nan"))))
        labels.append(f"area fraction {fractions[-1]:.4f}")
    verdicts = [verdict(COLLAPSE_TOLERANCE - abs(o), e, 0.0) for o, e in zip(offsets, errors)]
    result = both(*verdicts)
    return {"slope_per_m": a, "intercept_per_m": b0, "runs": len(pts),
            "area_fractions": fractions, "offsets": offsets, "offset_errors": errors,
            "verdict": result,
            "evidence": "pooled fit " + f"{plain(a)} tr F {b0:+.3g} 1/m; each run's mean "
            "offset from it: " + ", ".join(f"{f:.4f}: {pm(100 * o, 100 * e, '%')}"
                                           for f, o, e in zip(fractions, offsets, errors)),
            "points": [(lab, t, B, G) for lab, (t, B, G, _) in zip(labels, pts)]}


def orientation_numbers(p, n_band):
    ori = {q: np.degrees(c.orientation(tensor(p, q))) for q in ("F", "sigma", "eps")}
    band = slice(0, max(n_band, 2))
    return {f"band_mean_angle_{x}_{y}": float(np.nanmean(angle_diff(ori[x][band], ori[y][band])))
            for x, y in (("F", "sigma"), ("F", "eps"), ("sigma", "eps"))}


def eom(p):
    """(static residuals, total residuals, stress scale) of one profile (Fig. 7)."""
    sigma = tensor(p, "sigma")
    st = c.equations_of_motion(p.cells.centre, sigma)
    tot = c.equations_of_motion(p.cells.centre, c.momentum_flux_total(sigma, tensor(p, "dsigma")))
    scale = float(np.nanmean(np.abs(p.values["sigma_rr"][bulk(p.cells.n)])))
    return st, tot, scale


def eom_numbers(p):
    """The paper's check (div(sigma - dsigma) alone, one-sided at the walls) and the
    balance of forces with the body and boundary force densities, the walls closed
    (:mod:`granavg.analysis.balance`), relative to the bulk's mean |sigma_rr|."""
    st, tot, scale = eom(p)
    b = bulk(p.cells.n)
    terms = [t for t in FORCE_DENSITIES if f"{t}_r" in p.values]
    full = np.abs(np.array(residuals(p.values, p.cells, terms, closed=True))) / scale
    bare = np.abs(np.array(residuals(p.values, p.cells, (), closed=True))) / scale
    return {"stress_scale_Pa": scale,
            "bulk_median_residual": float(np.nanmedian(np.abs(np.concatenate(
                [tot[0][b], tot[1][b]])))) / scale,
            "wall_residual_max": float(np.nanmax(np.abs(np.concatenate(
                [tot[0][[0, -1]], tot[1][[0, -1]]])))) / scale,
            "balance_bulk_median_residual": float(np.nanmedian(full[:, b])),
            "balance_wall_residual_max": float(np.nanmax(full[:, [0, -1]])),
            "balance_near_wall_residual_max": float(np.nanmax(full[:, [1, -2]])),
            "balance_max_residual": float(np.nanmax(full)),
            "balance_wall_residual_max_without_forces": float(np.nanmax(bare[:, [0, -1]])),
            "balance_terms": len(terms)}


def power_numbers(p, arm):
    """The powers (W) the contacts and the body forces deliver to the disks over all
    rings: the disks' contacts (with the law's lever arm), the inner and the outer
    wall's contacts (the rings of the inner and the outer half), the base plate; their
    sum is the rate of the disks' kinetic energy."""
    V = p.cells.volume
    branch = (p.meta or {}).get("branch", "contact")
    lever = (BRANCHES[branch] - ARMS[arm]) / 0.5

    def total(name, where=slice(None)):
        return float(np.nansum((V * p.values[name])[where])) if name in p.values else 0.0
    inner = np.arange(p.cells.n) < p.cells.n // 2
    pp = total("contact_power") + lever * total("lever_power")
    w_in, w_out = total("wall_power", inner), total("wall_power", ~inner)
    body = total("body_power")
    return {"contact_dissipation_W": -pp, "plate_dissipation_W": -body,
            "inner_wall_delivered_W": w_in, "outer_wall_delivered_W": w_out,
            "kinetic_energy_rate_W": pp + w_in + w_out + body}


def spins(p, arm):
    """The spins' balance residual per ring (cells' and field's form, walls closed) and
    the forces' moment density, over the stress scale, for the figure."""
    cells = spin_balance(p, arm=arm, closed=True)
    field = spin_balance(p, arm=arm, closed=True, form="field")
    tau = moment_density(p.values, p.cells, arm, branch_reach(p))[0] / cells["scale"]
    return cells["residual"][0], cells["residual_err"][0], field["residual"][0], tau


def spin_numbers(p, arm):
    """The spins' balance over the rings (walls closed), relative to the stress scale:
    the couples passed (``cells`` form) and the couple stress's divergence (``field``)."""
    scale = stress_scale(p.values, p.cells)
    reach = branch_reach(p)
    cells, field = (np.abs(spin_residuals(p.values, p.cells, arm, reach, closed=True,
                                          form=form)[0]) / scale
                    for form in ("cells", "field"))
    b = bulk(p.cells.n)
    return {"max_residual": float(np.nanmax(cells)),
            "bulk_median_residual": float(np.nanmedian(cells[b])),
            "wall_residual_max": float(np.nanmax(cells[[0, -1]])),
            "field_max_residual": float(np.nanmax(field)),
            "field_bulk_median_residual": float(np.nanmedian(field[b])),
            "tau_max": float(np.nanmax(np.abs(moment_density(p.values, p.cells, arm,
                                                             reach)[0]))) / scale}


def layers(p, geo):
    W = c.deformation_rate_and_spin(p.cells.centre, p.values["v_phi"])[1]
    ws = c.eigen_rotation(p.values["omega"], W)
    layer = np.floor((p.cells.centre - geo.R_i) / geo.d_mean).astype(int)
    means = {}
    for k in (0, 1):
        w = ws[(layer == k) & np.isfinite(ws)]
        means[f"layer{k + 1}_per_s"] = float(w.mean()) if len(w) else float("nan")
    return means


def stationarity(p):
    """The window's steadiness judged per quantity: of the run, or of each realisation
    and of the ensemble (:func:`~granavg.engine.stationarity.ensemble_stationarity`, with
    at least MIN_RUNS realisations)."""
    meta = p.meta or {}
    if not meta.get("runs"):
        return {"run": meta.get("stationarity")}
    judged = {r["run"]: r.get("stationarity") for r in runs_by_name(meta["runs"])}
    ensemble = ensemble_stationarity(list(judged.values()))
    if ensemble:
        judged[f"ensemble ({max(r['n_runs'] for r in ensemble.values())} runs)"] = ensemble
    return judged


def plain_numbers(obj):
    if isinstance(obj, dict):
        return {k: plain_numbers(v) for k, v in obj.items()}
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj
