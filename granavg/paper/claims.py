"""Headline numbers and the paper's claims from coarse and fine ring profiles (Figs. 2-9).

:func:`analyze` returns a plain dict (written as ``summary.json``, stable keys) with the
run's parameters, every headline number with its standard error beside the paper's
value, and each of the paper's claims with a verdict and the numbers that decide it.
Arrays for the figures are in ``series`` (not written to JSON).

Errors of derived numbers (fits, exponents, maxima, layer means) come from replicates of
the profiles (:mod:`granavg.engine.uncertainty.blocking`): the number is recomputed on every replicate,
delete-one-block jackknife profiles of one run or the profiles of each realisation of an
ensemble, so the correlation of neighbouring rings is carried along. The fits' own
errors, which treat rings as independent, are not used.

A claim's verdict is ``reproduced`` when the data show it beyond twice its error,
``not reproduced`` when they show the opposite beyond twice its error, and
``inconclusive`` otherwise. Identity checks (the linear-spring stiffness) are listed
apart: they test the averaging, not the physics.

Regions: the *band* runs from the inner wall to the end of the shear-band fit's decay
range; the *bulk* is the middle half of the rings (away from both walls).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Callable

import numpy as np

from granavg.analysis import continuum as c
from granavg.analysis import rheology as rh
from granavg.analysis.continuum import tensor
from granavg.analysis.regime import QUASI_STATIC_LIMIT, dynamic_over_static
from granavg.analysis.rounding import plain, pm
from granavg.analysis.spin_balance import has_couples
from granavg.errors import UserError
from granavg.engine.quantities import TENSOR
from granavg.engine.stationarity import window_mean
from granavg.paper.numbers import (COLLAPSE_TOLERANCE, SceneNumbers, density_numbers,
                                   derived_errors, eom, eom_numbers, exponent,
                                   fabric_numbers, layers, master_curve,
                                   orientation_numbers, plain_numbers, power_numbers,
                                   runs_by_name, shear_band, spin_numbers, spins,
                                   stationarity, stiffness_numbers)
from granavg.paper.verdicts import (ANISOTROPY_LIMIT, COLINEAR_DEG, DECADES, EOM_LIMIT,
                                    EXPONENT_TOLERANCE, IDENTITY_TOLERANCE, PAPER,
                                    POWER_LIMIT, SPIN_BULK_LIMIT, SPIN_LIMIT, S_TOLERANCE,
                                    V0_TOLERANCE, Z, both, closes, verdict)

log = logging.getLogger(__name__)

def replicate_views(p20, p60):
    """Pairs of (coarse, fine) profile views, one per replicate, and the replicates that
    give their errors; ([], None) without replicates.

    Both profiles must have replicates of the same kind and number (the same run's
    blocks and sectors, or the same realisations). Structure replicates split into
    different sectors fall back to their time blocks, with a warning.
    """
    r20, r60 = p20.replicates, p60.replicates
    if r20 is None or r60 is None:
        return [], None
    if "structure" in (r20.kind, r60.kind) and (r20.kind, r20.parts) != (r60.kind, r60.parts):
        log.warning("the two profiles do not split their rings into the same sectors: "
                    "derived numbers get errors from time alone; average both with the "
                    "same number of sectors")
        r20, r60 = r20.in_time(), r60.in_time()
    if r20.kind != r60.kind or r20.n != r60.n or r20.n < 2:
        return [], None

    def view(p, rep, i):
        return SimpleNamespace(cells=p.cells, sem=p.sem, meta=p.meta,
                               values={k: v[i] for k, v in rep.values.items()})
    return [(view(p20, r20, i), view(p60, r60, i)) for i in range(r20.n)], r20


class _Reads(dict):
    """A profile's values that note the names read (``[]`` and ``get``)."""

    def __init__(self, values, seen):
        super().__init__(values)
        self.seen = seen

    def __getitem__(self, name):
        self.seen.add(name)
        return super().__getitem__(name)

    def get(self, name, default=None):
        self.seen.add(name)
        return super().get(name, default)


