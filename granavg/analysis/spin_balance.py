"""The balance of the spins' angular momentum on profiles of any cells (micropolar
fields): in steady state

    div(mu - dmu) + tau + lever = 0,    tau = eps : sigma  (the antisymmetric stress)

with mu the couple stress of the contact couples (``mu_*``: (1/V) sum_p w_p sum_c l m,
first index the branch vector's, the divergence on it), dmu the flux of the spins'
angular momentum (``dmu_*``: (1/V) sum_p w_p v I omega), tau the moment density of the
contact forces about the particles' centres (``sigma_*``: tau_z = sigma_yx - sigma_xy in
2D, tau_k = eps_kij sigma_ji in 3D; with sigma_ij = f_i l_j it is (1/V) sum w sum l x f)
and ``lever`` the moment a contact law adds whose lever arm for the torque is not the
branch vector (``pair gran/*``: the particle's surface; ``pair granular``: the contact
point, as granavg's branch, so none). The walls' contacts are among each particle's
contacts: their forces' moments are in tau and their couples in mu. A body couple enters
where the scene applies one (none of granavg's scenes does: the base plate's friction
acts at each disk's centre).

Per particle, I domega/dt = sum_c (l x f + m) exactly; weighted with the exact cell
weights, V_k (tau_k + lever_k) + sum_p w_pk sum_c m = the cell's rate of change of spin.
The net couple sum_p w_pk sum_c m (``couple_density`` times V_k) is what the contacts
pass through the cell's faces, and the balance comes in two forms (:data:`FORMS`):

- ``cells``: with that net couple itself. Exact at rest whatever the packing: it fails
  where the data miss couples (a dump without the rolling resistance's columns), where
  the lever arm is not the law's, or where contacts are missing; in a flow, by the
  spins' rate of change, which time averaging over a steady state removes.
- ``field``: with the finite-volume divergence of the couple-stress field mu between
  neighbouring cells and the walls' contact couples (``boundary_couple``, as the
  boundary force density of the force balance), as the force balance takes sigma
  (:mod:`granavg.analysis.balance`; each geometry's form,
  :meth:`~granavg.engine.cells.base.Cells.residuals`: 2D couple stresses enter as the
  first row of a tensor, whose first component then reads div mu; 3D ones
  transposed). It holds where mu is smooth over a cell, as in time averages of a
  steady flow. In one packing at rest mu is the couples' frozen disorder and its
  differences between cells do not give the couple passed (measured on a 2D pile:
  residuals of the order of tau itself, docs/profiles.md).

The spins' flux dmu enters both forms as a finite-volume divergence.

The residual is a moment density (Pa in SI, N m per m^3): the antisymmetric stress left
unbalanced. It is compared with the stress scale (the mean |trace sigma| / D of the cells
with particles), the yardstick of the force balance: "the cell's torques balance to x of
the stress". Errors come from the profiles' time replicates, as for the force balance.
"""

from __future__ import annotations

import numpy as np

from granavg.analysis.balance import _component, stress_scale
from granavg.engine.kernels import BRANCHES

#: Where each contact law's lever arm for the torque ends, as the overlap it gives up
#: (as :data:`granavg.engine.kernels.BRANCHES`): ``contact``, the middle of the overlap
#: (``pair granular``; the reference DEM with rolling resistance), ``surface``, the
#: particle's surface (``pair gran/hooke``, ``gran/hooke/history``, ``gran/hertz/history``;
#: measured against LAMMPS' per-atom torques, tests/test_couples.py).
ARMS = {"contact": 0.5, "surface": 0.0}
#: The forms of the balance (the module docstring).
FORMS = ("cells", "field")


def branch_reach(profiles) -> float:
    """The overlap fraction s_branch the fields' branch vectors gave up: of the branch
    their sidecar names (:data:`~granavg.engine.kernels.BRANCHES`; ``contact`` where it
    names none)."""
    return BRANCHES[(profiles.meta or {}).get("branch", "contact")]


def moment_density(values, geometry, arm="contact", reach=0.5) -> list:
    """tau + lever per axis of the couple (one array in 2D, three in 3D): the contact
    forces' moment density about the particles' centres with the law's own lever arm.
    ``lever`` (the moment (delta/2) n x f, :mod:`granavg.engine.quantities`) is added
    times (s_branch - s_arm) / (1/2), s_branch the fields' ``reach``
    (:func:`branch_reach`), so that it turns granavg's branch into the arm."""
    axes, n = geometry.axes, geometry.n

    def s(i, j):
        return _component(values, f"sigma_{i}{j}", n)
    if len(axes) == 2:
        a, b = axes
        tau = [s(b, a) - s(a, b)]
    else:
        x, y, z = axes
        tau = [s(z, y) - s(y, z), s(x, z) - s(z, x), s(y, x) - s(x, y)]
    factor = (reach - ARMS[arm]) / 0.5
    if factor:
        names = ["lever"] if len(axes) == 2 else [f"lever_{i}" for i in axes]
        tau = [t + factor * _component(values, k, n) for t, k in zip(tau, names)]
    return tau


