"""The balance laws in time, on fields smoothed by a time kernel and a smoothing kernel in
space (:mod:`granavg.engine.timing`): the continuity equation d rho/dt + div(rho v) = 0
and the momentum balance d(rho v)/dt = div(sigma - dsigma) + b + t, at every node and
time. Both hold exactly for the coarse-grained fields of every instant (Goldhirsch
2010; Weinhart et al. 2012); with the frames as the time quadrature's nodes they hold to
its accuracy, which the frame interval sets (docs/time.md). Each is a claim that can
fail, with its tolerance:

- continuity: the largest |d rho/dt + div(rho v)| over the nodes and times within
  :data:`CONTINUITY_TOLERANCE` of the largest |d rho/dt|;
- momentum: at bulk nodes (volume fraction at least :data:`BULK` of the time's
  largest), the largest |residual| within :data:`MOMENTUM_TOLERANCE` of the body force
  density there (rho g under gravity; without a body force, of the largest |div sigma|),
  each term reported.
"""

from __future__ import annotations

import html

import numpy as np

from granavg.engine.quantities import columns

#: The continuity claim's tolerance: of the largest |d rho/dt|.
CONTINUITY_TOLERANCE = 0.01
#: The momentum claim's tolerance: of the body force density (rho g) at bulk nodes.
MOMENTUM_TOLERANCE = 0.02
#: Bulk nodes: volume fraction at least this share of the time's largest.
BULK = 0.5


def _stack(p, name):
    return np.asarray(p.values[name], float) if name in p.values else None


def _vectors(p, name):
    """The components of a vector field, shape (D, n_times, n_cells), or None."""
    cols = columns(name, p.cells.axes)
    if not all(c in p.values for c in cols):
        return None
    return np.stack([np.asarray(p.values[c], float) for c in cols])


def _entry(text, result, evidence, tolerance):
    return {"claim": text, "kind": "identity", "verdict": result,
            "reproduced": result == "holds", "tolerance": tolerance, "note": "",
            "evidence": evidence}


def continuity(p) -> dict | None:
    """The continuity claim of fields in time (None without ``continuity``)."""
    res, rate = _stack(p, "continuity"), _stack(p, "drho_dt")
    if res is None or rate is None:
        return None
    scale = float(np.nanmax(np.abs(rate))) if np.any(np.isfinite(rate)) else float("nan")
    worst = np.nanargmax(np.abs(res)) if np.any(np.isfinite(res)) else None
    ratio = float(np.abs(res.flat[worst]) / scale) if worst is not None and scale > 0 \
        else float("nan")
    per_time = np.nanmax(np.abs(res), axis=1) / scale if scale > 0 else \
        np.full(len(p.times), np.nan)
    result = "inconclusive" if not np.isfinite(ratio) else \
        "holds" if ratio <= CONTINUITY_TOLERANCE else "violated"
    where = "" if worst is None else \
        f" at t = {p.times[worst // p.cells.n]:.4g}, node {worst % p.cells.n}"
    unit = p.units.get("drho_dt", "")
    return {"ratio": ratio, "scale": scale, "per_time": per_time.tolist(),
            "claim": _entry(
                "continuity in time: d rho/dt + div(rho v) = 0 at every node and time",
                result, f"largest |residual| {ratio:.3g} of the largest |d rho/dt| "
                f"({scale:.4g} {unit}){where}",
                f"{CONTINUITY_TOLERANCE:.0%} of the largest |d rho/dt|")}


