"""The shear band's exponential fit (Fig. 2): one stated estimator, and how much its
choices move the answer.

The paper fits v_phi = v0 exp(-(r - R_i)/s) "in the range of decay" of its 20- and
60-ring profiles and gives v0/(Omega R_i) = 0.645, s = 12.7 mm. It does not say which
rings, which weights, or how the first layer counts; between reasonable choices s moves
by about 30% on granavg's profiles, more than any comparison with the paper can bear.
granavg's estimator (:data:`ESTIMATOR`):

- **quantity**: ln v_phi against r - R_i (the paper's formula), on the finer profile;
- **first ring**: the first whose centre lies at least one mean diameter from the inner
  wall. The disks touching the wall move with it as a block, so rings finer than a disk
  see a staircase there (the whole layer at one velocity), not the decay; the layer
  taken at its centre lies on the exponential of the rings beyond it, but its rings pull
  a fit towards a plateau;
- **last ring**: the one before v_phi first falls below three times its noise, its own
  standard error or the floor (the root mean square of v_phi over the outer half of the
  rings), whichever is larger: below, ln v_phi has an error above 1/3, or the floor
  bends it off the exponential;
- **weights**: 1 / (e_i^2 + tau^2) in ln v_phi, with e_i = sem_i / v_i and tau the
  scatter about the exponential beyond the errors (chosen so that chi^2 per degree of
  freedom is 1; tau = 0 where the errors explain the scatter). Precise rings count more,
  but no ring dominates where the profile departs from an exponential by more than the
  errors say;
- **statistical error**: the same fit (same rings, same weights) on every replicate,
  the realisations of an ensemble or the sectors and time blocks of one run
  (:class:`granavg.paper.claims.Estimator`);
- **systematic error**: the largest shift of v0 and s among the estimator's variants
  (:data:`VARIANTS`: the range's end 2 rings shorter or longer, the first layer in,
  equal or error-only weights), each reported. Also reported, not counted: v_phi /
  (Omega r) fitted as an exponential (a different model: the paper's formula is for
  v_phi; on an exact exponential of s = 12.7 mm it gives 11.7 mm) and the estimator on
  the coarser profile (:data:`ALSO`).

Units: r, R_i, s in m; v_phi and its errors in m/s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from granavg.errors import UserError

#: v_phi must exceed this many of its standard errors to count as decaying, not noise.
SIGNIFICANCE = 3.0


@dataclass(frozen=True)
class BandRule:
    """The choices of one shear-band estimator.

    Attributes
    ----------
    first_layer : bool
        Fit the rings within one mean diameter of the inner wall too.
    weights : {"scatter", "errors", "equal"}
        1/(e^2 + tau^2) with the fitted scatter tau, 1/e^2, or equal weights (e: the
        relative error of v_phi, the error of ln v_phi).
    scaled : bool
        Fit ln(v_phi / (Omega r)) instead of ln v_phi (v0 then is Omega R_i times the
        intercept at R_i).
    end_shift : int
        Rings added to (negative: removed from) the end of the decay range.
    """

    first_layer: bool = False
    weights: str = "scatter"
    scaled: bool = False
    end_shift: int = 0


#: granavg's estimator (module docstring).
ESTIMATOR = BandRule()

#: The estimator's choices changed one at a time; the largest shift is its systematic
#: error.
VARIANTS = {
    "range 2 rings shorter": BandRule(end_shift=-2),
    "range 2 rings longer": BandRule(end_shift=2),
    "first layer in": BandRule(first_layer=True),
    "equal weights": BandRule(weights="equal"),
    "error weights only": BandRule(weights="errors"),
}
#: Reported beside the variants, not counted in the systematic error: another model
#: (on the fine rings) and the estimator on the coarse rings.
ALSO = {"v_phi/(Omega r) fitted": BandRule(scaled=True), "coarse rings": ESTIMATOR}


@dataclass(frozen=True)
class ShearBand:
    """A fit of v_phi = v0 exp(-(r - R_i)/s) (Fig. 2).

    Attributes
    ----------
    v0, s : float
        Velocity at R_i (m/s) and decay length (m).
    start, end : int
        The fitted rings are ``start:end`` (``end`` also ends the band: the decay range).
    sem : ndarray, shape (end - start,)
        The standard errors of the fitted rings' v_phi (m/s; kept for replicates).
    tau : float
        The scatter of ln v_phi about the exponential beyond the errors.
    noise : float
        The noise level of v_phi, m/s (:func:`noise_level`).
    r_max : float
        Centre of the last fitted ring, m.
    rule : BandRule
    """

    v0: float
    s: float
    start: int
    end: int
    sem: np.ndarray
    tau: float
    noise: float
    r_max: float
    rule: BandRule

    @property
    def n_rings(self) -> int:
        """Rings in the fit."""
        return self.end - self.start

    def weights(self, v):
        """Weights of the fitted rings' ln v_phi for the values ``v`` there: 1/(e^2 +
        tau^2) with e = sem/v (0 where v <= 0, the limit v -> 0+), or all 1."""
        if self.rule.weights == "equal":
            return np.ones(len(v))
        with np.errstate(divide="ignore", over="ignore"):
            e = np.where(v > 0, self.sem / v, np.inf)
            return 1.0 / (e**2 + self.tau**2)


def noise_floor(v) -> float:
    """Root mean square of v_phi over the outer half of the rings (m/s), where the band
    has decayed."""
    v = np.asarray(v, float)
    tail = v[len(v) // 2:]
    tail = tail[np.isfinite(tail)]
    return float(np.sqrt(np.mean(tail**2))) if len(tail) else 0.0


def noise_level(v, sem) -> float:
    """Noise level of a v_phi profile (m/s): the larger of three times the median
    standard error and :func:`noise_floor`."""
    finite = np.asarray(sem, float)
    finite = finite[np.isfinite(finite)]
    return max(SIGNIFICANCE * float(np.median(finite)) if len(finite) else 0.0,
               noise_floor(v))


def decay_end(v, sem, start=0) -> int:
    """Index after the last ring, from ``start`` on, before v_phi first falls to
    :data:`SIGNIFICANCE` times its noise: its own standard error or the
    :func:`noise_floor`, whichever is larger (below, ln v_phi is off the exponential or
    its error exceeds 1/3)."""
    v, sem = np.asarray(v, float), np.asarray(sem, float)
    level = SIGNIFICANCE * np.maximum(np.where(np.isfinite(sem), sem, np.inf), noise_floor(v))
    above = np.isfinite(v[start:]) & (v[start:] > level[start:])
    return start + (int(np.argmin(above)) if not above.all() else len(above))


def first_ring(r, R_i, d_layer) -> int:
    """Index of the first ring whose centre lies at least ``d_layer`` (the mean diameter)
    from the inner wall."""
    return int(np.searchsorted(np.asarray(r, float) - R_i, d_layer * (1 - 1e-12)))


def line(x, y, w):
    """Weighted least squares of y = a + b x; returns (a, b)."""
    A = np.column_stack([np.ones(len(x)), x]) * np.sqrt(w)[:, None]
    (a, b), *_ = np.linalg.lstsq(A, y * np.sqrt(w), rcond=None)
    return a, b


def scatter(x, y, e) -> float:
    """The tau >= 0 with sum (y - a - b x)^2 / (e^2 + tau^2) = n - 2 for the line fitted
    with those weights (0 if the errors e already explain the scatter)."""
    def chi2(tau):
        w = 1.0 / (e**2 + tau**2)
        a, b = line(x, y, w)
        return np.sum(w * (y - a - b * x) ** 2) / (len(x) - 2)

    if len(x) < 3 or chi2(0.0) <= 1.0:
        return 0.0
    lo, hi = 0.0, float(np.ptp(y)) + float(np.max(e)) + 1.0
    for _ in range(80):                 # chi2 falls monotonically as tau grows
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chi2(mid) > 1.0 else (lo, mid)
    return hi


def _log_values(r, v, R_i, Omega, scaled):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(v / (Omega * r)) if scaled else np.log(v)


def fit_band(r, v, sem, R_i, d_layer, Omega, rule: BandRule = ESTIMATOR) -> ShearBand:
    """Fit the shear band of one profile by ``rule`` (module docstring).

    Parameters
    ----------
    r, v, sem : ndarray, shape (n_rings,)
        Ring centres (m), v_phi and its standard errors (m/s).
    R_i, d_layer, Omega : float
        Inner wall radius (m), the first layer's width (the mean diameter, m), the inner
        wall's angular velocity (rad/s; only for ``rule.scaled``).
    """
    r, v, sem = (np.asarray(x, float) for x in (r, v, sem))
    start = 0 if rule.first_layer else first_ring(r, R_i, d_layer)
    end = decay_end(v, sem, start) + rule.end_shift
    end = min(max(end, start), len(r))
    ok = np.isfinite(v[start:end]) & (v[start:end] > 0)   # v <= 0 (beyond): zero weight
    if ok.sum() < 3 or not ok[0]:
        raise UserError(
            f"v_phi decays above its noise in only {int(ok.sum())} ring(s) beyond the "
            f"first layer ({len(r)} rings); no decay to fit (use finer rings or a longer run)")
    rr, vv = r[start:end][ok], v[start:end][ok]
    e = sem[start:end][ok] / vv
    if rule.weights != "equal" and not np.all(np.isfinite(e) & (e > 0)):
        raise UserError("v_phi has no standard error in the decay range; average with "
                        "errors (several frames) to fit the band")
    tau = (scatter(rr - R_i, _log_values(rr, vv, R_i, Omega, rule.scaled), e)
           if rule.weights == "scatter" else 0.0)
    band = ShearBand(v0=np.nan, s=np.nan, start=start, end=end, sem=sem[start:end], tau=tau,
                     noise=noise_level(v, sem), r_max=float(r[end - 1]), rule=rule)
    return refit(band, r, v, R_i, Omega)


def refit(band: ShearBand, r, v, R_i, Omega) -> ShearBand:
    """The fit of ``band`` (its rings, errors and scatter) on another profile ``v`` of the
    same rings: a replicate. A ring whose v_phi is <= 0 there gets zero weight (the
    limit of its weight as v_phi -> 0+); the first fitted ring must be positive."""
    r, v = np.asarray(r, float), np.asarray(v, float)
    sl = slice(band.start, band.end)
    ok = np.isfinite(v[sl]) & (v[sl] > 0)
    if not ok[0] or ok.sum() < 2:
        raise UserError("v_phi is not positive where the band starts: no decay to fit")
    x = r[sl][ok] - R_i
    y = _log_values(r[sl][ok], v[sl][ok], R_i, Omega, band.rule.scaled)
    a, b = line(x, y, band.weights(v[sl])[ok])
    v0 = np.exp(a) * (Omega * R_i if band.rule.scaled else 1.0)
    with np.errstate(divide="ignore"):
        s = -1.0 / b
    return dataclasses.replace(band, v0=float(v0), s=float(s))


def sensitivity(fine, coarse, R_i, d_layer, Omega, primary: ShearBand) -> dict:
    """v0 and s of every variant of :data:`VARIANTS` and :data:`ALSO`; NaN where one
    cannot fit.

    Parameters
    ----------
    fine, coarse : (r, v, sem)
        Ring centres, v_phi and its errors of the two profiles.

    Returns
    -------
    dict
        ``{name: {"v0": m/s, "s": m}}``, and ``"largest shift"``: ``{"v0", "s"}`` the
        largest absolute shift of a :data:`VARIANTS` fit from ``primary`` (the
        systematic errors).
    """
    out = {}
    for name, rule in (*VARIANTS.items(), *ALSO.items()):
        r, v, sem = coarse if name == "coarse rings" else fine
        try:
            b = fit_band(r, v, sem, R_i, d_layer, Omega, rule)
            out[name] = {"v0": b.v0, "s": b.s}
        except UserError:
            out[name] = {"v0": np.nan, "s": np.nan}
    shifts = {k: [abs(out[n][k] - getattr(primary, k)) for n in VARIANTS
                  if np.isfinite(out[n][k])] for k in ("v0", "s")}
    out["largest shift"] = {k: float(max(d)) if d else np.nan for k, d in shifts.items()}
    return out
