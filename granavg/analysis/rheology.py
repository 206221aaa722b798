"""Local rheology from any granavg fields, and the constitutive fits across cells and runs
(docs/rheology.md).

Per cell (2D and 3D, any cells, exact weights or smoothing kernels), from the fields'
stress, kinetic stress and velocity (or the kernels' strain rate), the columns of
:data:`COLUMNS`: the ``pressure`` P, the ``shear_stress`` tau, the ``shear_rate``
gamma_dot, the ``inertial_number`` I, the ``friction`` mu = tau / P, the packing
fraction ``nu``, the normal-stress differences ``N1`` (and ``N2`` in 3D), the
``axes_angle`` between the stress's and the strain rate's principal axes and the
``fluidity`` g = gamma_dot / mu (:func:`rheology`). Every error comes from the fields'
replicates (:class:`~granavg.engine.uncertainty.blocking.Replicates`): the same function
applied to each replicate's fields, its spread taken as the fields' own errors are
(jackknife blocks, sectors, realisations), so every correlation between the columns is
carried; a column undefined on a replicate where the fields define it has no error
(NaN). A shear rate or shear stress is defined where its deviator differs from 0,
its components judged together (:func:`deviator_nonzero`).

Across cells, runs and scenes: mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) (Jop,
Forterre and Pouliquen, Nature 441, 727, 2006) and phi(I) = phi_max - a I, fitted to the
pooled points weighted by their errors (:func:`fit_mu_I`, :func:`fit_phi_I`), the
parameters' errors from refits on every replicate of each source, and the cells where
the local law fails (:class:`Fit`).

Conventions (docs/analysis.md): stresses are tension-positive (compression negative) and
sigma_ij = f_i l_j; dsigma_fluct = rho <v' (x) v'> is a momentum flux (positive), so

- total stress S = sym(sigma - dsigma_fluct) (the antisymmetric part, balanced by the
  couples, does not enter);
- P = -tr S / D (D = 2 or 3), s = S + P 1 its deviator, tau = sqrt(s:s / 2): sqrt(J2)
  in 3D, in 2D sqrt(((S_xx - S_yy)/2)^2 + S_xy^2), half the difference of the principal
  stresses; simple shear S = -P 1 + tau_0 (e_x e_y + e_y e_x) gives tau = tau_0;
- D = sym(grad v), d = D - tr D / D 1 its deviator, gamma_dot = sqrt(2 d:d): simple
  shear v_x = g y gives gamma_dot = |g|; tau = mu P and gamma_dot are Jop et al.'s
  |tau| and |gamma_dot| (their gamma_dot_ij = 2 D_ij);
- I = gamma_dot d_p / sqrt(P / rho_p), mu = tau / P, g = gamma_dot / mu;
- the flow frame: e_f, e_g bisect the principal axes of d (its most stretching and most
  compressing), e_f the one the velocity lies along, or where it does not decide, the
  one along which the velocity does not change (L_ij = d v_i / d x_j, in a polar basis
  the components' derivatives without the curvature terms; :func:`flow_frame`), e_v (3D)
  d's middle axis; N1 = S_ff - S_gg, N2 = S_gg - S_vv. Simple shear v_x = g y gives
  e_f = e_x, e_g = e_y, e_v = e_z; Couette flow v_phi(r), whatever its profile,
  e_f = e_phi, e_g = e_r; the replicates keep the fields' e_f;
- axes_angle: 2D, the principal axis of S minus d's (their most tensile, equally their
  most compressive), degrees in [-90, 90), counter-clockwise from the cells' first axis
  (e_r, e_x) positive; 3D, the angle between S's and d's most compressive axes, in
  [0, 90].
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from granavg.analysis.continuum import angle_diff, principal_axis
from granavg.engine.fields import Fields
from granavg.engine.quantities import columns
from granavg.engine.species import MIXTURE
from granavg.engine.uncertainty.blocking import Replicates
from granavg.engine.unit_system import SI
from granavg.errors import ParameterError, UserError, literal

log = logging.getLogger(__name__)

#: A pressure at or below this many of its own errors (or not positive) carries no ratio:
#: what divides by it is NaN. A shear rate or shear stress is judged at the same level,
#: :data:`P_DEFINED`, on its deviator's components together (:func:`deviator_nonzero`).
Z_DEFINED = 2.0
#: The one-sided Gaussian tail beyond :data:`Z_DEFINED` (0.0228): the share of cells
#: without shear that the test of a deviator lets through.
P_DEFINED = 0.5 * math.erfc(Z_DEFINED / math.sqrt(2.0))
#: A point more than this many errors off a fit lies outside it.
Z_OUTSIDE = 3.0
#: A point is judged nonlocal with its errors scaled by the law's misfit over the kept
#: points, or over this many of them next to it in I where that is larger.
NEAREST = 3
#: P, tau and gamma_dot at or below this share of the stress's or the velocity
#: gradient's norm are round-off (a rigid rotation's D), whatever their errors.
ROUND_OFF = 1e-10
#: The flow direction is decided where the velocity's part across it is at most this
#: share of its part along it, or else where the velocity changes along it at most this
#: share of its change across it (:func:`flow_frame`; 0 in simple shear).
FRAME_RATIO = 0.5


@dataclass(frozen=True)
class Column:
    """One column of the rheology: its name, its physical dimension in a unit system's
    named units (:meth:`granavg.engine.unit_system.UnitSystem.unit`) and what it is."""

    name: str
    unit: str
    help: str


#: The rheology's columns, in the table's order (N2 in 3D only).
COLUMNS = {c.name: c for c in (
    Column("pressure", "{stress}", "P = -tr(S)/D, S = sym(sigma - dsigma_fluct)"),
    Column("shear_stress", "{stress}", "tau = sqrt(s:s/2), s the deviator of S"),
    Column("shear_rate", "1/{time}", "gamma_dot = sqrt(2 d:d), d the deviator of D"),
    Column("inertial_number", "1", "I = gamma_dot d_p / sqrt(P / rho_p)"),
    Column("friction", "1", "mu = tau / P"),
    Column("nu", "1", "packing (volume) fraction, the fields' nu"),
    Column("N1", "{stress}", "first normal-stress difference, S_ff - S_gg"),
    Column("N2", "{stress}", "second normal-stress difference, S_gg - S_vv (3D)"),
    Column("axes_angle", "deg", "the angle between the principal axes of S and of d"),
    Column("fluidity", "1/{time}", "g = gamma_dot / mu"),
)}


def catalogue(system=SI) -> str:
    """The columns in words, for help texts, their units in ``system`` (SI by default):
    ``pressure [Pa] P = -tr(S)/D, ...; shear_stress [Pa] ...``."""
    return "; ".join(f"{c.name} [{system.unit(c.unit)}] {c.help}" for c in COLUMNS.values())


#: The flags the rheology adds to a cell, and what they mean.
FLAGS = {
    "no_pressure": f"pressure <= 0 or within {Z_DEFINED:g} errors of 0: friction, "
                   "inertial_number and fluidity are NaN",
    "no_shear": "shear_rate round-off, or the strain rate's deviator not distinguishable "
                f"from 0 (p = {P_DEFINED:.3f}, its components together): inertial_number, "
                "fluidity, N1, N2 and axes_angle are NaN",
    "no_shear_stress": "shear_stress round-off, or the stress deviator not distinguishable "
                       f"from 0 (p = {P_DEFINED:.3f}, its components together): "
                       "axes_angle and fluidity are NaN",
    "no_flow_frame": "no flow and gradient directions (the flow is not a shear along its "
                     "streamlines): N1 and N2 are NaN",
    "no_diameter": "a species whose diameter is not known: inertial_number is NaN",
}


# -- per cell ------------------------------------------------------------------------

def _tensor(values, name, axes) -> np.ndarray:
    """A tensor's columns as an array (..., n_cells, D, D), [i, j] its ij component."""
    D = len(axes)
    parts = [np.asarray(values[c], float) for c in columns(name, axes)]
    return np.stack(parts, axis=-1).reshape(*parts[0].shape, D, D)


