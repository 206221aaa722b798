"""The balance of forces on profiles of any cells: div(sigma - dsigma) + b + t = 0,
with b the body force density (gravity, base-plate friction; ``body_*``) and t the
boundary force density (what walls exert on the packing; ``boundary_*``).

Conventions as :mod:`granavg.analysis.continuum`: tension-positive stress, first index
the force's, divergence on the second index, (div T)_i = d_j T_ij.

Each kind of cells holds its own finite-volume form
(:meth:`~granavg.engine.cells.base.Cells.residuals`, in its module of
:mod:`granavg.engine.cells`):

- rings, steady and axisymmetric (Eqs. 11-12 with the force densities), in r-form:
  radial d(r T_rr)/dr - T_phiphi + r f_r (= r dT_rr/dr + T_rr - T_phiphi + r f_r),
  tangential d(r^2 T_phir)/dr / r + T_rphi - T_phir + r f_phi (= r dT_phir/dr + T_rphi
  + T_phir + r f_phi);
- a polar grid: the same with the phi derivatives between its sectors;
- slabs across u (2D or 3D): dT_iu/du + f_i for every component i, times the cell width;
- a grid or a 3D box grid: sum_j dT_ij/dx_j + f_i, times the mean cell width (interior
  cells, and along a periodic axis every cell);
- 3D cylindrical shells, axisymmetric: (1/r) d(r T_rr)/dr + dT_rz/dz - T_phiphi / r,
  (1/r^2) d(r^2 T_phir)/dr + dT_phiz/dz + (T_rphi - T_phir) / r and
  (1/r) d(r T_zr)/dr + dT_zz/dz, plus f, times the mean cell width (the z derivatives
  between layers; none with a single layer, where the flow is taken uniform in z).

At a wall the stress ends: the flux through the wall is nil and the wall's action is the
boundary force density, so the cells next to it are balanced in finite-volume form with
no flux through their outer face (``closed``).

Each residual is made the net force on the cell over the area of its face (rings: the
r-form times dr / r; slabs: times the width), a stress (Pa in SI) that does not grow
with the number of cells, and compared with the stress scale (the mean |trace sigma|
/ D of the cells with particles): "the cell's forces balance to x of the stress on its
face". (The paper's Fig. 7 plots the r-form itself, r/dr times larger.) Errors come from
the profiles' replicates (jackknife blocks or realisations), the same way as every
derived number.
"""

from __future__ import annotations

import numpy as np

from granavg.errors import UserError

#: Force densities that enter the balance, in the order added.
FORCE_DENSITIES = ("body", "boundary", "f_inter")


def _component(values, name, n):
    return np.asarray(values[name], float) if name in values else np.zeros(n)


def _axes(geometry):
    return geometry.axes


def tensor_total(values, geometry, dynamic=True):
    """T = sigma - dsigma (or sigma alone) as a dict of components (rr, rphi, ... or
    xx, xy, ...)."""
    axes = _axes(geometry)
    n = geometry.n
    out = {}
    for i in axes:
        for j in axes:
            s = _component(values, f"sigma_{i}{j}", n)
            d = _component(values, f"dsigma_{i}{j}", n) if dynamic else 0.0
            out[i + j] = s - d
    return out


def force_density(values, geometry, terms=FORCE_DENSITIES):
    """f = the sum of the force densities present (``body``, ``boundary``), per
    component, shape (n_cells,) each."""
    n = geometry.n
    return {c: sum((_component(values, f"{t}_{c}", n) for t in terms), np.zeros(n))
            for c in _axes(geometry)}


def residuals(values, geometry, terms=FORCE_DENSITIES, dynamic=True, closed=False):
    """The components of the balance residual per cell (the module docstring; each
    geometry's finite-volume form, :meth:`~granavg.engine.cells.base.Cells.residuals`),
    a stress: the flux of T through each face from the mean of the two cells beside it,
    and through the outer faces none where ``closed`` (else the edge cells are NaN:
    their outer flux is unknown). Fields of a smoothing kernel with their divergences
    (``divsigma_*``) balance pointwise instead (:func:`pointwise`)."""
    if pointwise_possible(values, geometry):
        return pointwise(values, geometry, terms, dynamic)
    return geometry.residuals(tensor_total(values, geometry, dynamic),
                              force_density(values, geometry, terms), closed)


def pointwise_possible(values, geometry) -> bool:
    """Whether the profile holds the divergence of its stress at every node (a smoothing
    kernel's derivative)."""
    return all(f"divsigma_{a}" in values for a in geometry.axes)


def pointwise(values, geometry, terms=FORCE_DENSITIES, dynamic=True):
    """div(sigma - dsigma) + b + t at each node from the kernel's own derivative (no
    differences between nodes), times the kernel's width w: the net force density over
    w, a stress like the finite-volume residual's, per component."""
    n = geometry.n
    f = force_density(values, geometry, terms)
    width = getattr(geometry, "width", 1.0)
    out = []
    for a in geometry.axes:
        div = _component(values, f"divsigma_{a}", n)
        if dynamic:
            div = div - _component(values, f"divdsigma_{a}", n)
        out.append(width * (div + f[a]))
    return tuple(out)


def stress_scale(values, geometry) -> float:
    """Mean |trace sigma| / D over the cells with particles (the residuals' yardstick)."""
    axes = _axes(geometry)
    tr = np.abs(sum(_component(values, f"sigma_{a}{a}", geometry.n) for a in axes)) / len(axes)
    full = np.asarray(values.get("nu", np.ones(geometry.n))) > 0
    return float(np.nanmean(tr[full])) if np.any(full) else float("nan")


def balance(profiles, terms=FORCE_DENSITIES, dynamic=True, closed=False) -> dict:
    """The balance residual of a profile, relative to its stress scale, per cell and
    component, with errors from the replicates.

    Returns
    -------
    dict
        ``scale``; ``residual`` and ``residual_err`` (D, n_cells) relative to it;
        ``terms`` (the force densities present and used).
    """
    geo = profiles.cells
    flux = ((profiles.meta or {}).get("unit_system") or {}).get("momentum_flux")
    if flux and dynamic:
        raise UserError(f"the dynamic stress is in {flux}, not the stress unit of these "
                        "units: the balance of forces would mix them (LAMMPS' real, metal "
                        "and electron styles)")
    used = [t for t in terms if any(k.startswith(t + "_") for k in profiles.values)]
    scale = stress_scale(profiles.values, geo)
    res = np.array(residuals(profiles.values, geo, used, dynamic, closed)) / scale
    err = np.full(res.shape, np.nan)
    # a sector's balance misses the tractions on its cuts: time blocks only
    reps = profiles.replicates.in_time() if profiles.replicates is not None else None
    if reps is not None and reps.n >= 2:
        each = np.array([np.array(residuals({k: v[i] for k, v in reps.values.items()}, geo,
                                            used, dynamic, closed)) / scale
                         for i in range(reps.n)])
        err = np.array([[reps.error(each[:, c, k]) for k in range(geo.n)]
                        for c in range(len(geo.axes))])
    return {"scale": scale, "residual": res, "residual_err": err, "terms": used,
            "closed": bool(closed)}