class Estimator:
    """Numbers computed by one function of (coarse, fine) profiles, with replicate errors.

    With a single run's ``structure`` replicates, a number that reads only values with
    errors from time alone (the balance of forces fixes them in a whole cell, the
    sidecar's ``errors.sectors.time_only``), or one marked ``balance`` (a balance law's
    residual, which a sector cannot close: it misses the tractions on its cuts), takes
    its error from the time blocks alone."""

    def __init__(self, p20, p60):
        self.p20, self.p60 = p20, p60
        self.views, self.replicates = replicate_views(p20, p60)
        self.time_only = set(((p20.meta or {}).get("errors", {}).get("sectors") or {})
                             .get("time_only", []))

    def _in_time(self):
        """(views, replicates) of the time blocks alone."""
        return replicate_views(*(SimpleNamespace(cells=p.cells, sem=p.sem, meta=p.meta,
                                                 replicates=p.replicates.in_time())
                                 for p in (self.p20, self.p60)))

    def __call__(self, fn, balance=False):
        """``fn(coarse, fine) -> dict of float``; returns the dict with ``<key>_err`` added
        (NaN without replicates)."""
        seen = set()
        reading = [SimpleNamespace(cells=p.cells, sem=p.sem, meta=p.meta,
                                   values=_Reads(p.values, seen)) for p in (self.p20, self.p60)]
        value = {k: float(v) for k, v in fn(*reading).items()}
        views, replicates = self.views, self.replicates
        if replicates is not None and replicates.kind == "structure" and (
                balance or (seen and seen <= self.time_only)):
            views, replicates = self._in_time()
        reps = []
        for a, b in views:
            try:
                reps.append(fn(a, b))
            except (UserError, np.linalg.LinAlgError, ValueError):
                reps.append({})
        for k in list(value):
            xs = [r.get(k, np.nan) for r in reps]
            value[f"{k}_err"] = replicates.error(xs) if views else float("nan")
        return value


def _claim(text, result, evidence, kind="claim", tolerance="", deviations=()):
    """One claim's entry. ``tolerance``: what decides it beyond the errors, shown beside
    the verdict. ``deviations``: (label, value, error, reference) of the numbers a
    tolerance lets pass; a claim that holds while one of them lies more than Z errors
    from its reference says so in its ``note`` ("within its tolerance (0.3 on each
    exponent, + 2 errors): sigma_rr 21 errors from 0"), never a plain "reproduced"."""
    note = ""
    if result in ("reproduced", "holds"):
        far = [(label, abs(v - ref) / e, ref) for label, v, e, ref in deviations
               if np.isfinite(v) and np.isfinite(e) and e > 0 and abs(v - ref) > Z * e]
        if far:
            note = f"within its tolerance ({tolerance}): " + ", ".join(
                f"{label} {n:.0f} errors from {ref:g}" for label, n, ref in far)
    return {"claim": text, "kind": kind, "verdict": result,
            "reproduced": result in ("reproduced", "holds"), "tolerance": tolerance,
            "note": note, "evidence": evidence}


@dataclass
class Analysis:
    """What the claims read and write: the coarse and fine profiles, the scene's numbers,
    the replicates' estimator, and the summary's numbers, series and claims so far."""

    p20: object
    p60: object
    manifest: dict
    density_series: tuple
    geo: object = None
    est: object = None
    numbers: dict = field(default_factory=dict)
    series: dict = field(default_factory=dict)
    claims: list = field(default_factory=list)
    band: object = None
    band_end: int = 0

    @property
    def arm(self) -> str:
        """The law's lever arm for the torque: the contact point with rolling resistance
        (pair granular), else the surface (gran/hooke/history)."""
        return "contact" if self.manifest["scene"].get("mu_roll", 0) > 0 else "surface"


@dataclass(frozen=True)
class Claim:
    """One of the paper's claims (or a check of the averaging), registered in
    :data:`CLAIMS` like the quantities.

    Attributes
    ----------
    name : str
        Its key.
    figure : str
        The paper's figure (or equation) it is about.
    decide : callable
        ``decide(analysis) -> dict or None``: the claim's entry (:func:`_claim`), None
        where the data cannot hold it (no couple stress, no wall torque); it may add
        the numbers it reads to ``analysis.numbers`` and the figures' arrays to
        ``analysis.series``.
    shows : tuple of str
        The report's figures that draw its data (keys of
        :data:`granavg.analysis.figures.FIGURES`), written into its entry as ``figures``.
    """

    name: str
    figure: str
    decide: Callable
    shows: tuple = ()