def momentum(p) -> dict | None:
    """The momentum claim of fields in time at bulk nodes (None without
    ``momentum_balance``), with each term's largest magnitude there."""
    res = _vectors(p, "momentum_balance")
    if res is None:
        return None
    nu = _stack(p, "nu")
    bulk = nu >= BULK * np.nanmax(nu, axis=1, keepdims=True) if nu is not None else \
        np.ones(res.shape[1:], bool)
    body = _vectors(p, "body")
    terms = {name: _vectors(p, name) for name in
             ("dmomentum_dt", "divsigma", "divdsigma", "body", "boundary", "f_inter")}
    size = {k: float(np.nanmax(np.linalg.norm(v, axis=0)[bulk])) for k, v in terms.items()
            if v is not None and np.any(bulk)}
    residual = np.linalg.norm(res, axis=0)
    if body is not None:
        yard = np.linalg.norm(body, axis=0)
        yardstick = "the body force density there (rho g)"
    else:
        yard = np.full(residual.shape, size.get("divsigma", np.nan))
        yardstick = "the largest |div sigma| at bulk nodes (no body force)"
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(bulk & (yard > 0), residual / yard, np.nan)
    ratio = float(np.nanmax(rel)) if np.any(np.isfinite(rel)) else float("nan")
    result = "inconclusive" if not np.isfinite(ratio) else \
        "holds" if ratio <= MOMENTUM_TOLERANCE else "violated"
    unit = p.units.get(columns("momentum_balance", p.cells.axes)[0], "")
    shown = ", ".join(f"{k} {v:.4g}" for k, v in size.items())
    per_time = [float(np.nanmax(r)) if np.any(np.isfinite(r)) else float("nan") for r in rel]
    return {"ratio": ratio, "bulk_nodes": int(np.sum(bulk)), "terms": size,
            "per_time": per_time,
            "claim": _entry(
                "momentum balance in time: d(rho v)/dt = div(sigma - dsigma) + b + t at "
                "bulk nodes", result,
                f"largest |residual| {ratio:.3g} of {yardstick}, over {int(np.sum(bulk))} "
                f"bulk node-times; largest terms there ({unit}): {shown}",
                f"{MOMENTUM_TOLERANCE:.0%} of {yardstick}")}


def time_summary(p) -> dict:
    """The balance laws in time of fields in time: the two claims where the fields hold
    their residuals (a time kernel and a smoothing kernel in space), else why not."""
    out = {"times": np.asarray(p.times).tolist(), "kind": p.meta.get("time", {}).get("kind")}
    found = {"continuity": continuity(p), "momentum": momentum(p)}
    out.update({k: v for k, v in found.items() if v is not None})
    out["claims"] = [v["claim"] for v in found.values() if v is not None]
    if not out["claims"]:
        out["why_none"] = ("the fields hold no residual of a balance law in time: average "
                           "with a time kernel (time_kernel, time_width, times) and a "
                           "smoothing kernel in space (kernel, width)")
    return out


def time_panels(p, summary, ax=None):
    """Fields in time at a glance: the volume fraction (or the first field) against
    position and time (:meth:`~granavg.engine.fields.Fields.plot`: a kymograph; cells
    that form a plane: at the middle time), and each balance law's largest residual
    against time, relative to its yardstick, with the tolerance. Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(1, 2, figsize=(9.6, 3.6), constrained_layout=True)
    name = "nu" if "nu" in p.values else next(iter(p.values))
    if p.cells.position() is not None:
        p.plot(name, ax=ax[0])
    else:
        p.plot(name, ax=ax[0], time=p.times[len(p.times) // 2])
    t = np.asarray(p.times)
    for key, tol, marker in (("continuity", CONTINUITY_TOLERANCE, "o"),
                             ("momentum", MOMENTUM_TOLERANCE, "s")):
        if key in summary and len(summary[key]["per_time"]) == len(t):
            line, = ax[1].semilogy(t, summary[key]["per_time"], marker=marker, ms=3,
                                   label=key)
            ax[1].axhline(tol, color=line.get_color(), ls="--", lw=0.8)
    t_unit = p.unit_system.unit("{time}")
    ax[1].set(xlabel=f"t ({t_unit})", ylabel="largest |residual| / yardstick (-)",
              title="balance laws in time (dashed: tolerances)")
    if ax[1].lines:
        ax[1].legend(fontsize=7)
    return ax


def time_row(p, s, figure, figures: bool, saved) -> str:
    """The report's section of fields in time: what they are, the claims, the figure
    (``saved(draw, path, figures)`` saves it and gives its tag)."""
    tb = s["time_balance"]
    img = saved(lambda: time_panels(p, tb)[0], figure, figures)
    claims = "".join(f"<tr><td>{html.escape(c['claim'])}</td><td>{c['verdict']}</td>"
                     f"<td>{html.escape(c['tolerance'])}</td>"
                     f"<td>{html.escape(c['evidence'])}</td></tr>" for c in tb["claims"])
    table = ("<table><tr><th>claim</th><th>verdict</th><th>tolerance</th><th>the numbers"
             f"</th></tr>{claims}</table>") if claims else \
        f"<p>{html.escape(tb['why_none'])}.</p>"
    return (f"<h2>{html.escape(s['profile'])}</h2><p>{s['n_cells']} "
            f"{html.escape(p.cells.kind)} at {s['n_times']} times ({html.escape(str(tb['kind']))}), "
            f"{s['n_frames']} frames, units {html.escape(str(s['units']))}.</p>" + table + img)
