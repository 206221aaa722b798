"""Continuum analysis of ring profiles (paper sections 3-4, Eqs. 8-15), SI units.

Pure functions of arrays over rings (radius r in m); no plotting. Conventions:

- sigma = sum f (x) l with f the force on the particle is tension-positive (a compressed
  packing has sigma_rr < 0). Its *first* index is the force's, the second the branch
  vector's (sigma_ij = f_i l_j), so the force balance takes the divergence on the second
  index: (div T)_i = d_j T_ij.
- Momentum balance, steady and axisymmetric: div(sigma - dsigma) = 0, with the dynamic
  stress dsigma = rho <v (x) v> of Eq. 6 (the momentum flux; the mean flow's part
  rho v_phi^2 e_phi (x) e_phi is the inertial term of Eq. 11, so no separate rho v_phi^2
  is added). Times r, in components:
  radial (Eq. 11): r dT_rr/dr + T_rr - T_phiphi, tangential (Eq. 12 with this index
  order): r dT_phir/dr + T_rphi + T_phir, for T = sigma - dsigma. The paper prints
  r d(sigma_rphi)/dr, which is the same equation for the transposed convention
  (sigma_ij = l_i f_j); for a symmetric tensor both agree.
- Eq. 14: D_rphi = (dv/dr - v/r)/2, W_rphi = (dv/dr + v/r)/2, so a rigid rotation
  v = Omega r has D = 0 and W = Omega, the same sign as the particles' spin omega.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.errors import UserError


@dataclass(frozen=True)
class ShearBand:
    """Fit v_phi = v0 exp(-(r - R_i)/s) over the decay range (Fig. 2).

    Attributes
    ----------
    v0, v0_err : float
        Velocity at R_i, m/s, and its standard error.
    s, s_err : float
        Decay length, m, and its standard error.
    r_max : float
        Outer end of the decay range (m): where v_phi reaches the noise level.
    noise : float
        The noise level of v_phi, m/s.
    n_rings : int
        Rings in the fit.
    """

    v0: float
    v0_err: float
    s: float
    s_err: float
    r_max: float
    noise: float
    n_rings: int


def noise_level(v, sem):
    """Noise level of a velocity profile (m/s): the larger of three times the median
    standard error and the spread of v over the outer half of the rings, where the
    band has decayed."""
    v, sem = np.asarray(v, float), np.asarray(sem, float)
    tail = v[len(v) // 2:]
    tail = tail[np.isfinite(tail)]
    spread = np.sqrt(np.mean(tail**2)) if len(tail) else 0.0
    finite_sem = sem[np.isfinite(sem)]
    return max(3.0 * np.median(finite_sem) if len(finite_sem) else 0.0, spread)


def decay_range(v, sem):
    """Number of inner rings over which v_phi decays above the noise level."""
    noise = noise_level(v, sem)
    above = np.isfinite(v) & (np.asarray(v) > noise)
    n = int(np.argmin(above)) if not above.all() else len(above)
    return n, noise


def fit_shear_band(r, v, sem, R_i, n_rings=None) -> ShearBand:
    """Weighted least-squares fit of ln v = ln v0 - (r - R_i)/s over the decay range.

    Parameters
    ----------
    r, v, sem : ndarray, shape (n_rings,)
        Ring radius (m), v_phi and its standard error (m/s).
    R_i : float
        Inner ring radius (m).
    n_rings : int, optional
        Fit this many inner rings instead of the decay range (for replicates and the
        range-sensitivity of s). Rings among them with v_phi <= 0 get zero weight (the
        limit of their weight as v_phi -> 0+), as do rings without an error; the first
        ring must have both.

    The errors ``v0_err`` and ``s_err`` treat the rings as independent; the analysis
    replaces them by errors from replicates (:mod:`granavg.engine.uncertainty`).
    """
    r, v, sem = (np.asarray(x, float) for x in (r, v, sem))
    n, noise = decay_range(v, sem)
    use = np.ones(n, bool)
    if n_rings is not None:
        n = int(min(max(n_rings, 0), len(r)))
        # a ring whose v_phi is <= 0 (a replicate's noise near the band's end) gets zero
        # weight: the limit of the weight (v/sem)^2 as v -> 0+; the ring count stays n
        use = np.isfinite(v[:n]) & (v[:n] > 0) & np.isfinite(sem[:n]) & (sem[:n] > 0)
        if n and not use[0]:
            raise UserError("v_phi next to the inner wall is not positive (or has no "
                            "error): no decay to fit")
    if use.sum() < 3:
        raise UserError(f"v_phi is above its noise level ({noise:.3g} m/s) in only "
                        f"{int(use.sum())} ring(s) next to the inner wall; no decay to fit "
                        "(use finer rings or a longer run)")
    x, y = r[:n][use] - R_i, np.log(v[:n][use])
    sig = np.where(np.isfinite(sem[:n][use]) & (sem[:n][use] > 0),
                   sem[:n][use] / v[:n][use], 1.0)
    A = np.column_stack([np.ones(len(x)), x]) / sig[:, None]
    coef, *_ = np.linalg.lstsq(A, y / sig, rcond=None)
    resid = (y - coef[0] - coef[1] * x) / sig
    chi2 = max(np.sum(resid**2) / max(len(x) - 2, 1), 1.0)  # scatter beyond the errors
    cov = np.linalg.inv(A.T @ A) * chi2
    v0, s = np.exp(coef[0]), -1.0 / coef[1]
    return ShearBand(v0=v0, v0_err=v0 * np.sqrt(cov[0, 0]), s=s,
                     s_err=np.sqrt(cov[1, 1]) / coef[1] ** 2, r_max=r[n - 1], noise=noise,
                     n_rings=n)


def power_law(r, y, sem=None):
    """Exponent n (and its standard error) of |y| ~ r^n, fitted in log-log.

    With standard errors the fit is weighted (relative errors sem/|y|) and the error
    follows from them, inflated by the scatter if that is larger; without, points weigh
    the same and the error comes from the scatter alone. Either error assumes
    independent rings; ring errors of one run are strongly correlated (the whole cell's
    pressure moves every ring), so the analysis takes the exponent's error from
    replicates instead.
    """
    r, y = np.asarray(r, float), np.abs(np.asarray(y, float))
    weighted = sem is not None
    sem = np.asarray(sem, float) if weighted else np.ones_like(y)
    ok = np.isfinite(y) & (y > 0) & np.isfinite(sem)
    if ok.sum() < 3:
        raise UserError("fewer than three rings with a value: no exponent to fit")
    sig = np.where(sem[ok] > 0, sem[ok] / y[ok], 1.0) if weighted else np.ones(ok.sum())
    A = np.column_stack([np.ones(ok.sum()), np.log(r[ok])]) / sig[:, None]
    coef, *_ = np.linalg.lstsq(A, np.log(y[ok]) / sig, rcond=None)
    chi2 = np.sum((np.log(y[ok]) / sig - A @ coef) ** 2) / max(ok.sum() - 2, 1)
    chi2 = max(chi2, 1.0) if weighted else chi2
    return coef[1], np.sqrt(np.linalg.inv(A.T @ A)[1, 1] * chi2)


def trace(T):
    """tr T of tensors given as (rr, rphi, phir, phiphi) components, each (n_rings,)."""
    return np.asarray(T[0]) + np.asarray(T[3])


def deviator_norm(T):
    """|dev T|: the magnitude of the eigenvalues +-(T_1 - T_2)/2 of the deviator of the
    symmetric part of T, sqrt(((T_rr - T_phiphi)/2)^2 + ((T_rphi + T_phir)/2)^2).

    This is the "dev" of the analysis and of Figs. 3 and 5 (half the eigenvalue
    difference). The paper's text does not define its scalar norm; the Frobenius norm
    of the deviator is sqrt(2) times this, the full eigenvalue difference 2 times.
    """
    rr, rp, pr, pp = (np.asarray(t, float) for t in T)
    return np.sqrt(0.25 * (rr - pp) ** 2 + 0.25 * (rp + pr) ** 2)


def orientation(T):
    """Angle (rad, in (-pi/2, pi/2]) from e_r to the eigenvector of the symmetric part of
    T whose eigenvalue has the largest magnitude (the "major" one, Fig. 6)."""
    rr, rp, pr, pp = (np.asarray(t, float) for t in T)
    off = 0.5 * (rp + pr)
    phi = 0.5 * np.arctan2(2 * off, rr - pp)            # eigenvector of the larger eigenvalue
    mean = 0.5 * (rr + pp)
    # if the most negative eigenvalue is the larger in magnitude, take the other axis
    major_negative = mean < 0
    phi = np.where(major_negative, phi + np.pi / 2, phi)
    return (phi + np.pi / 2) % np.pi - np.pi / 2


def stiffness(sigma, eps, k_n):
    """2 pi E / k_n = tr sigma / tr eps and pi G / k_n = |dev sigma| / |dev eps|, both
    divided by k_n (N/m) as in Fig. 5; arrays over rings."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return trace(sigma) / trace(eps) / k_n, deviator_norm(sigma) / deviator_norm(eps) / k_n