def _band(a: Analysis) -> dict:
    """The shear band's numbers (:func:`shear_band`), computed once."""
    if "shear_band" not in a.numbers:
        a.numbers["shear_band"], a.band, a.band_end = shear_band(a.p20, a.p60, a.geo, a.est)
    return a.numbers["shear_band"]


def _decay(a: Analysis) -> dict:
    num = _band(a)
    return _claim(
        "exponential decay over about two decades",
        verdict(num["decades"], num["decades_err"], DECADES),
        f"{pm(num['decades'], num['decades_err'], 'decades')} from the first ring to the "
        "noise", tolerance=f"above {DECADES:g} decades by {Z:g} errors")


def _compared(key, label, unit, scale, tol):
    """The claim that the band's ``key`` lies within ``tol`` of the paper's value."""
    def decide(a: Analysis) -> dict:
        num = _band(a)
        total = float(np.hypot(num[f"{key}_err"], num[f"{key}_sys"]))
        paper = PAPER[key]
        return _claim(
            f"{label} within {tol:.0%} of the paper's {paper * scale:g}{unit}",
            verdict(abs(num[key] - paper), total, tol * paper, above=False),
            f"{pm(num[key] * scale, num[f'{key}_err'] * scale, unit.strip())} (statistical)"
            f", +- {plain(num[f'{key}_sys'] * scale, 2)}{unit} (estimator); "
            f"{num['rings_fitted']} of {a.p60.cells.n} rings", kind="comparison",
            tolerance=f"{tol:.0%} of the paper's value, + {Z:g} combined errors",
            deviations=[(label, num[key] * scale, total * scale, paper * scale)])
    return decide


def _density(a: Analysis) -> dict:
    if "density" not in a.numbers:
        a.numbers["density"] = a.est(lambda x, y: density_numbers(x, y, a.geo))
    return a.numbers["density"]


def _dilation(a: Analysis) -> dict:
    d = _density(a)
    return _claim(
        "dilation in the shear zone and at the outer wall",
        both(verdict(d["dilation_inner"], d["dilation_inner_err"], 0.0),
              verdict(d["dilation_outer"], d["dilation_outer_err"], 0.0)),
        f"nu_bulk - nu between 1 and 3 mean diameters from the wall (the first layer, where "
        f"excluded volume alone lowers nu, left out): inner "
        f"{pm(d['dilation_inner'], d['dilation_inner_err'])}, outer "
        f"{pm(d['dilation_outer'], d['dilation_outer_err'])} ({a.p60.cells.n} rings)",
        tolerance=f"both above 0 by {Z:g} errors")


def _layering(a: Analysis) -> dict:
    d = _density(a)
    return _claim(
        "layering at the walls, none in the bulk",
        both(verdict(d["layering_excess"], d["layering_excess_err"], 0.0),
              verdict(d["layering_walls"], 0.0, 2 * d["layering_bulk"])),
        f"rms of nu about a straight line between 1 and 3 mean diameters from a wall: "
        f"{plain(d['layering_walls'])}, in a bulk window as wide: "
        f"{plain(d['layering_bulk'])}; excess "
        f"{pm(d['layering_excess'], d['layering_excess_err'])}",
        tolerance=f"excess above 0 by {Z:g} errors, the walls' rms over twice the bulk's")


def _anisotropy(a: Analysis) -> dict:
    """Fig. 3: fabric anisotropy, in the norm |dev F| = (F_1 - F_2)/2."""
    fab = a.numbers["fabric"] = a.est(lambda x, y: fabric_numbers(x))
    return _claim(
        "anisotropy |dev F|/tr F below 20%",
        verdict(fab["anisotropy_max"], fab["anisotropy_max_err"], ANISOTROPY_LIMIT,
                above=False),
        f"largest over {a.p20.cells.n} rings: "
        f"{pm(fab['anisotropy_max'], fab['anisotropy_max_err'])} with |dev F| = "
        f"(F_1 - F_2)/2, half the eigenvalue difference (the paper does not define its "
        f"norm; as Frobenius norm {plain(fab['anisotropy_max'] * np.sqrt(2))}, as full "
        f"difference {plain(2 * fab['anisotropy_max'])})",
        tolerance=f"below {ANISOTROPY_LIMIT:g} by {Z:g} errors")


