"""Headline numbers and the paper's claims from 20- and 60-ring profiles (Figs. 2-9).

:func:`analyze` returns a plain dict (written as ``summary.json``, stable keys) with the
run's parameters, every headline number with its uncertainty beside the paper's value,
and each qualitative claim of the paper marked reproduced or not with the number that
decides it. Arrays for the figures are in ``series`` (not written to JSON).
Regions: the *band* is the decay range of the shear-band fit; the *bulk* is the middle
half of the rings (away from both walls).
"""

from __future__ import annotations

import logging

import numpy as np

from . import continuum as c
from .errors import UserError

log = logging.getLogger(__name__)

PAPER = {"v0_over_omega_Ri": 0.645, "s_m": 0.0127, "exp_sigma_rr": 0.0,
         "exp_sigma_phiphi": 0.0, "exp_sigma_rphi": -2.0, "exp_sigma_phir": -2.0}
COMPONENTS = ("rr", "rphi", "phir", "phiphi")


def tensor(p, name):
    """The four components of a tensor profile, as a tuple of arrays."""
    return tuple(p.values[f"{name}_{k}"] for k in COMPONENTS)


#: Dynamic over static stress above which the flow is no longer quasi-static (the paper
#: describes the quasi-static regime only); granavg warns.
QUASI_STATIC_LIMIT = 0.1