def couple_flux(values, geometry, dynamic=True, field=True) -> dict:
    """mu - dmu (``field``; else -dmu alone) as the components of a tensor whose
    divergence on its second index is div(mu - dmu) on mu's first: in 2D its first row
    (``mu_<j>`` at ``<a0><j>``), in 3D transposed."""
    axes, n = geometry.axes, geometry.n

    def total(name):
        flux = _component(values, f"mu_{name}", n) if field else np.zeros(n)
        return flux - _component(values, f"dmu_{name}", n) if dynamic else flux
    if len(axes) == 2:
        return {i + j: total(j) if i == axes[0] else np.zeros(n) for i in axes for j in axes}
    return {i + j: total(j + i) for i in axes for j in axes}


def spin_residuals(values, geometry, arm="contact", reach=0.5, dynamic=True,
                   closed=False, form="cells") -> tuple:
    """div(mu - dmu) + tau + lever per cell, per component of the couple (one in 2D,
    three in 3D), div mu the net couple passed (``form="cells"``) or the field's
    finite-volume divergence (``"field"``): a moment density, each geometry's
    finite-volume form (the residual of :meth:`~granavg.engine.cells.base.Cells.residuals`
    over its own width, obtained as that of a unit source)."""
    axes, n = geometry.axes, geometry.n
    if form not in FORMS:
        raise ValueError(f"form {form!r}: choose from {', '.join(FORMS)}")
    tau = moment_density(values, geometry, arm, reach)
    source = "couple_density" if form == "cells" else "boundary_couple"
    names = [source] if len(axes) == 2 else [f"{source}_{i}" for i in axes]
    tau = [t + _component(values, k, n) for t, k in zip(tau, names)]
    source = {a: tau[0] if k == 0 else np.zeros(n) for k, a in enumerate(axes)} \
        if len(axes) == 2 else dict(zip(axes, tau))
    res = geometry.residuals(couple_flux(values, geometry, dynamic, form == "field"),
                             source, closed)
    zero = {c: np.zeros(n) for c in couple_flux({}, geometry, False)}
    width = geometry.residuals(zero, {a: np.ones(n) for a in axes}, True)
    parts = range(1) if len(axes) == 2 else range(3)
    with np.errstate(invalid="ignore", divide="ignore"):
        return tuple(np.asarray(res[k]) / np.asarray(width[k]) for k in parts)


def has_couples(values, geometry) -> bool:
    """Whether a profile holds what the balance needs: the stress and the couple stress."""
    axes = geometry.axes
    return f"sigma_{axes[0]}{axes[1]}" in values and \
        any(k.startswith("mu_") for k in values)


def spin_balance(profiles, arm="contact", dynamic=True, closed=False,
                 form="cells") -> dict:
    """The spins' balance residual of a profile, relative to its stress scale, per cell
    and component of the couple, with errors from the time replicates, the branch the
    profile's stress was averaged with its sidecar's (:func:`branch_reach`).

    Returns
    -------
    dict
        ``scale`` (the stress scale); ``residual`` and ``residual_err``, shape
        (1 or 3, n_cells), relative to it; ``arm``, ``form``; ``dynamic`` (dmu
        included); ``terms``: each term's largest |value| over the cells, relative to
        the scale (``tau``: the forces' moment density with the law's arm; ``mu``: the
        couples passed, as the residual without tau).
    """
    geo = profiles.cells
    reach = branch_reach(profiles)
    dynamic = dynamic and any(k.startswith("dmu_") for k in profiles.values)
    scale = stress_scale(profiles.values, geo)

    def relative(values):
        return np.array(spin_residuals(values, geo, arm, reach, dynamic, closed,
                                       form)) / scale
    res = relative(profiles.values)
    err = np.full(res.shape, np.nan)
    reps = profiles.replicates.in_time() if profiles.replicates is not None else None
    if reps is not None and reps.n >= 2:
        each = np.array([relative({k: v[i] for k, v in reps.values.items()})
                         for i in range(reps.n)])
        err = np.array([[reps.error(each[:, c, k]) for k in range(geo.n)]
                        for c in range(res.shape[0])])
    tau = np.array(moment_density(profiles.values, geo, arm, reach)) / scale
    return {"scale": scale, "residual": res, "residual_err": err, "arm": arm, "form": form,
            "dynamic": bool(dynamic), "closed": bool(closed),
            "terms": {"tau": float(np.nanmax(np.abs(tau))),
                      "mu": float(np.nanmax(np.abs(res - tau)))}}