def _exponents(a: Analysis) -> dict:
    """Fig. 4, Eq. 10: stress exponents in the bulk (unweighted; errors from replicates)."""
    ex = a.numbers["stress_exponents"] = {
        k: v for comp in TENSOR for k, v in a.est(
            lambda x, y, comp=comp: exponent(x, comp)).items()}
    parts = []
    for k in TENSOR:
        e, err = ex[f"sigma_{k}"], ex[f"sigma_{k}_err"]
        off = abs(e - PAPER[f"exp_sigma_{k}"])
        if not np.isfinite(err) or err > EXPONENT_TOLERANCE:
            parts.append("inconclusive")
        else:
            parts.append("reproduced" if off <= EXPONENT_TOLERANCE + Z * err
                         else "not reproduced")
    return _claim(
        "sigma_rr, sigma_phiphi ~ r^0 and sigma_rphi, sigma_phir ~ r^-2 (Eq. 10)",
        both(*parts),
        ", ".join(f"{k}: {pm(ex[f'sigma_{k}'], ex[f'sigma_{k}_err'])}" for k in TENSOR)
        + " (the paper: 0, 0, -2, -2)",
        tolerance=f"{EXPONENT_TOLERANCE:g} on each exponent, + {Z:g} errors",
        deviations=[(f"sigma_{k}", ex[f"sigma_{k}"], ex[f"sigma_{k}_err"],
                     PAPER[f"exp_sigma_{k}"]) for k in TENSOR])


def _quasi_static(a: Analysis) -> dict:
    q = a.numbers["quasi_static"] = a.est(lambda x, y: {
        "dynamic_over_static_max": float(np.nanmax(dynamic_over_static(x)))})
    return _claim(
        "quasi-static: dynamic stress much smaller than static",
        verdict(q["dynamic_over_static_max"], q["dynamic_over_static_max_err"],
                QUASI_STATIC_LIMIT, above=False),
        f"largest |d sigma| / |sigma| = "
        f"{pm(q['dynamic_over_static_max'], q['dynamic_over_static_max_err'])}",
        tolerance=f"below {QUASI_STATIC_LIMIT:g} by {Z:g} errors")


def _identity(a: Analysis) -> dict:
    """Fig. 5: stiffness against tr F; for linear springs an identity, checked as such."""
    st = a.numbers["stiffness"] = a.est(lambda x, y: stiffness_numbers(x, y, a.geo))
    for p in (a.p20, a.p60):
        B, G = c.stiffness(tensor(p, "sigma"), tensor(p, "eps"), a.geo.k_n)
        a.series[f"stiffness_{p.cells.n}"] = (c.trace(tensor(p, "F")), B, G)
    a.series["bulk_fit"] = (st["bulk_slope_per_m"], st["bulk_intercept_per_m"])
    dev = st["identity_deviation"]
    return _claim(
        "bulk stiffness = tr F / (2 pi h), the linear-spring identity",
        "holds" if abs(dev) <= IDENTITY_TOLERANCE + Z * st["identity_deviation_err"]
        else "violated",
        f"slope {pm(st['bulk_slope_per_m'], st['bulk_slope_per_m_err'], '1/m')} against "
        f"1/(2 pi h) = {plain(a.geo.identity_slope, 4)} 1/m: deviation "
        f"{pm(100 * dev, 100 * st['identity_deviation_err'], '%')} (damping, tangential "
        "forces and fabric anisotropy make it; an identity of the averaging, not a finding "
        "of the paper; the paper's collapse of several simulations is Fig. 5 of a density "
        "series)", kind="identity check",
        tolerance=f"{IDENTITY_TOLERANCE:.0%}, + {Z:g} errors",
        deviations=[("the deviation", dev, st["identity_deviation_err"], 0.0)])


def _collapse(a: Analysis) -> dict | None:
    """Fig. 5 of a density series: the bulk stiffness of every run on one line."""
    if not a.density_series:
        return None
    collapse = master_curve([a.p20, *a.density_series], a.geo)
    a.series["density_series"] = collapse.pop("points")
    a.numbers["master_curve"] = collapse
    return _claim(
        "bulk stiffness of different simulations on one master curve (Fig. 5)",
        collapse["verdict"], collapse["evidence"],
        tolerance=f"{COLLAPSE_TOLERANCE:.0%} on each run's offset, + {Z:g} errors",
        deviations=[(f"area fraction {f:.4f}", o, e, 0.0) for f, o, e in zip(
            collapse["area_fractions"], collapse["offsets"], collapse["offset_errors"])])