def _sym(T):
    return 0.5 * (T + np.swapaxes(T, -1, -2))


def _deviator(T):
    D = T.shape[-1]
    return T - np.trace(T, axis1=-2, axis2=-1)[..., None, None] / D * np.eye(D)


def _eigh(T):
    """Eigenvalues (ascending) and eigenvectors (columns) of symmetric tensors; NaN
    where a tensor is not finite."""
    ok = np.all(np.isfinite(T), axis=(-2, -1))
    w, V = np.linalg.eigh(np.where(ok[..., None, None], T, 0.0))
    return np.where(ok[..., None], w, np.nan), np.where(ok[..., None, None], V, np.nan)


def _derivative(y, x, axis, period=None):
    """dy/dx along ``axis`` by second-order differences on the points ``x`` (one-sided
    at the ends; periodic where ``period`` is given)."""
    if period is not None:
        n = y.shape[axis]
        y = np.concatenate([np.take(y, [-1], axis), y, np.take(y, [0], axis)], axis=axis)
        x = np.r_[x[-1] - period, x, x[0] + period]
        return np.take(np.gradient(y, x, axis=axis), np.arange(1, n + 1), axis=axis)
    return np.gradient(y, x, axis=axis, edge_order=2 if len(x) > 2 else 1)


def velocity_gradient(v, cells) -> np.ndarray:
    """L_ij = d v_i / d x_j at the cells' centres, by finite differences of the velocity
    profile over them.

    Along a dimension of the cells' grid (``cells.grid()``) the derivative is taken
    between the cells' centres (second order, one-sided at the ends; an angle's closes
    on itself over 2 pi); along a direction the cells average over (the length of a
    slab, the angle of a ring) the fields are uniform and it is 0. In a polar basis
    (axes r, phi[, z]) the derivatives along phi are (1/r) d/dphi and the curvature
    terms are added: L_rphi -= v_phi / r, L_phiphi += v_r / r, so that a rigid
    rotation has D = 0 and D_rphi = (dv_phi/dr - v_phi/r) / 2 (Eq. 14).

    Parameters
    ----------
    v : ndarray, shape (..., n_cells, D)
        Velocity in the cells' basis (leading axes: replicates).
    cells : Cells

    Returns
    -------
    ndarray, shape (..., n_cells, D, D)
    """
    dims, shape, edges = cells.grid()
    axes, D = tuple(cells.axes), len(cells.axes)
    lead = v.shape[:-2]
    grid = np.asarray(v, float).reshape(*lead, *shape, D)
    L = np.zeros(grid.shape + (D,))
    centres = [0.5 * (np.asarray(e[1:], float) + np.asarray(e[:-1], float)) for e in edges]
    r = None
    if axes[:2] == ("r", "phi"):
        k = list(dims).index("r")
        r = centres[k].reshape([-1 if j == k else 1 for j in range(len(dims))])
    for k, (name, c) in enumerate(zip(dims, centres)):
        if len(c) < 2:
            continue
        span = float(edges[k][-1] - edges[k][0])
        if name in cells.angles:
            closed = 2 * np.pi if np.isclose(span, 2 * np.pi) else None
            dv = _derivative(grid, c, len(lead) + k, closed) / r[..., None]
        else:
            dv = _derivative(grid, c, len(lead) + k)
        L[..., axes.index(name)] = dv
    if r is not None:
        L[..., 0, 1] -= grid[..., 1] / r
        L[..., 1, 1] += grid[..., 0] / r
    return L.reshape(*lead, -1, D, D)


def strain_rate(values, cells) -> tuple:
    """The strain rate D = sym(L) and the velocity gradient L of fields (or of their
    replicates): a smoothing kernel's ``D_*`` (with ``gradv_*``, or L = D - W from its
    ``W_*``) where the fields hold them, else finite differences of ``v_*``
    (:func:`velocity_gradient`).

    Returns
    -------
    L : ndarray, shape (..., n_cells, D, D), or None
        None where the fields hold D but neither gradv nor W.
    D : ndarray, shape (..., n_cells, D, D)
    how : str
        Where they come from, in words.
    """
    axes = cells.axes
    if all(c in values for c in columns("D", axes)):
        D = _tensor(values, "D", axes)
        if all(c in values for c in columns("gradv", axes)):
            return _tensor(values, "gradv", axes), D, "the smoothing kernel's D and gradv"
        if all(c in values for c in columns("W", axes)):
            return D - _tensor(values, "W", axes), D, "the smoothing kernel's D and W"
        return None, D, "the smoothing kernel's D (no gradv or W)"
    names = columns("v", axes)
    if not all(c in values for c in names):
        raise UserError(f"the fields lack the velocity ({', '.join(names)}) and the strain "
                        "rate D: average with the quantity v")
    L = velocity_gradient(np.stack([np.asarray(values[c], float) for c in names], -1), cells)
    return L, _sym(L), "finite differences of the velocity over the cells' centres"


def flow_frame(d, L=None, v=None, flow=None) -> tuple:
    """The flow, gradient and vorticity directions of a shear-like flow.

    e_f and e_g bisect the principal axes of the strain rate's deviator ``d`` (its most
    stretching and most compressing: in a shear along e_f with the velocity varying
    along e_g, these lie at 45 degrees between them); e_v (3D) is d's middle axis.
    Which bisector is the flow direction: the one the velocity lies along (the flow is
    a shear along its streamlines: Couette flow, irrotational or not), where
    |v . e_g| <= :data:`FRAME_RATIO` |v . e_f| and the velocity gradient does not say
    the opposite; else the one along which the velocity does not change, where
    |L e_f| <= :data:`FRAME_RATIO` |L e_g| (simple shear v_x = g y: |L e_f| = 0, at
    v = 0 too; pure shear, with no flow direction: equal). Undefined where neither
    decides. Given ``flow`` (the fields' own e_f, for their replicates), the bisector
    nearer to it, defined where it is.

    Parameters
    ----------
    d : ndarray, shape (..., D, D)
    L : ndarray, shape (..., D, D), optional
        The velocity's change, L_ij = d v_i / d x_j; in a polar basis the components'
        derivatives without the curvature terms (:func:`local`), so that a flow along
        circles, v_phi(r) e_phi, does not change along e_phi.
    v : ndarray, shape (..., D), optional
        The velocity.
    flow : ndarray, shape (..., D), optional
        The flow direction to follow (NaN: undefined); L and v are then not used.

    Returns
    -------
    e_f, e_g : ndarray, shape (..., D)
    e_v : ndarray, shape (..., 3), or None in 2D
    defined : ndarray of bool, shape (...)
    """
    _, V = _eigh(d)
    lo, hi = V[..., :, 0], V[..., :, -1]
    b1, b2 = (hi + lo) / np.sqrt(2.0), (hi - lo) / np.sqrt(2.0)
    vort = V[..., :, 1] if d.shape[-1] == 3 else None
    finite = np.all(np.isfinite(d), axis=(-2, -1))
    if flow is not None:
        first = np.abs(np.sum(b1 * flow, -1)) >= np.abs(np.sum(b2 * flow, -1))
        return (np.where(first[..., None], b1, b2), np.where(first[..., None], b2, b1),
                vort, finite & np.all(np.isfinite(flow), axis=-1))
    none = np.zeros(d.shape[:-2], bool)

    def decide(n1, n2):
        """(b1 is the flow direction, clearly so) from evidence n1, n2 >= 0 for each."""
        with np.errstate(invalid="ignore"):
            return n1 >= n2, (np.fmin(n1, n2) <= FRAME_RATIO * np.fmax(n1, n2)) & (
                np.fmax(n1, n2) > 0)

    def change(b):
        return np.linalg.norm(np.einsum("...ij,...j->...i", L, b), axis=-1)
    by_L, clear_L = decide(change(b2), change(b1)) if L is not None else (none, none)
    by_v, clear_v = decide(*(np.abs(np.sum(v * b, axis=-1)) for b in (b1, b2))) \
        if v is not None else (none, none)
    use_v = clear_v & ~(clear_L & (by_L != by_v))
    first = np.where(use_v, by_v, by_L)[..., None]
    return (np.where(first, b1, b2), np.where(first, b2, b1), vort,
            (use_v | clear_L) & finite)