def derivative(r, y):
    """dy/dr by second-order finite differences on the ring radii (one-sided at ends)."""
    return np.gradient(np.asarray(y, float), np.asarray(r, float), edge_order=2)


def equations_of_motion(r, T):
    """Residuals r (div T)_r and r (div T)_phi per ring (Pa), steady and axisymmetric.

    Parameters
    ----------
    r : ndarray, shape (n_rings,)
        Ring radii, m.
    T : tuple of 4 ndarray, shape (n_rings,) each
        Components rr, rphi, phir, phiphi (Pa), first index the force's: the static
        stress sigma alone, or the total sigma - dsigma (momentum balance; see the
        module's conventions).

    Returns
    -------
    radial : ndarray
        r dT_rr/dr + T_rr - T_phiphi (Eq. 11; with T = sigma - dsigma its inertial term
        rho v_phi^2 comes from -dsigma_phiphi).
    tangential : ndarray
        r dT_phir/dr + T_rphi + T_phir (Eq. 12, divergence on the second index).
    """
    rr, rp, pr, pp = (np.asarray(t, float) for t in T)
    radial = r * derivative(r, rr) + (rr - pp)
    tangential = r * derivative(r, pr) + (rp + pr)
    return radial, tangential


def momentum_flux_total(sigma, dsigma):
    """sigma - dsigma componentwise: the tensor whose divergence vanishes in steady
    flow (Pa)."""
    return tuple(np.asarray(s) - np.asarray(d) for s, d in zip(sigma, dsigma))


def deformation_rate_and_spin(r, v_phi):
    """D_rphi and W_rphi (1/s) from a velocity profile by finite differences (Eq. 14)."""
    dv = derivative(r, v_phi)
    return 0.5 * (dv - v_phi / r), 0.5 * (dv + v_phi / r)


def deformation_rate_and_spin_fit(r, band: ShearBand, R_i):
    """D_rphi and W_rphi (1/s) of the fitted exponential (Eq. 15 and its spin twin)."""
    v = band.v0 * np.exp(-(np.asarray(r) - R_i) / band.s)
    return -0.5 * v * (1 / band.s + 1 / r), -0.5 * v * (1 / band.s - 1 / r)


def eigen_rotation(omega, W):
    """omega* = omega - W_rphi (1/s): the particles' spin beyond the continuum's (Fig. 9)."""
    return np.asarray(omega) - np.asarray(W)