def _colinear(a: Analysis) -> dict:
    """Fig. 6: orientations, not co-linear in the band."""
    _band(a)
    for p in (a.p20, a.p60):
        a.series[f"orientation_{p.cells.n}"] = {
            q: np.degrees(c.orientation(tensor(p, q))) for q in ("F", "sigma", "eps")}
    o = a.numbers["orientation"] = a.est(lambda x, y: orientation_numbers(y, a.band_end))
    pairs = [k for k in o if k.startswith("band_mean_angle") and not k.endswith("_err")]
    significant = [k for k in pairs
                   if abs(o[k]) > COLINEAR_DEG and abs(o[k]) > Z * o[f"{k}_err"]]
    colinear = all(abs(o[k]) + Z * o[f"{k}_err"] < COLINEAR_DEG for k in pairs)
    return _claim(
        "fabric, stress and strain not co-linear",
        "reproduced" if significant else ("not reproduced" if colinear else "inconclusive"),
        "mean angle between major axes over the band (" + str(max(a.band_end, 2)) +
        f" of {a.p60.cells.n} rings): " + ", ".join(
            f"{k.replace('band_mean_angle_', '').replace('_', ' to ')} "
            f"{pm(o[k], o[k + '_err'], 'deg')}" for k in pairs),
        tolerance=f"one angle above {COLINEAR_DEG:g} deg and {Z:g} errors")


def _motion(a: Analysis) -> dict:
    """Fig. 7: equations of motion, static alone and the total sigma - dsigma."""
    for p in (a.p20, a.p60):
        a.series[f"eom_{p.cells.n}"] = eom(p)
    eo = a.numbers["equations_of_motion"] = a.est(lambda x, y: eom_numbers(x), balance=True)
    return _claim(
        "equations of motion close in the bulk",
        verdict(eo["bulk_median_residual"], eo["bulk_median_residual_err"], EOM_LIMIT,
                above=False),
        f"median |residual of div(sigma - dsigma)| / mean |sigma_rr| in the bulk = "
        f"{pm(eo['bulk_median_residual'], eo['bulk_median_residual_err'])} "
        f"({a.p20.cells.n} rings). Each ring's net force over its face's with the body and "
        f"boundary force densities, walls closed: median "
        f"{pm(eo['balance_bulk_median_residual'], eo['balance_bulk_median_residual_err'])} "
        f"in the bulk, at most "
        f"{pm(eo['balance_max_residual'], eo['balance_max_residual_err'])} in any ring, "
        f"wall rings "
        f"{pm(eo['balance_wall_residual_max'], eo['balance_wall_residual_max_err'])} "
        f"({plain(eo['balance_wall_residual_max_without_forces'])} without the force "
        "densities)",
        tolerance=f"bulk median below {EOM_LIMIT:g} of the stress scale by {Z:g} errors")


def _spins_balance(a: Analysis) -> dict | None:
    """The spins' balance (micropolar): the forces' moments, the couples passed and the
    spins' flux, with the law's own lever arm."""
    if not all(has_couples(p.values, p.cells) for p in (a.p20, a.p60)):
        return None
    arm = a.arm
    for p in (a.p20, a.p60):
        a.series[f"spins_{p.cells.n}"] = spins(p, arm)
    sp = a.numbers["spin_balance"] = a.est(lambda x, y: spin_numbers(x, arm), balance=True)
    return _claim(
        "the spins' angular momentum balances in every ring",
        both(verdict(sp["max_residual"], sp["max_residual_err"], SPIN_LIMIT, above=False),
              verdict(sp["bulk_median_residual"], sp["bulk_median_residual_err"],
                      SPIN_BULK_LIMIT, above=False)),
        f"moment density left unbalanced by the forces' moments (lever arm to the "
        f"{'contact point' if arm == 'contact' else 'surface'}), the couples the "
        f"contacts pass and the spins' flux, over the stress scale ({a.p20.cells.n} "
        f"rings, walls included): at most {pm(sp['max_residual'], sp['max_residual_err'])}"
        f", bulk median "
        f"{pm(sp['bulk_median_residual'], sp['bulk_median_residual_err'])}; the forces' "
        f"moments alone reach {plain(sp['tau_max'], 2)}. With the couple stress field's "
        f"divergence instead of the couples passed: at most "
        f"{pm(sp['field_max_residual'], sp['field_max_residual_err'])}",
        tolerance=f"below {SPIN_LIMIT:g} in every ring and {SPIN_BULK_LIMIT:g} as the "
                  f"bulk's median, by {Z:g} errors")