def _along(S, e):
    """e . S . e, shapes (..., D, D) and (..., D) -> (...)."""
    return np.einsum("...i,...ij,...j->...", e, S, e)


def axes_angle(S, d) -> np.ndarray:
    """The angle (deg) between the principal axes of the stress S and of the strain
    rate's deviator d: in 2D the principal axis of S minus d's
    (:func:`~granavg.analysis.continuum.principal_axis`: their most tensile, equally
    their most compressive) in [-90, 90), counter-clockwise from the first axis
    positive; in 3D the angle between their most compressive axes, in [0, 90].
    Shapes (..., D, D) -> (...)."""
    if S.shape[-1] == 2:
        def axis(T):
            return np.degrees(principal_axis((T[..., 0, 0], T[..., 0, 1], T[..., 1, 0],
                                              T[..., 1, 1])))
        return angle_diff(axis(S), axis(d))
    _, VS = _eigh(S)
    _, Vd = _eigh(d)
    cos = np.abs(np.sum(VS[..., :, 0] * Vd[..., :, 0], axis=-1))
    return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))


def _spacing(cells) -> float:
    """The cells' smallest width along a length (not an angle) of their grid."""
    dims, _, edges = cells.grid()
    widths = [np.min(np.diff(e)) for name, e in zip(dims, edges) if name not in cells.angles]
    return float(min(widths)) if widths else 1.0


def _components(T) -> np.ndarray:
    """The independent components of a symmetric tensor's deviator in an orthonormal
    basis, (T_xx - T_yy)/sqrt 2, sqrt 2 T_xy, and in 3D (2 T_zz - T_xx - T_yy)/sqrt 6,
    sqrt 2 T_xz, sqrt 2 T_yz: their squares add up to dev(T):dev(T). Shape (..., D, D)
    -> (..., 2 or 5)."""
    r2 = np.sqrt(2.0)
    c = [(T[..., 0, 0] - T[..., 1, 1]) / r2, r2 * T[..., 0, 1]]
    if T.shape[-1] == 3:
        c += [(2 * T[..., 2, 2] - T[..., 0, 0] - T[..., 1, 1]) / np.sqrt(6.0),
              r2 * T[..., 0, 2], r2 * T[..., 1, 2]]
    return np.stack(c, axis=-1)


def local(values, cells, diameter, rho_p, pressure=None, flow=None) -> dict:
    """The rheology's columns (:data:`COLUMNS`) of fields, or of all their replicates at
    once, without the errors' thresholds: NaN only where a ratio's divisor is not
    positive.

    Parameters
    ----------
    values : dict of name -> ndarray, shape (..., n_cells)
        The fields' columns in the cells' basis: ``sigma_*`` (and ``dsigma_fluct_*``,
        without which S is the static stress alone), ``v_*`` or ``D_*``, ``nu``.
    cells : Cells
    diameter, rho_p : float
        d_p and rho_p of I (NaN: I is NaN).
    pressure : ndarray, shape (..., n_cells), optional
        The pressure I takes (a mixture's, for a species); default the fields' own P.
    flow : ndarray, shape (n_cells, D), optional
        The flow direction to keep (the fields' ``_flow``, for their replicates: the
        same bisector, :func:`flow_frame`).

    Returns
    -------
    dict of name -> ndarray, shape (..., n_cells)
        pressure, shear_stress, shear_rate, inertial_number, friction, nu, N1, N2 (3D),
        axes_angle, fluidity; and for the
        thresholds ``_flow`` (e_f, NaN where the flow frame is undefined; shape
        (..., n_cells, D)), ``_stress`` and ``_rate`` (the norms of S and of L, with
        |v| / the cells' width: round-off's scales), ``_s`` and ``_d`` (the components
        of the deviators of S and D, :func:`_components`) and ``_how`` (where D came
        from).
    """
    axes, D = cells.axes, cells.dim
    missing = [c for c in columns("sigma", axes) if c not in values]
    if missing:
        raise UserError(f"the fields lack the static stress ({missing[0]}): average with "
                        "the quantity sigma (the contacts are needed)")
    S = _tensor(values, "sigma", axes)
    if all(c in values for c in columns("dsigma_fluct", axes)):
        S = S - _tensor(values, "dsigma_fluct", axes)
    S = _sym(S)
    P = -np.trace(S, axis1=-2, axis2=-1) / D
    s = _deviator(S)
    L, rate, how = strain_rate(values, cells)
    d = _deviator(rate)
    tau = np.sqrt(0.5 * np.sum(s * s, axis=(-2, -1)))
    gamma_dot = np.sqrt(2.0 * np.sum(d * d, axis=(-2, -1)))
    confining = P if pressure is None else np.asarray(pressure, float)
    names = columns("v", axes)
    v = np.stack([np.asarray(values[c], float) for c in names], -1) \
        if all(c in values for c in names) else None
    G = L
    if L is not None and v is not None and tuple(axes[:2]) == ("r", "phi"):
        r = np.asarray(cells.coordinates()["r"], float)     # less the curvature terms
        G = L.copy()
        G[..., 0, 1] += v[..., 1] / r
        G[..., 1, 1] -= v[..., 0] / r
    e_f, e_g, e_v, defined = flow_frame(d, G, v, flow)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = np.where(P > 0, tau / P, np.nan)
        I = np.where(confining > 0, gamma_dot * diameter * np.sqrt(rho_p / confining),
                     np.nan)
        out = {"pressure": P, "shear_stress": tau, "shear_rate": gamma_dot,
               "inertial_number": I, "friction": mu,
               "nu": np.asarray(values.get("nu", np.full(P.shape, np.nan)), float),
               "N1": np.where(defined, _along(S, e_f) - _along(S, e_g), np.nan)}
        if e_v is not None:
            out["N2"] = np.where(defined, _along(S, e_g) - _along(S, e_v), np.nan)
        out["axes_angle"] = axes_angle(S, d)
        out["fluidity"] = np.where(mu > 0, gamma_dot / mu, np.nan)
    out["_flow"] = np.where(defined[..., None], e_f, np.nan)    # for _rheology
    out["_how"], out["_s"], out["_d"] = how, _components(s), _components(d)
    out["_stress"] = np.sqrt(np.sum(S * S, axis=(-2, -1)))
    out["_rate"] = np.sqrt(np.sum((rate if L is None else L) ** 2, axis=(-2, -1)))
    if v is not None:                      # uniform v: its differences' round-off
        out["_rate"] = out["_rate"] + np.linalg.norm(v, axis=-1) / _spacing(cells)
    return out


def deviator_nonzero(c, reps) -> np.ndarray:
    """Where a deviator differs from 0 beyond its noise, its components judged together.

    A shear rate or shear stress is a norm, |c|, of its deviator's k independent
    components c (:func:`_components`; k = 2 in 2D, 5 in 3D): positive, biased up by
    the noise, and its own error sees only the noise along c. Its square is judged
    against the noise of all components: C, the covariance of c, is estimated from the
    replicates as :meth:`Replicates.error` scales them (jackknife: (n-1)/n times the sum
    of the outer products of the deviations; runs: that sum / (n (n-1)); ``structure``:
    its time blocks alone, :meth:`Replicates.in_time`). Where the deviator is 0,
    |c|^2 is about (tr C / h) chi^2_h with h = (tr C)^2 / tr(C^2), between 1 and k, the
    components that carry the noise (Satterthwaite; exact for equal, independent
    components), so the deviator is taken as nonzero where
    |c|^2 > chi^2_h quantile(1 - :data:`P_DEFINED`) tr C / h: for one noisy component
    |c| beyond :data:`Z_DEFINED` errors, the pressure's test. Like it, the test takes C
    as known: with few replicates more noise passes (tests/test_rheology.py). Where the
    replicates do not vary (tr C = 0) or fewer than two are finite, every c counts
    (round-off is judged apart).

    Parameters
    ----------
    c : ndarray, shape (n_cells, k)
    reps : Replicates or None
        The components on each replicate, under the name ``c``: shape
        (n_replicates, n_cells, k).

    Returns
    -------
    ndarray of bool, shape (n_cells,)
    """
    from scipy import stats

    if reps is None:
        return np.ones(len(c), bool)
    reps = reps.in_time()
    x = np.asarray(reps.values["c"], float)
    ok = np.all(np.isfinite(x), axis=-1)
    n = ok.sum(axis=0)
    x = np.where(ok[..., None], x, 0.0)
    dev = np.where(ok[..., None], x - x.sum(axis=0) / np.maximum(n, 1)[:, None], 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = (n - 1) / n if reps.kind == "jackknife" else 1.0 / (n * (n - 1))
        C = np.einsum("rni,rnj->nij", dev, dev) * scale[:, None, None]
        t = np.trace(C, axis1=-2, axis2=-1)
        h = np.where(t > 0, np.clip(t ** 2 / np.sum(C * C, axis=(-2, -1)), 1.0,
                                    c.shape[-1]), 1.0)
        q = np.sum(np.asarray(c, float) ** 2, axis=-1)
        beyond = q > stats.chi2.isf(P_DEFINED, h) / h * t
    return np.where((n >= 2) & (t > 0), beyond, True)


#: Which flags make which columns NaN.
_MASKS = {"friction": ("no_pressure",),
          "inertial_number": ("no_pressure", "no_shear", "no_diameter"),
          "fluidity": ("no_pressure", "no_shear", "no_shear_stress"),
          "N1": ("no_shear", "no_flow_frame"),
          "N2": ("no_shear", "no_flow_frame"), "axes_angle": ("no_shear", "no_shear_stress")}


# -- the particles --------------------------------------------------------------------

def scene_diameter(scene: dict) -> float:
    """The number-weighted mean diameter of a granavg scene (its ``n_small`` disks of
    ``d_s`` and ``n_large`` of ``d_l``)."""
    return (scene["n_small"] * scene["d_s"] + scene["n_large"] * scene["d_l"]) / (
        scene["n_small"] + scene["n_large"])


def _positive(name, value, of="") -> float:
    """``value`` as a positive number; refused in one line where it is not one."""
    number = isinstance(value, (int, float, np.integer, np.floating)) and \
        not isinstance(value, bool)
    x = float(value) if number else float("nan")
    if not (np.isfinite(x) and x > 0):
        raise ParameterError(name, f"{{param}}{literal(of)} {literal(repr(value))}: give a "
                             "positive number, in the fields' units")
    return x


def material(meta: dict, diameter=None, rho_p=None) -> dict:
    """The mean diameter d_p and the material density rho_p that I takes: as given, else
    the run's scene (``meta["run_manifest"]``), else for rho_p the density the fields
    were averaged with (``meta["inputs"]["density"]``); refused in one line where
    neither says.

    Returns
    -------
    dict
        ``diameter``, ``density`` (the fields' length and mass units) and ``from``: where
        each came from, in words.
    """
    scene = ((meta or {}).get("run_manifest") or {}).get("scene") or {}
    averaged = ((meta or {}).get("inputs") or {}).get("density")
    for name, value in (("diameter", diameter), ("density", rho_p)):
        if value is not None:
            _positive(name, value)
    where = {"diameter": "given", "density": "given"}
    if diameter is None and "d_s" in scene:
        diameter, where["diameter"] = scene_diameter(scene), "the run's scene (mean)"
    if rho_p is None and (scene.get("rho_p") or averaged):
        rho_p = scene.get("rho_p") or averaged
        where["density"] = "the run's scene" if scene.get("rho_p") else "the average's"
    if diameter is None:
        raise ParameterError("diameter", "the fields do not record the particles' size: "
                             "give {param}, their mean diameter in the fields' length unit")
    if rho_p is None:
        raise ParameterError("density", "the fields do not record the particles' material "
                             "density: give {param} in the fields' units (mass/length^3)")
    return {"diameter": float(diameter), "density": float(rho_p), "from": where}


def _species_diameters(fields, diameter, d_mean) -> dict:
    """Each species' d_p: a mapping as given; a run's species by type its scene's d_s
    (type1) and d_l (type2); the whole's the mean; others unknown (None)."""
    if isinstance(diameter, dict):
        return {n: diameter.get(n) for n in fields.species}
    meta = fields.meta or {}
    scene = (meta.get("run_manifest") or {}).get("scene") or {}
    known = {MIXTURE: d_mean}
    if scene and (meta.get("species") or {}).get("by") == "type":
        known.update({"type1": scene.get("d_s"), "type2": scene.get("d_l")})
    return {n: known.get(n) for n in fields.species}


# -- the rheology of fields ---------------------------------------------------------------

def rheology(fields: Fields, *, diameter=None, density=None) -> Fields:
    """The local rheology of fields, per cell, with errors and flags.

    Parameters
    ----------
    fields : Fields
        Fields of :func:`granavg.average` (or :func:`granavg.read`) with the static
        stress ``sigma``, the kinetic stress ``dsigma_fluct`` (without it S is the static
        stress alone, said in the sidecar), the velocity ``v`` (or a smoothing kernel's
        ``D``) and ``nu``, in a coherent unit system; their replicates give the errors.
        Fields in time are refused (take one time: ``fields.at(j)``).
    diameter : float or dict, optional
        The particles' mean diameter d_p in the fields' length unit; a mixture's: a
        mapping species -> d_p (``"all"``: the whole's). Default: the run's scene.
    density : float, optional
        The particles' material density rho_p. Default: the run's scene, or the density
        the fields were averaged with.

    Returns
    -------
    Fields
        On the same cells: the columns of :data:`COLUMNS` (``values``, shape (n_cells,)
        each), their errors (``sem``), the fields' flags with :data:`FLAGS` added, the
        replicates of every column (the fits' errors come from them), and the sidecar
        with ``meta["rheology"]`` (d_p, rho_p, the conventions, where D came from) and
        the columns' dimensions. A mixture's: one per species on a species axis, each
        species' pressure, shear_stress, friction, N1, N2 and axes_angle its partial
        stress's, its inertial_number with its own d_p and gamma_dot under the whole's
        pressure.

    See :func:`granavg.pipeline.api.rheology` (``granavg.rheology``) for an example.
    """
    if fields.in_time:
        raise UserError("fields in time: the rheology is of time-averaged fields; take one "
                        "time (fields.at(j)) or average without windows or a time kernel")
    system = fields.unit_system
    if system.momentum_flux:
        raise UserError(f"the fields are in {system.style} units, where mass (length/time)^2 "
                        "is not the energy unit: the kinetic stress and I would need a "
                        "conversion granavg does not make; average in a coherent system "
                        "(si, cgs, lj, micro, nano)")
    if isinstance(diameter, dict):
        if MIXTURE not in diameter:
            raise ParameterError("diameter", f"{{param}}: give the whole mixture's "
                                 f"('{MIXTURE}') mean diameter beside the species'")
        for name, value in diameter.items():
            if fields.species is not None and name not in fields.species:
                raise ParameterError("diameter", f"{{param}}: {literal(repr(name))} is not "
                                     f"a species of the fields "
                                     f"({literal(', '.join(fields.species))})")
            if value is not None:
                _positive("diameter", value, f"[{name!r}]")
    mat = material(fields.meta, diameter.get(MIXTURE) if isinstance(diameter, dict) else
                   diameter, density)
    if fields.species is None:
        if isinstance(diameter, dict):
            raise ParameterError("diameter", "{param}: a mapping is for a mixture's fields "
                                 "(species=); give one number")
        return _rheology(fields, mat["diameter"], mat)
    sizes = _species_diameters(fields, diameter, mat["diameter"])
    whole = _rheology(fields.of(MIXTURE), sizes[MIXTURE], mat)
    parts = {n: whole if n == MIXTURE else _rheology(fields.of(n), sizes[n], mat, whole)
             for n in fields.species}
    unknown = [n for n, d in sizes.items() if d is None]
    if unknown:
        log.warning("the diameter of %s is not known: their inertial_number is NaN (flag "
                    "no_diameter); "
                    "give diameter={'all': ..., %s}", ", ".join(unknown),
                    ", ".join(f"'{n}': ..." for n in unknown))
    meta = dict(whole.meta)
    meta["rheology"] = {**meta["rheology"], "diameters": sizes,
                        "species": "each species' pressure, shear_stress, friction, N1, N2 "
                                   "and axes_angle from its partial stress; its "
                                   "inertial_number I = gamma_dot_s d_s / sqrt(P / "
                                   "rho_p) with the whole's pressure P"}
    return Fields.of_species(parts, meta)


def _rheology(fields, diameter, mat, whole=None) -> Fields:
    """:func:`rheology` of fields without a species axis; ``whole``: the mixture's
    rheology, whose pressure a species' I takes."""
    cells, reps = fields.cells, fields.replicates
    d = np.nan if diameter is None else float(diameter)
    rho = mat["density"]
    value = local(fields.values, cells, d, rho,
                  None if whole is None else whole.values["pressure"])
    flow, how = value.pop("_flow"), value.pop("_how")
    floor = {"pressure": value.pop("_stress"), "shear_rate": value.pop("_rate")}
    floor["shear_stress"] = floor["pressure"]
    parts = {"shear_stress": value.pop("_s"), "shear_rate": value.pop("_d")}
    rep, spread = None, dict.fromkeys(parts)
    if reps is not None:
        confining = None
        if whole is not None:
            same = whole.replicates is not None and whole.replicates.n == reps.n
            confining = whole.replicates.values["pressure"] if same else np.nan
            if not same:
                log.warning("a species' replicates are not the whole's: its "
                            "inertial_number has no error")
        rep = local(reps.values, cells, d, rho, confining, flow)
        spread = {k: Replicates(reps.kind, {"c": rep[c]}, reps.parts)
                  for k, c in (("shear_stress", "_s"), ("shear_rate", "_d"))}
        rep = {k: x for k, x in rep.items() if k in COLUMNS}
        rep["axes_angle"] = value["axes_angle"] + angle_diff(rep["axes_angle"],
                                                             value["axes_angle"])
        sem = Replicates(reps.kind, rep, reps.parts).profile_errors()
    else:
        log.warning("the fields carry no replicates: the rheology has no errors, and the "
                    "pressure, shear_stress and shear_rate are judged against round-off "
                    "alone; average them again with this granavg")
        sem = {k: np.full(cells.n, np.nan) for k in value}

    def weak(name):
        x = value[name]
        with np.errstate(invalid="ignore"):
            small = ~(x > ROUND_OFF * floor[name])
            if name in parts:
                return small | ~deviator_nonzero(parts[name], spread[name])
            return small | (x <= Z_DEFINED * sem[name])
    raised = {"no_pressure": weak("pressure") if whole is None else weak("pressure") |
              np.array(["no_pressure" in str(f).split(";") for f in whole.flags]),
              "no_shear": weak("shear_rate"), "no_shear_stress": weak("shear_stress"),
              "no_flow_frame": ~np.all(np.isfinite(flow), axis=-1),
              "no_diameter": np.full(cells.n, diameter is None)}
    for name, flags in _MASKS.items():
        if name in value:
            cut = np.any([raised[f] for f in flags], axis=0)
            value[name] = np.where(cut, np.nan, value[name])
            if rep is not None:
                rep[name] = np.where(cut, np.nan, rep[name])
                sem[name] = np.where(cut, np.nan, sem[name])
    for name in rep or {}:          # undefined on a replicate: its spread is not known
        lost = np.isfinite(value[name]) & np.any(~np.isfinite(rep[name]), axis=0)
        if lost.any():
            sem[name] = np.where(lost, np.nan, sem[name])
            log.warning("%s: undefined on some replicate in %d cells, whose error is NaN",
                        name, int(lost.sum()))
    flags = np.array([";".join([*(f for f in str(old).split(";") if f),
                                *(f for f in raised if raised[f][k])])
                      for k, old in enumerate(fields.flags)], dtype=object)
    meta = {k: v for k, v in (fields.meta or {}).items() if k != "columns"}
    meta["dimensions"] = {c: COLUMNS[c].unit for c in value}
    kinetic = all(c in fields.values for c in columns("dsigma_fluct", cells.axes))
    if not kinetic:
        log.warning("the fields lack dsigma_fluct: the rheology's stress is the static "
                    "stress alone")
    meta["rheology"] = {
        "diameter": None if diameter is None else float(diameter), "density": rho,
        "from": mat["from"],
        "stress": "S = sym(sigma - dsigma_fluct), tension positive" if kinetic else
                  "S = sym(sigma), the static stress alone (no dsigma_fluct in the fields)",
        "strain_rate": how,
        "errors": (f"from the fields' {reps.kind} replicates ({reps.n}): each column "
                   "computed on every replicate") if reps is not None else "none (no "
                  "replicates)",
        "columns": {c: COLUMNS[c].help for c in value}, "flags": FLAGS,
        "thresholds": {"Z_DEFINED": Z_DEFINED, "P_DEFINED": P_DEFINED,
                       "FRAME_RATIO": FRAME_RATIO,
                       "ROUND_OFF": ROUND_OFF}}
    return Fields(cells, value, sem, flags, fields.n_frames, meta,
                  None if rep is None else Replicates(reps.kind, rep, reps.parts),
                  fields.n_runs, fields.series)


# -- constitutive fits ------------------------------------------------------------------

@dataclass(frozen=True)
class Law:
    """A constitutive law y(I) with its parameters.

    Attributes
    ----------
    name : str
    column : str
        The rheology's column it predicts (``friction``, ``nu``).
    params : tuple of str
    f, df : callable
        ``f(I, *p)`` and its derivative dy/dI, arrays of I.
    guess : callable
        ``guess(I, y) -> p0``.
    lower : tuple
        The parameters' lower bounds.
    yield_param : str, optional
        The parameter below which the law has no flow (mu_s): points below it and below
        the law are the nonlocal ones.
    """

    name: str
    column: str
    params: tuple
    f: Callable
    df: Callable
    guess: Callable
    lower: tuple
    yield_param: str | None = None


def _guess_mu(I, mu):
    return (float(np.percentile(mu, 10)), float(np.max(mu) + 0.1 * np.ptp(mu) + 1e-3),
            float(np.median(I)))


MU_I = Law("mu(I)", "friction", ("mu_s", "mu_2", "I_0"),
           lambda I, s, m, i0: s + (m - s) / (1.0 + i0 / I),
           lambda I, s, m, i0: (m - s) * i0 / (I + i0) ** 2, _guess_mu,
           (0.0, 0.0, 1e-12), "mu_s")
PHI_I = Law("phi(I)", "nu", ("phi_max", "a"), lambda I, p, a: p - a * I,
            lambda I, p, a: -a + 0.0 * I,
            lambda I, y: (float(np.max(y)), 0.0), (-np.inf, -np.inf))


@dataclass
class Points:
    """One source's points of a fit: its cells with the inertial number I and the law's
    column defined.

    Attributes
    ----------
    label : str
    cells : ndarray of int, shape (m,)
        The cells' indices in the source.
    x, y, sx, sy : ndarray, shape (m,)
        I, the law's column and their standard errors.
    replicates : Replicates or None
        The source's replicates; ``rx``, ``ry`` (n_replicates, m) their I and column.
    used, nonlocal_, z : ndarray, shape (m,)
        Set by the fit: whether the point entered it, whether it is nonlocal (below
        the law and its yield, :attr:`Law.yield_param`, by more than :data:`Z_OUTSIDE`
        errors at the smallest I: :func:`_local_points`; never both), and
        (y - law(I)) / its error in the final fit.
    """

    label: str
    cells: np.ndarray
    x: np.ndarray
    y: np.ndarray
    sx: np.ndarray
    sy: np.ndarray
    replicates: Replicates | None = None
    rx: np.ndarray | None = None
    ry: np.ndarray | None = None
    used: np.ndarray | None = None
    nonlocal_: np.ndarray | None = None
    z: np.ndarray | None = None


@dataclass
class Fit:
    """A constitutive law fitted to pooled points.

    Attributes
    ----------
    law : Law
    params, errors : dict of name -> float
        The parameters and their standard errors: refits on every replicate of each
        source (the others at their values), each source's spread from its replicates
        (:meth:`Replicates.error`), the sources' variances added (independent runs).
    fit_errors : dict of name -> float
        The errors the fit alone gives, its points taken as independent (for comparison:
        the cells of one run are correlated, so these are not the errors).
    by_source : list of dict
        Each source's share of ``errors``.
    chi2 : float
        sum z^2 over the points used, z = (y - law(I)) / sqrt(sy^2 + (law'(I) sx)^2).
    dof : int
        Points used less parameters.
    points : list of Points
    """

    law: Law
    params: dict
    errors: dict
    fit_errors: dict
    by_source: list
    chi2: float
    dof: int
    points: list = field(default_factory=list)

    def __call__(self, I):
        """The law at I."""
        return self.law.f(np.asarray(I, float), *self.params.values())

    @property
    def chi2_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")

    @property
    def nonlocal_cells(self) -> dict:
        """Each source's nonlocal cells, at the smallest I below the law and below its
        yield by more than :data:`Z_OUTSIDE` errors (the creep where the local law has
        no flow; :func:`_local_points`): label -> cell indices."""
        return {p.label: p.cells[p.nonlocal_] for p in self.points}

    @property
    def outside_cells(self) -> dict:
        """Each source's cells among those fitted that lie more than :data:`Z_OUTSIDE`
        errors off the law: label -> cell indices."""
        return {p.label: p.cells[p.used & (np.abs(p.z) > Z_OUTSIDE)] for p in self.points}

    def to_dict(self) -> dict:
        """The fit as plain numbers (JSON)."""
        return {"law": self.law.name, "params": self.params, "errors": self.errors,
                "fit_errors_independent_points": self.fit_errors,
                "errors_by_source": self.by_source, "chi2": self.chi2, "dof": self.dof,
                "chi2_dof": self.chi2_dof, "z_outside": Z_OUTSIDE,
                "points": {p.label: {"cells": p.cells.tolist(), "used": p.used.tolist(),
                                     "nonlocal": p.nonlocal_.tolist(),
                                     "z": [float(z) for z in p.z]} for p in self.points},
                "nonlocal_cells": {k: v.tolist() for k, v in self.nonlocal_cells.items()},
                "outside_cells": {k: v.tolist() for k, v in self.outside_cells.items()}}


def _sources(results, labels, species) -> list:
    """Rheology results as a list of Fields without a species axis, and their labels;
    refused in one line where ``species`` is not theirs, or where some carry
    replicates (errors) and others not."""
    results = [results] if isinstance(results, Fields) else list(results)
    labels = list(labels) if labels is not None else (
        ["cells"] if len(results) == 1 else [f"source {k + 1}" for k in range(len(results))])
    if len(labels) != len(results) or len(set(labels)) != len(labels):
        raise ParameterError("labels", "{param}: give one distinct label per source")
    out = []
    for res, label in zip(results, labels):
        if not isinstance(res, Fields) or "rheology" not in (res.meta or {}):
            raise UserError(f"{label}: not a rheology; give granavg.rheology(fields)")
        if species not in (res.species or (MIXTURE,)):
            raise ParameterError("species", f"{{param}} {literal(repr(species))}: not a "
                                 f"species of {literal(label)} ("
                                 f"{literal(', '.join(res.species or ('no species',)))})")
        out.append(res.of(species) if res.species is not None else res)
    bare = [label for res, label in zip(out, labels) if res.replicates is None]
    if bare and len(bare) < len(out):
        raise UserError(f"{', '.join(bare)}: no replicates, so no errors, beside sources "
                        "with them: fit them apart, or average them again with this granavg")
    return list(zip(out, labels))


def _points(results, law, labels, species, exclude) -> list:
    """Each source's :class:`Points` of ``law``: cells with an inertial_number I > 0 and
    the column finite (errors may be NaN: no replicates, or a column undefined on a
    replicate), but those ``exclude`` names (label -> cell indices)."""
    pts = []
    for res, label in _sources(results, labels, species):
        x, y = res.values["inertial_number"], res.values[law.column]
        sx, sy = res.sem["inertial_number"], res.sem[law.column]
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(x) & (x > 0) & np.isfinite(y)
        ok[np.asarray(exclude.get(label, []), int)] = False
        rep = res.replicates
        pts.append(Points(label, np.flatnonzero(ok), x[ok], y[ok], sx[ok], sy[ok], rep,
                          None if rep is None else rep.values["inertial_number"][:, ok],
                          None if rep is None else rep.values[law.column][:, ok]))
    return pts


def _solve(law, x, y, sx, sy, p0):
    """Weighted least squares of ``law`` (effective variance sy^2 + (law'(x) sx)^2);
    returns scipy's result."""
    from scipy.optimize import least_squares

    def resid(p):
        return (y - law.f(x, *p)) / np.sqrt(sy ** 2 + (law.df(x, *p) * sx) ** 2)
    lower = np.asarray(law.lower, float)
    p0 = np.maximum(np.asarray(p0, float), lower + 1e-12 * (np.isfinite(lower)))
    return least_squares(resid, p0, bounds=(lower, np.inf), x_scale="jac")


def _below(law, sol, kept, i, x, y, sx, sy) -> bool:
    """Whether point ``i`` lies below the fit ``sol`` of the points ``kept`` (indices,
    ascending in I) and below its yield (mu_s) by more than :data:`Z_OUTSIDE` errors:
    its own error and the fit's there (the parameters' covariance), both scaled by the
    law's misfit where it exceeds 1 - sqrt(chi^2/dof) of those points, or the rms z of
    the :data:`NEAREST` of them at the smallest I, whichever is larger (a law that
    misses the points next to i by more than their errors is not known better at i)."""
    p = sol.x
    z = (y[kept] - law.f(x[kept], *p)) / np.sqrt(sy[kept] ** 2 +
                                                 (law.df(x[kept], *p) * sx[kept]) ** 2)
    dof = len(kept) - len(p)
    s2 = max(1.0, np.sum(z ** 2) / dof if dof > 0 else 1.0, np.mean(z[:NEAREST] ** 2))
    cov = s2 * np.linalg.pinv(sol.jac.T @ sol.jac)
    steps = 1e-6 * np.maximum(np.abs(p), 1e-6)
    grad = np.array([(law.f(x[i], *(p + h)) - law.f(x[i], *(p - h))) / (2 * h[j])
                     for j, h in enumerate(np.diag(steps))])
    own = s2 * (sy[i] ** 2 + (law.df(x[i], *p) * sx[i]) ** 2)
    k = law.params.index(law.yield_param)
    return bool(y[i] - law.f(x[i], *p) < -Z_OUTSIDE * np.sqrt(own + grad @ cov @ grad)
                and y[i] - p[k] < -Z_OUTSIDE * np.sqrt(own + cov[k, k]))


def _local_points(law, x, y, sx, sy, good):
    """The points the law is fitted to, and its fit to them.

    A law with a yield (mu(I): mu_s) is fitted to the upper half of the points by I;
    then each point below, from the largest I down, is judged against the fit of the
    points kept so far (:func:`_below`): set aside where it lies below that fit and its
    mu_s by more than :data:`Z_OUTSIDE` errors, else kept and the law fitted again.
    The nonlocal points are those set aside in a run from the smallest I up; others
    set aside are kept, and the law fitted once more. Nothing is judged twice, so the
    rule cannot ratchet; at most the lower half is nonlocal (a warning says so where all
    of it is, or where a nonlocal point is not below the final fit)."""
    order = np.flatnonzero(good)[np.argsort(x[good], kind="stable")]
    n = len(order)
    start = n if law.yield_param is None else \
        min(n, max(n - n // 2, len(law.params) + 2))
    keep = np.zeros(len(x), bool)
    keep[order[n - start:]] = True

    def fit(p0):
        return _solve(law, x[keep], y[keep], sx[keep], sy[keep], p0)
    sol = fit(law.guess(x[keep], y[keep]))
    aside = np.zeros(len(x), bool)
    for i in order[:n - start][::-1]:
        if _below(law, sol, order[keep[order]], i, x, y, sx, sy):
            aside[i] = True
        else:
            keep[i] = True
            sol = fit(sol.x)
    tail = order[:int(np.argmin(aside[order]))]
    if aside.sum() > len(tail):
        keep = good.copy()
        keep[tail] = False
        sol = fit(sol.x)
    if len(tail) > 1 and len(tail) == n - start:
        log.warning("%s: every point in the lower half of I lies below mu_s (nonlocal): "
                    "the creep may reach further, or the law does not hold", law.name)
    back = [i for i in tail if not _below(law, sol, order[keep[order]], i, x, y, sx, sy)]
    if back:
        log.warning("%s: %d nonlocal points are within %g errors of the final fit",
                    law.name, len(back), Z_OUTSIDE)
    return keep, sol


def fit_law(results, law: Law, *, labels=None, species=MIXTURE, exclude=None) -> Fit:
    """Fit a constitutive law to the cells of one or several rheologies, with errors that
    honour the points' correlation.

    Points are the cells with ``inertial_number`` I and the law's column defined (NaN and
    flagged cells left out), weighted by their errors (effective variance
    sy^2 + (y'(I) sx)^2); a point whose error is not known (NaN: the column undefined on
    one of its replicates) is left out. Sources without replicates give equal weights,
    no chi^2 and no errors; they cannot be pooled with sources that have them. A law
    with a yield (mu(I): mu_s) leaves out the nonlocal points, each below the fit of
    the points at larger I and below its mu_s by more than :data:`Z_OUTSIDE` errors
    (scaled by sqrt(chi^2/dof) where that exceeds 1): the creep where the local law has
    no flow (:func:`_local_points`).

    Errors: for each source k and each of its replicates i, the fit is made again with
    source k's points at their replicate values (the same points and weights; the other
    sources at their values); the parameters' spread over i is source k's error
    (:meth:`Replicates.error`: jackknife, sectors and time, or realisations), and the
    sources' variances add (independent runs). Cells of one run move together on a
    replicate (the whole cell's pressure), which the points' own errors do not say.

    Parameters
    ----------
    results : Fields or sequence of Fields
        Rheologies (:func:`rheology`) of one or several runs or scenes.
    law : Law
        :data:`MU_I` or :data:`PHI_I`.
    labels : sequence of str, optional
        A name per source (default ``cells``, or ``source 1``, ...).
    species : str
        A mixture's rheology: the species whose points are fitted (default the whole).
    exclude : Fit or dict, optional
        Cells left out: a fit's nonlocal cells (:attr:`Fit.nonlocal_cells`), or label
        -> cell indices.

    Returns
    -------
    Fit
    """
    if isinstance(exclude, Fit):
        exclude = exclude.nonlocal_cells
    pts = _points(results, law, labels, species, exclude or {})
    x, y, sx, sy = (np.concatenate([getattr(p, a) for p in pts]) for a in ("x", "y", "sx", "sy"))
    weighted = pts[0].replicates is not None
    if weighted:
        with np.errstate(invalid="ignore"):
            good = np.isfinite(sy) & (sy > 0) & np.isfinite(sx) & (sx >= 0)
        if not good.all():
            log.warning("%s: %d cells without an error of inertial_number or %s (undefined "
                        "on a replicate) left out", law.name, int((~good).sum()), law.column)
    else:
        log.warning("%s: the points carry no errors: equal weights, no chi^2 and no errors",
                    law.name)
        good, sx, sy = np.ones(len(x), bool), np.zeros(len(x)), np.ones(len(x))
    n_par = len(law.params)
    if good.sum() <= n_par:
        raise UserError(f"{law.name}: {int(good.sum())} cells with inertial_number, "
                        f"{law.column} and their errors; the fit needs more than {n_par} "
                        "(more cells, or a longer average: cells where the shear rate or "
                        "pressure is not distinguishable from 0 have no inertial_number)")
    keep, sol = _local_points(law, x, y, sx, sy, good) if weighted else \
        (good, _solve(law, x, y, sx, sy, law.guess(x, y)))
    p = sol.x
    z = (y - law.f(x, *p)) / np.sqrt(sy ** 2 + (law.df(x, *p) * sx) ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = np.linalg.pinv(sol.jac.T @ sol.jac)
    chi2, dof = float(np.sum(z[keep] ** 2)), int(keep.sum() - n_par)
    by_source, start = [], 0
    for pt in pts:
        own = slice(start, start + len(pt.x))
        pt.used, pt.nonlocal_, pt.z = keep[own], (good & ~keep)[own], z[own]
        by_source.append(_replicate_errors(law, pt, own, x, y, sx, sy, keep, p))
        start += len(pt.x)
    var = np.sum([[e[n] ** 2 for n in law.params] for e in by_source], axis=0)
    name = list(law.params)
    nan = dict.fromkeys(name, float("nan"))
    return Fit(law, dict(zip(name, map(float, p))),
               dict(zip(name, map(float, np.sqrt(var)))) if weighted else nan,
               dict(zip(name, map(float, np.sqrt(np.diag(cov))))) if weighted else nan,
               [{"source": pt.label, **e} for pt, e in zip(pts, by_source)],
               chi2 if weighted else float("nan"), dof, pts)


def _replicate_errors(law, pt, own, x, y, sx, sy, keep, p) -> dict:
    """One source's errors of the parameters: the fit again on each of its replicates
    (its points at their replicate values; the same points, weights and the other
    sources' values), the spread by the replicates' kind. NaN without replicates, and
    (with a warning) where a point used is not defined on a replicate."""
    if pt.replicates is None:
        return dict.fromkeys(law.params, float("nan"))
    used = keep[own]
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(pt.rx) & (pt.rx > 0) & np.isfinite(pt.ry))[:, used]
    if bad.any():
        log.warning("%s: %s: %d of its points used are undefined on a replicate: no "
                    "errors from it", law.name, pt.label, int(bad.any(axis=0).sum()))
        return dict.fromkeys(law.params, float("nan"))
    est = []
    for rx, ry in zip(pt.rx, pt.ry):
        xi, yi = x.copy(), y.copy()
        xi[own], yi[own] = rx, ry
        est.append(_solve(law, xi[keep], yi[keep], sx[keep], sy[keep], p).x)
    est = np.array(est)
    return {n: pt.replicates.error(est[:, j]) for j, n in enumerate(law.params)}


def fit_mu_I(results, *, labels=None, species=MIXTURE) -> Fit:
    """mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) (Jop, Forterre and Pouliquen 2006)
    fitted to the cells of one or several rheologies (:func:`fit_law`), the points at
    the smallest I below mu_s by more than :data:`Z_OUTSIDE` errors (creep:
    ``Fit.nonlocal_cells``) left out.

    Examples
    --------
    >>> import granavg
    >>> fields = granavg.average(granavg.examples.couette_2d.run, cells={"bins": 8},
    ...                          t_min=1.0)
    >>> fit = granavg.fit_mu_I(granavg.rheology(fields))   # doctest: +SKIP
    >>> fit.params["mu_s"], fit.errors["mu_s"], fit.chi2_dof       # doctest: +SKIP
    """
    return fit_law(results, MU_I, labels=labels, species=species)


def fit_phi_I(results, *, labels=None, species=MIXTURE, exclude=None) -> Fit:
    """phi(I) = phi_max - a I fitted to the packing fraction of the cells of one or
    several rheologies (:func:`fit_law`); ``exclude``: cells left out, e.g. the mu(I)
    fit whose nonlocal cells (creep, where the local law fails) are not fitted."""
    return fit_law(results, PHI_I, labels=labels, species=species, exclude=exclude)


def fit_laws(results, *, labels=None, species=MIXTURE) -> dict:
    """mu(I) and then phi(I) without mu(I)'s nonlocal cells (:func:`fit_mu_I`,
    :func:`fit_phi_I`), by key ``mu_I``, ``phi_I``: each a :class:`Fit`, or where it
    cannot be made the one line saying why (str)."""
    fits = {}
    for key, fit in (("mu_I", fit_mu_I), ("phi_I", fit_phi_I)):
        extra = {"exclude": fits["mu_I"]} if isinstance(fits.get("mu_I"), Fit) else {}
        try:
            fits[key] = fit(results, labels=labels, species=species, **extra)
        except UserError as exc:
            fits[key] = str(exc)
    return fits


def local_law(fit: Fit, inside, source: int = 0) -> dict:
    """Where the local law holds: a fit's points in a region (the shear band) against
    those beyond it (its tail).

    Parameters
    ----------
    fit : Fit
        A fit of :data:`MU_I`.
    inside : ndarray of bool, shape (n_cells,)
        The region's cells, of the fit's source ``source``.

    Returns
    -------
    dict
        ``band``: ``reproduced`` where at least two points lie inside and all within
        :data:`Z_OUTSIDE` errors of the law, ``not reproduced`` where one lies further,
        else ``inconclusive``; ``tail``: ``reproduced`` where a point beyond the region is
        nonlocal (below the law and mu_s by more than :data:`Z_OUTSIDE` errors while its
        shear rate is distinguishable from 0: creep), ``not reproduced`` where every
        point beyond lies within :data:`Z_OUTSIDE` errors of the law (it holds there
        too), ``inconclusive`` where no point lies beyond (no measurable flow); both
        ``inconclusive`` where the fit has no errors (no replicates: no chi^2); and the
        counts and largest |z| that decide them. Only points with a finite z count.
    """
    pt = fit.points[source]
    band = np.asarray(inside, bool)[pt.cells]
    counted = (pt.used | pt.nonlocal_) & np.isfinite(pt.z)
    z = np.abs(pt.z)
    inner, outer = counted & band, counted & ~band
    worst = float(np.max(z[inner])) if inner.any() else float("nan")
    creep = pt.nonlocal_ & outer
    if not np.isfinite(fit.chi2):
        in_band = tail = "inconclusive"
    else:
        in_band = "inconclusive" if inner.sum() < 2 else "reproduced" if \
            worst <= Z_OUTSIDE and not (inner & pt.nonlocal_).any() else "not reproduced"
        tail = "reproduced" if creep.any() else "not reproduced" if outer.any() and \
            np.all(z[outer] <= Z_OUTSIDE) else "inconclusive"
    return {"band": in_band, "tail": tail, "band_points": int(inner.sum()),
            "band_max_z": worst, "tail_points": int(outer.sum()),
            "tail_nonlocal": int(creep.sum())}


# -- figures --------------------------------------------------------------------------------

def plot_fit(fit: Fit, ax=None):
    """A fit's points with their error bars (I on a log axis), the law, and its nonlocal
    points (open red markers); mu(I) also its mu_s. Returns the axes.

    Parameters
    ----------
    fit : Fit
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).
    """
    import matplotlib.pyplot as plt

    from granavg.analysis.figures import MARKERS, OKABE_ITO

    if ax is None:
        _, ax = plt.subplots(figsize=(4.8, 3.6), constrained_layout=True)
    for k, pt in enumerate(fit.points):
        colour = OKABE_ITO[k % len(OKABE_ITO)]
        for part, kw in ((pt.used, {"mfc": colour, "label": pt.label}),
                         (~pt.used & ~pt.nonlocal_, {"mfc": "none", "label": None}),
                         (pt.nonlocal_, {"mfc": "none", "mec": "#b00000",
                                         "label": f"{pt.label}: nonlocal (left out)"})):
            if part.any():
                ax.errorbar(pt.x[part], pt.y[part], xerr=pt.sx[part], yerr=pt.sy[part],
                            ls="none", marker=MARKERS[k % len(MARKERS)], ms=4,
                            color=colour, elinewidth=0.7, **kw)
    every = np.concatenate([pt.x for pt in fit.points])
    I = np.geomspace(every.min() / 2, every.max() * 2, 200)
    text = ", ".join(f"{n} = {v:.3g}" for n, v in fit.params.items())
    ax.plot(I, fit(I), color="k", lw=1, label=f"{fit.law.name}: {text}")
    if fit.law.yield_param:
        ax.axhline(fit.params[fit.law.yield_param], color="k", ls=":", lw=0.8,
                   label=fit.law.yield_param)
    ax.set_xscale("log")
    ylabel = "friction mu = tau / P (-)" if fit.law.column == "friction" else \
        "packing fraction phi (-)"
    ax.set(xlabel="inertial number I (-)", ylabel=ylabel,
           title=f"{fit.law.name}, chi^2/dof = {fit.chi2_dof:.2g}")
    ax.legend(fontsize=6, frameon=False)
    return ax


def plot_fits(mu_fit: Fit | None, phi_fit: Fit | None, axes=None):
    """mu(I) and phi(I) side by side (:func:`plot_fit`; a panel without its fit says
    so). Returns the two axes."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(9.6, 3.8), constrained_layout=True)
    for ax, fit, name in zip(axes, (mu_fit, phi_fit), ("mu(I)", "phi(I)")):
        if fit is None:
            ax.text(0.5, 0.5, f"no {name} fit", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_axis_off()
        else:
            plot_fit(fit, ax)
    return axes
