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

import numpy as np

from granavg.engine.quantities import TENSOR

from granavg.errors import UserError


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


def principal_axis(T):
    """Angle (rad, in (-pi/2, pi/2]) from the first axis (e_r, e_x) towards the second to
    the eigenvector of the larger eigenvalue of the symmetric part of a 2D tensor T,
    given as (rr, rphi, phir, phiphi) components (arrays of any shape)."""
    rr, rp, pr, pp = (np.asarray(t, float) for t in T)
    return 0.5 * np.arctan2(rp + pr, rr - pp)


def orientation(T):
    """Angle (rad, in (-pi/2, pi/2]) from e_r to the eigenvector of the symmetric part of
    T whose eigenvalue has the largest magnitude (the "major" one, Fig. 6)."""
    phi = principal_axis(T)
    mean = 0.5 * (np.asarray(T[0], float) + np.asarray(T[3], float))
    # if the most negative eigenvalue is the larger in magnitude, take the other axis
    major_negative = mean < 0
    phi = np.where(major_negative, phi + np.pi / 2, phi)
    return (phi + np.pi / 2) % np.pi - np.pi / 2


def angle_diff(a, b):
    """a - b for axes' angles in degrees (an axis and its reverse are one), wrapped into
    [-90, 90)."""
    return (np.asarray(a) - np.asarray(b) + 90.0) % 180.0 - 90.0


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


def deformation_rate_and_spin_fit(r, band, R_i):
    """D_rphi and W_rphi (1/s) of the fitted exponential (Eq. 15 and its spin twin);
    ``band`` has v0 (m/s) and s (m), e.g. a :class:`granavg.analysis.shear_band.ShearBand`."""
    v = band.v0 * np.exp(-(np.asarray(r) - R_i) / band.s)
    return -0.5 * v * (1 / band.s + 1 / r), -0.5 * v * (1 / band.s - 1 / r)


def eigen_rotation(omega, W):
    """omega* = omega - W_rphi (1/s): the particles' spin beyond the continuum's (Fig. 9)."""
    return np.asarray(omega) - np.asarray(W)


def tensor(p, name):
    """The four components of a tensor profile (``name_rr``, ...), as a tuple of arrays."""
    return tuple(p.values[f"{name}_{k}"] for k in TENSOR)