def _power(a: Analysis) -> dict | None:
    """The power balance: what the inner wall delivers (-Omega <T_in>) is dissipated by
    the contacts, at the walls and by the base plate, the kinetic energy steady."""
    p20, geo = a.p20, a.geo
    if not all(k in p20.values for k in ("contact_power", "wall_power")):
        return None
    arm = a.arm
    t_in = window_mean(p20.timeseries, "torque_in_Nm",
                       (p20.meta.get("frames") or {}).get("t_min_s", 0.0))
    pw = a.numbers["power_balance"] = a.est(lambda x, y: power_numbers(x, arm),
                                            balance=True)
    if t_in is None:
        return None
    P, P_err = -geo.Omega * t_in["mean"], geo.Omega * t_in["err"]
    W = "inner_wall_contacts_dissipation_W"
    pw.update({"inner_wall_power_W": P, "inner_wall_power_W_err": P_err,
               "inner_wall_contacts_dissipation_W": P - pw["inner_wall_delivered_W"],
               "inner_wall_contacts_dissipation_W_err": float(np.hypot(
                   P_err, pw["inner_wall_delivered_W_err"])),
               "closure": pw["kinetic_energy_rate_W"] / P,
               "closure_err": pw["kinetic_energy_rate_W_err"] / abs(P)})
    plate = (f", the base plate "
             f"{pm(pw['plate_dissipation_W'], pw['plate_dissipation_W_err'], 'W')}"
             if "body_power" in p20.values else " (no base plate)")
    return _claim(
        "the inner wall's power is dissipated",
        closes(pw["closure"], pw["closure_err"], POWER_LIMIT),
        f"inner wall -Omega T_in (window mean) = {pm(P, P_err, 'W')}; dissipated by "
        f"the disks' contacts "
        f"{pm(pw['contact_dissipation_W'], pw['contact_dissipation_W_err'], 'W')}, "
        f"the inner wall's contacts "
        f"{pm(pw[W], pw[W + '_err'], 'W')}"
        f", the outer wall's "
        f"{pm(-pw['outer_wall_delivered_W'], pw['outer_wall_delivered_W_err'], 'W')}"
        f"{plate}: unbalanced {pm(pw['closure'], pw['closure_err'])} of the wall's "
        "power (what is left is the rate of the kinetic and elastic energy, nil in a "
        "steady state)",
        tolerance=f"{POWER_LIMIT:.0%} of the wall's power, or {Z:g} errors",
        deviations=[("the unbalanced share", pw["closure"], pw["closure_err"], 0.0)])


def _wall_loads(a: Analysis) -> None:
    """The shear cell's torque (what the experiments measure): no claim, its numbers."""
    t0 = (a.p20.meta.get("frames") or {}).get("t_min_s", 0.0)
    a.numbers["wall_loads"] = {}
    for q in ("torque_in_Nm", "torque_out_Nm"):
        m = window_mean(a.p20.timeseries, q, t0)
        if m is not None:
            a.numbers["wall_loads"].update({q: m["mean"], f"{q}_err": m["err"],
                                            f"{q}_error": m.get("error", "")})
    return None


def _eigen_rotation(a: Analysis) -> dict:
    """Figs. 8-9: deformation rate, spin, eigen-rotation."""
    _band(a)
    for p in (a.p20, a.p60):
        D, W = c.deformation_rate_and_spin(p.cells.centre, p.values["v_phi"])
        Df, Wf = (c.deformation_rate_and_spin_fit(p.cells.centre, a.band, a.geo.R_i)
                  if a.band is not None else (np.full(p.cells.n, np.nan),) * 2)
        a.series[f"rates_{p.cells.n}"] = (D, W, Df, Wf, p.values["omega"],
                                          c.eigen_rotation(p.values["omega"], W))
    er = a.numbers["eigen_rotation"] = a.est(lambda x, y: layers(y, a.geo))
    l1, l2 = er["layer1_per_s"], er["layer2_per_s"]
    e1, e2 = er["layer1_per_s_err"], er["layer2_per_s_err"]
    sig1, sig2 = abs(l1) > Z * e1, abs(l2) > Z * e2
    if sig1 and sig2:
        rot = "reproduced" if np.sign(l1) != np.sign(l2) else "not reproduced"
    else:
        rot = "inconclusive"
    return _claim(
        "eigen-rotation alternates over the two innermost layers", rot,
        f"omega* = {pm(l1, e1, '1/s')}, {pm(l2, e2, '1/s')} (layers of d_mean = "
        f"{a.geo.d_mean * 1e3:.2f} mm, {a.p60.cells.n} rings)",
        tolerance=f"both beyond {Z:g} errors of 0, of opposite signs")


def _rheology(a: Analysis) -> dict | None:
    """Beyond the paper: the local rheology of the coarse rings (mu(I), phi(I);
    :mod:`granavg.analysis.rheology`), and where the local law mu(I) holds (the band:
    rings up to the end of the shear band's decay range) and where it fails (beyond: a
    ring that flows while below mu_s, creep). None without the kinetic stress about the
    mean flow, part of the total stress."""
    p = a.p20
    if not all(f"dsigma_fluct_{k}" in p.values for k in TENSOR):
        return None
    res = rh.rheology(p, diameter=a.geo.d_mean, density=a.manifest["scene"]["rho_p"])
    band_end = _band(a)["decay_range_end_m"]
    label = f"{p.cells.n} rings"
    made = rh.fit_laws(res, labels=[label])
    fits = {k: f for k, f in made.items() if isinstance(f, rh.Fit)}
    why = {k: f for k, f in made.items() if not isinstance(f, rh.Fit)}
    a.series["rheology"] = (res, fits.get("mu_I"), fits.get("phi_I"))
    shown = ("inertial_number", "friction", "nu")                 # the report's columns
    num = a.numbers["rheology"] = {
        "diameter_m": res.meta["rheology"]["diameter"],
        "rho_p_kg_per_m3": res.meta["rheology"]["density"], "band_end_m": band_end,
        "per_ring": {"r_m": p.cells.centre.tolist(), "flags": [str(f) for f in res.flags],
                  **{k: res.values[k].tolist() for k in shown},
                  **{f"{k}_err": res.sem[k].tolist() for k in shown}},
        "no_fit": why}
    for key, fit in fits.items():
        num.update({n: v for k, v in fit.params.items() for n, v in
                    ((k, v), (f"{k}_err", fit.errors[k]))})
        num[f"{key}_chi2_dof"] = fit.chi2_dof
    text = "the local rheology mu(I) holds in the shear band and fails in its tail"
    tolerance = (f"every band ring within {rh.Z_OUTSIDE:g} errors of the fit; beyond the "
                 f"band a ring that flows (its strain rate's deviator distinguishable "
                 f"from 0, p = {rh.P_DEFINED:.3f}) "
                 f"below mu_s and the fit by more than {rh.Z_OUTSIDE:g} errors")
    if "mu_I" not in fits:
        return _claim(text, "inconclusive", f"no fit: {why['mu_I']}", kind="rheology",
                      tolerance=tolerance)
    fit = fits["mu_I"]
    law = rh.local_law(fit, p.cells.centre <= band_end)
    num.update(law)
    num["nonlocal_r_m"] = p.cells.centre[fit.nonlocal_cells[label]].tolist()
    params = ", ".join(f"{k} = {pm(v, fit.errors[k])}" for k, v in fit.params.items())
    return _claim(
        text, both(law["band"], law["tail"]),
        f"mu(I) over {int(fit.points[0].used.sum())} of {p.cells.n} rings: {params}, "
        f"chi^2/dof {plain(fit.chi2_dof, 2)}; band (to r = {band_end * 1e3:.1f} mm): "
        f"{law['band_points']} rings with I, largest |z| {plain(law['band_max_z'], 2)}; "
        f"beyond: {law['tail_points']} rings with I, {law['tail_nonlocal']} flowing below "
        f"mu_s (d = {num['diameter_m'] * 1e3:.2f} mm, rho_p = "
        f"{plain(num['rho_p_kg_per_m3'], 4)} kg/m^3)",
        kind="rheology", tolerance=tolerance)


#: The paper's claims and granavg's checks, in the report's order.
CLAIMS = (
    Claim("decay", "Fig. 2", _decay, ("fig2",)),
    Claim("decay_length", "Fig. 2", _compared("s_m", "decay length s", " mm", 1e3,
                                              S_TOLERANCE), ("fig2",)),
    Claim("wall_velocity", "Fig. 2", _compared("v0_over_omega_Ri", "v0/(Omega R_i)", "",
                                               1.0, V0_TOLERANCE), ("fig2",)),
    Claim("dilation", "Fig. 2", _dilation, ("fig2",)),
    Claim("layering", "Fig. 2", _layering, ("fig2",)),
    Claim("anisotropy", "Fig. 3", _anisotropy, ("fig3",)),
    Claim("exponents", "Fig. 4, Eq. 10", _exponents, ("fig4",)),
    Claim("quasi_static", "Fig. 4", _quasi_static, ("fig4",)),
    Claim("identity", "Fig. 5", _identity, ("fig5",)),
    Claim("master_curve", "Fig. 5", _collapse, ("fig5",)),
    Claim("colinear", "Fig. 6", _colinear, ("fig6",)),
    Claim("motion", "Fig. 7, Eqs. 11-12", _motion, ("fig7",)),
    Claim("eigen_rotation", "Figs. 8-9", _eigen_rotation, ("fig8", "fig9")),
    Claim("spins", "Figs. 8-9, micropolar", _spins_balance, ("spins",)),
    Claim("power", "the energy balance", _power),
    Claim("wall_loads", "the shear cell's torque", _wall_loads),
    Claim("rheology", "beyond the paper: mu(I)", _rheology, ("rheology",)),
)


def analyze(p20, p60, manifest, density_series=()) -> dict:
    """Analyse coarse and fine ring profiles of one run or one ensemble: every claim of
    :data:`CLAIMS`, with the numbers that decide it.

    Parameters
    ----------
    p20, p60 : Fields
        The same data averaged over coarse and fine rings (e.g. 20 and 60), with
        replicates for the errors of derived numbers.
    manifest : dict
        The run's manifest (scene, contact law).
    density_series : sequence of Fields, optional
        Coarse profiles of the same scene at other area fractions: Fig. 5's master curve
        is judged on the collapse of all of them with ``p20``.
    """
    for p in (p20, p60):
        if p.cells.n < 4:
            raise UserError(f"{p.cells.n} ring(s): the analysis needs at least 4 rings")
        missing = [q for q in ("nu", "rho", "v_phi", "omega", "F_rr", "sigma_rr", "dsigma_rr",
                               "eps_rr") if q not in p.values]
        if missing:
            raise UserError(f"the profiles lack {missing[0]}; average with all quantities "
                            "(the contact dump is needed)")
    a = Analysis(p20, p60, manifest, tuple(density_series), SceneNumbers(manifest["scene"]),
                 Estimator(p20, p60))
    for claim in CLAIMS:
        entry = claim.decide(a)
        if entry is not None:
            a.claims.append({**entry, "figures": list(claim.shows)})
    for p, errs in zip((p20, p60), derived_errors(a.est, a.geo.k_n)):
        a.series[f"errors_{p.cells.n}"] = errs
    est = a.est
    errors = {"kind": est.replicates.kind if est.replicates else None,
              "replicates": est.replicates.n if est.replicates else 0,
              "parts": est.replicates.parts if est.replicates else None,
              "profiles": (p20.meta or {}).get("errors", {}).get("method"),
              "sectors": (p20.meta or {}).get("errors", {}).get("sectors"),
              "lower_bound_rings": {str(p.cells.n): sorted(
                  {k for ks in (p.meta or {}).get("errors", {}).get("lower_bound", {}).values()
                   for k in ks}) for p in (p20, p60)}}
    if not est.views:
        log.warning("the profiles carry no replicates: derived numbers have no errors and "
                    "every claim is inconclusive; average them again with this granavg")
    summary = {"units": "SI (m, s, kg, N, Pa)",
               "run": {k: manifest.get(k) for k in ("preset", "scene", "contact_law", "derived",
                                                   "forecast", "preparation",
                                                   "lammps_version", "granavg_version")},
               "frames": p20.meta.get("frames") if p20.meta else None,
               "runs": runs_by_name((p20.meta or {}).get("runs")),
               "stationarity": stationarity(p20),
               "errors": errors, "numbers": plain_numbers(a.numbers), "claims": a.claims}
    summary["series"] = a.series
    return summary