def dynamic_over_static(p) -> np.ndarray:
    """|dynamic stress| / |static stress| per ring (Frobenius norms), shape (n_rings,)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(sum(np.asarray(t) ** 2 for t in tensor(p, "dsigma"))) / np.sqrt(
            sum(np.asarray(t) ** 2 for t in tensor(p, "sigma")))


def warn_if_inertial(p) -> float | None:
    """Log a warning when the dynamic stress is no longer small against the static
    stress in some ring; returns the largest ratio (None without both stresses)."""
    if "sigma_rr" not in p.values or "dsigma_rr" not in p.values:
        return None
    ratio = float(np.nanmax(dynamic_over_static(p)))
    if ratio > QUASI_STATIC_LIMIT:
        log.warning("dynamic stress reaches %.2f of the static stress (above %.2f): the flow "
                    "is inertial, outside the quasi-static regime the paper describes; lower "
                    "Omega or stiffen k_n", ratio, QUASI_STATIC_LIMIT)
    return ratio


def bulk(n):
    """Slice of the middle half of n rings."""
    return slice(n // 4, n - n // 4)


def analyze(p20, p60, manifest) -> dict:
    """Analyse two ring profiles of one run (coarse and fine rings).

    Parameters
    ----------
    p20, p60 : RingProfiles
        The same run averaged over 20 and 60 rings (any two ring counts work).
    manifest : dict
        The run's manifest (scene, contact law).
    """
    for p in (p20, p60):
        if p.rings.n < 4:
            raise UserError(f"{p.rings.n} ring(s): the analysis needs at least 4 rings")
        missing = [q for q in ("nu", "v_phi", "omega", "F_rr", "sigma_rr", "dsigma_rr", "eps_rr")
                   if q not in p.values]
        if missing:
            raise UserError(f"the profiles lack {missing[0]}; average with all quantities "
                            "(the contact dump is needed)")
    scene = manifest["scene"]
    R_i, Omega, k_n = scene["R_i"], scene["Omega"], scene["k_n"]
    d_mean = (scene["n_small"] * scene["d_s"] + scene["n_large"] * scene["d_l"]) / (
        scene["n_small"] + scene["n_large"])
    num, series, claims = {}, {}, []

    # Fig. 2: density and the shear band
    band_p = p60
    r = band_p.rings.centre
    band = c.fit_shear_band(r, band_p.values["v_phi"], band_p.sem["v_phi"], R_i)
    v_first = band_p.values["v_phi"][0]
    num["shear_band"] = {
        "v0_over_omega_Ri": band.v0 / (Omega * R_i), "v0_over_omega_Ri_err": band.v0_err / (Omega * R_i),
        "s_m": band.s, "s_m_err": band.s_err, "s_over_d_mean": band.s / d_mean,
        "s_over_d_mean_err": band.s_err / d_mean, "decay_range_end_m": band.r_max,
        "noise_m_per_s": band.noise, "rings_fitted": band.n_rings, "ring_count": band_p.rings.n,
        "decades": float(np.log10(v_first / band.noise)),
        "paper_v0_over_omega_Ri": PAPER["v0_over_omega_Ri"], "paper_s_m": PAPER["s_m"]}
    nu = p20.values["nu"]
    num["density"] = {"nu_inner": nu[0], "nu_bulk": float(np.nanmean(nu[bulk(len(nu))])),
                      "nu_outer": nu[-1]}
    claims.append(_claim("dilation at both walls",
                         nu[0] < num["density"]["nu_bulk"] and nu[-1] < num["density"]["nu_bulk"],
                         f"nu = {nu[0]:.3f} (inner ring), {num['density']['nu_bulk']:.3f} (bulk), "
                         f"{nu[-1]:.3f} (outer ring)"))
    nu60, r60 = p60.values["nu"], p60.rings.centre
    near = (r60 - R_i < 3 * d_mean) | (scene["R_o"] - r60 < 3 * d_mean)
    wiggle_wall = float(np.nanstd(np.diff(nu60[near])))
    wiggle_bulk = float(np.nanstd(np.diff(nu60[bulk(len(nu60))])))
    num["density"].update({"nu_wiggle_walls": wiggle_wall, "nu_wiggle_bulk": wiggle_bulk})
    claims.append(_claim("layering at the walls, none in the bulk", wiggle_wall > 2 * wiggle_bulk,
                         f"ring-to-ring spread of nu ({p60.rings.n} rings): {wiggle_wall:.3f} "
                         f"within 3 d of a wall, {wiggle_bulk:.3f} in the bulk"))
    claims.append(_claim("exponential decay over about two decades", num["shear_band"]["decades"] >= 1.5,
                         f"{num['shear_band']['decades']:.2f} decades from the first ring to the noise"))

    # Fig. 3: fabric
    F20 = tensor(p20, "F")
    aniso = c.deviator_norm(F20) / c.trace(F20)
    num["fabric"] = {"trF_min": float(np.nanmin(c.trace(F20))), "trF_max": float(np.nanmax(c.trace(F20))),
                     "anisotropy_max": float(np.nanmax(aniso))}
    claims.append(_claim("anisotropy |dev F|/tr F below 20%", num["fabric"]["anisotropy_max"] < 0.2,
                         f"largest {num['fabric']['anisotropy_max']:.3f}"))

    # Fig. 4, Eq. 10: stress exponents in the bulk; quasi-static
    b = bulk(p20.rings.n)
    rb = p20.rings.centre[b]
    num["stress_exponents"] = {}
    ok = True
    for k in COMPONENTS:
        e, err = c.power_law(rb, p20.values[f"sigma_{k}"][b], p20.sem[f"sigma_{k}"][b])
        num["stress_exponents"][f"sigma_{k}"] = e
        num["stress_exponents"][f"sigma_{k}_err"] = err
        ok &= abs(e - PAPER[f"exp_sigma_{k}"]) <= max(2 * err, 0.3)
    ex = num["stress_exponents"]
    claims.append(_claim("sigma_rr, sigma_phiphi ~ r^0 and sigma_rphi, sigma_phir ~ r^-2 (Eq. 10)", ok,
                         ", ".join(f"{k}: {ex[f'sigma_{k}']:.2f}+-{ex[f'sigma_{k}_err']:.2f}"
                                   for k in COMPONENTS)))
    ratio = dynamic_over_static(p20)
    num["quasi_static"] = {"dynamic_over_static_max": float(np.nanmax(ratio))}
    claims.append(_claim("quasi-static: dynamic stress much smaller than static",
                         np.nanmax(ratio) < QUASI_STATIC_LIMIT,
                         f"largest |d sigma| / |sigma| = {np.nanmax(ratio):.2e}"))

    # Fig. 5: stiffness against tr F
    trF, bulk_mod, shear_mod = [], [], []
    for p in (p20, p60):
        B, G = c.stiffness(tensor(p, "sigma"), tensor(p, "eps"), k_n)
        bb = bulk(p.rings.n)
        trF.append(c.trace(tensor(p, "F"))[bb])
        bulk_mod.append(B[bb])
        shear_mod.append(G[bb])
        series[f"stiffness_{p.rings.n}"] = (c.trace(tensor(p, "F")), B, G)
    trF, bulk_mod, shear_mod = (np.concatenate(x) for x in (trF, bulk_mod, shear_mod))
    good = np.isfinite(trF) & np.isfinite(bulk_mod)
    slope, intercept = np.polyfit(trF[good], bulk_mod[good], 1)
    pearson = float(np.corrcoef(trF[good], bulk_mod[good])[0, 1])
    num["stiffness"] = {"bulk_slope_per_m": slope, "bulk_intercept_per_m": intercept,
                        "bulk_pearson_r": pearson,
                        "shear_relative_scatter": float(np.nanstd(shear_mod) / np.nanmean(shear_mod))}
    series["bulk_fit"] = (slope, intercept)
    claims.append(_claim("bulk modulus linear in tr F", pearson > 0.9,
                         f"Pearson r = {pearson:.3f} over {good.sum()} bulk rings"))

    # Fig. 6: orientations
    for p in (p20, p60):
        series[f"orientation_{p.rings.n}"] = {
            q: np.degrees(c.orientation(tensor(p, q))) for q in ("F", "sigma", "eps")}
    ori = series[f"orientation_{p60.rings.n}"]
    inband = slice(0, max(band.n_rings, 2))
    diff = max(np.nanmax(np.abs(_angle_diff(ori[a][inband], ori[b][inband])))
               for a, b in (("F", "sigma"), ("F", "eps"), ("sigma", "eps")))
    num["orientation"] = {"max_difference_in_band_deg": float(diff)}
    claims.append(_claim("fabric, stress and strain not co-linear", diff > 5.0,
                         f"largest angle between their major axes in the band: {diff:.1f} deg"))

    # Fig. 7: equations of motion
    scale = float(np.nanmean(np.abs(p20.values["sigma_rr"][b])))
    for p in (p20, p60):
        st = c.equations_of_motion(p.rings.centre, tensor(p, "sigma"))
        tot = c.equations_of_motion(p.rings.centre,
                                    tuple(s + d for s, d in zip(tensor(p, "sigma"), tensor(p, "dsigma"))),
                                    p.values["rho"], p.values["v_phi"])
        series[f"eom_{p.rings.n}"] = (st, tot, scale)
    st, tot, _ = series[f"eom_{p20.rings.n}"]
    bulk_res = float(np.nanmedian(np.abs(np.concatenate([tot[0][b], tot[1][b]])))) / scale
    num["equations_of_motion"] = {"stress_scale_Pa": scale, "bulk_median_residual": bulk_res,
                                  "wall_residual_max": float(np.nanmax(np.abs(
                                      np.concatenate([tot[0][[0, -1]], tot[1][[0, -1]]])))) / scale}
    claims.append(_claim("equations of motion close in the bulk", bulk_res < 0.1,
                         f"median |residual| / mean |sigma_rr| in the bulk = {bulk_res:.3f} "
                         "(20 rings)"))

    # Figs. 8-9: deformation rate, spin, eigen-rotation
    for p in (p20, p60):
        D, W = c.deformation_rate_and_spin(p.rings.centre, p.values["v_phi"])
        Df, Wf = c.deformation_rate_and_spin_fit(p.rings.centre, band, R_i)
        series[f"rates_{p.rings.n}"] = (D, W, Df, Wf, p.values["omega"],
                                        c.eigen_rotation(p.values["omega"], W))
    ws = series[f"rates_{p60.rings.n}"][5]
    layer = np.floor((p60.rings.centre - R_i) / d_mean).astype(int)
    layers = [float(np.nanmean(ws[layer == k])) for k in (0, 1)]
    num["eigen_rotation"] = {"layer1_per_s": layers[0], "layer2_per_s": layers[1]}
    claims.append(_claim("eigen-rotation alternates over the two innermost layers",
                         c.alternates(layers), f"omega* = {layers[0]:.3g}, {layers[1]:.3g} 1/s "
                         f"(layers of d_mean = {d_mean * 1e3:.2f} mm, 60 rings)"))

    summary = {"units": "SI (m, s, kg, N, Pa)",
               "run": {k: manifest.get(k) for k in ("preset", "scene", "contact_law", "derived",
                                                   "lammps_version", "granavg_version")},
               "frames": p20.meta.get("frames") if p20.meta else None,
               "numbers": _plain(num), "claims": claims}
    summary["series"] = series
    return summary


def _angle_diff(a, b):
    return (np.asarray(a) - np.asarray(b) + 90.0) % 180.0 - 90.0


def _claim(text, reproduced, evidence):
    return {"claim": text, "reproduced": bool(reproduced), "evidence": evidence}


def _plain(obj):
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj
