"""The balance laws in time, on fields smoothed by a time kernel and a smoothing kernel in
space (:mod:`granavg.engine.timing`): the continuity equation d rho/dt + div(rho v) = 0
and the momentum balance d(rho v)/dt = div(sigma - dsigma) + b + t, at every node and
time. Both hold exactly for the coarse-grained fields of every instant (Goldhirsch
2010; Weinhart et al. 2012); with the frames as the time quadrature's nodes they hold to
its accuracy, which the frame interval sets (docs/time.md). Each is a claim that can
fail, with its tolerance:

- continuity: the largest |d rho/dt + div j| over the nodes and times within
  :data:`CONTINUITY_TOLERANCE` of the largest |d rho/dt|, j the mass flux of the
  displacements between frames: it holds by construction at any frame interval
  (:mod:`granavg.engine.smoothing.displacements`), and fails where particles appear or
  vanish between frames (an outlet, an insertion: a source of mass);
- continuity with the dumped velocities (``continuity_v``, where asked): d rho/dt +
  div(rho v), which holds only where the frames resolve the collisions;
- momentum between frames (``impulse_balance``, where the atoms carry forces): d(rho
  v)/dt + div j_p against the forces dumped at each interval's end, within
  :data:`MOMENTUM_TOLERANCE` of the body force density; it holds at any interval where
  those forces are the interval's means (LAMMPS' fix ave/atom);
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


def continuity(p, name: str = "continuity") -> dict | None:
    """The continuity claim of fields in time (None without ``name``): with the
    displacements' mass flux (``continuity``), or with the dumped velocities
    (``continuity_v``: how far the frames resolve the motion)."""
    res, rate = _stack(p, name), _stack(p, "drho_dt")
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
    # fields written before continuity came from the displacements hold the velocities'
    displaced = name == "continuity" and "mass_flux" in (p.meta or {}).get("time", {})
    flux = "div j (the displacements' mass flux)" if displaced else \
        "div(rho v) (the dumped velocities)"
    return {"ratio": ratio, "scale": scale, "per_time": per_time.tolist(),
            "claim": _entry(
                f"continuity in time: d rho/dt + {flux} = 0 at every node and time",
                result, f"largest |residual| {ratio:.3g} of the largest |d rho/dt| "
                f"({scale:.4g} {unit}){where}",
                f"{CONTINUITY_TOLERANCE:.0%} of the largest |d rho/dt|")}


def _relative(p, name="momentum_balance"):
    """The momentum residual ``name`` and its estimated time-quadrature error (None
    where the fields lack it) relative to the yardstick at bulk nodes (NaN elsewhere),
    shape (n_times, n_cells) each, the yardstick in words and the largest terms there."""
    res = _vectors(p, name)
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
    estimate = _stack(p, "momentum_quadrature") if name == "momentum_balance" else None
    with np.errstate(invalid="ignore", divide="ignore"):
        keep = bulk & (yard > 0)
        rel = np.where(keep, residual / yard, np.nan)
        quad = None if estimate is None else np.where(keep, estimate / yard, np.nan)
    return rel, quad, bulk, yardstick, size


def _median(a) -> float:
    return float(np.nanmedian(a)) if a is not None and np.any(np.isfinite(a)) else float("nan")


#: The momentum balances in time: the residual's name and its claim.
BALANCES = {
    "momentum_balance": "momentum balance in time: d(rho v)/dt = div(sigma - dsigma) + b + t "
                        "at bulk nodes",
    "impulse_balance": "momentum between frames: d(rho v)/dt + div j_p = the mean forces "
                       "dumped (fix ave/atom) at bulk nodes"}


def momentum(p, name: str = "momentum_balance") -> dict | None:
    """The momentum claim of fields in time at bulk nodes (None without the residual
    ``name``: :data:`BALANCES`), with each term's largest magnitude there and, where the
    fields hold it (``momentum_quadrature``), the estimated time-quadrature error beside
    the residual: a residual within twice that estimate is the frames' interval's, one
    beyond it a force the balance misses (a body force, a wall)."""
    found = _relative(p, name)
    if found is None:
        return None
    rel, quad, bulk, yardstick, size = found
    ratio = float(np.nanmax(rel)) if np.any(np.isfinite(rel)) else float("nan")
    result = "inconclusive" if not np.isfinite(ratio) else \
        "holds" if ratio <= MOMENTUM_TOLERANCE else "violated"
    unit = p.units.get(columns(name, p.cells.axes)[0], "")
    shown = ", ".join(f"{k} {v:.4g}" for k, v in size.items())
    per_time = [float(np.nanmax(r)) if np.any(np.isfinite(r)) else float("nan") for r in rel]
    out = {"ratio": ratio, "median": _median(rel), "bulk_nodes": int(np.sum(bulk)),
           "terms": size, "per_time": per_time}
    quadrature = ""
    if quad is not None and np.any(np.isfinite(quad)):
        beyond = np.isfinite(rel) & np.isfinite(quad) & (rel > MOMENTUM_TOLERANCE) & \
            (rel > 2.0 * quad)
        out.update(quadrature_median=_median(quad), quadrature_largest=float(np.nanmax(quad)),
                   beyond_quadrature=int(np.sum(beyond)))
        quadrature = (f"; estimated time-quadrature error median {out['quadrature_median']:.3g}"
                      f", largest {out['quadrature_largest']:.3g} (residual median "
                      f"{out['median']:.3g}); {out['beyond_quadrature']} node-times miss the "
                      "tolerance by more than twice the estimate (a force the balance "
                      "lacks, not the frames' interval)")
    out["claim"] = _entry(
        BALANCES[name], result,
        f"largest |residual| {ratio:.3g} of {yardstick}, over {int(np.sum(bulk))} "
        f"bulk node-times; largest terms there ({unit}): {shown}{quadrature}",
        f"{MOMENTUM_TOLERANCE:.0%} of {yardstick}")
    return out


#: The momentum residual a dump interval is forecast for by default: the median over
#: bulk node-times, of the yardstick (rho g; without a body force, the largest |div
#: sigma|).
TARGET = 0.01
#: Where the forecast runs through intervals the data do not show, it aims at the target
#: over this: toward longer intervals (the error may steepen there), and toward shorter
#: ones from frames that resolve the collisions (the error's measured order at least 1:
#: the residual flattens below toward what no interval removes, orders 0.7-0.9 measured
#: on the collapse below 0.2 contact durations).
MARGIN = 2.0 ** 0.5
#: The orders the forecast takes toward shorter and toward longer intervals: the
#: shallowest and the steepest the error's order was measured at on the collapse and
#: the silo (docs/time.md). Toward shorter intervals, 1: the trapezoid rule's on a force
#: that jumps where a contact starts (a dashpot), once the frames resolve the
#: collisions (through the transition from unresolved collisions it is steeper, 1.3-1.8,
#: so the forecast errs on the short side); toward longer ones, 2 (measured 1.6-2.0
#: through that transition).
FORECAST_ORDERS = {"shorter": 1.0, "longer": 2.0}


def interval_forecast(p, target: float = TARGET) -> dict | None:
    """The dump interval that the momentum balance in time needs for a median residual
    of ``target`` (of the yardstick, at bulk nodes), forecast from the fields' own
    residual r and estimated quadrature error e at their frames' interval h (None
    without ``momentum_quadrature`` or the interval).

    Where e is at least half of r the residual is the quadrature's (anchor r, no
    floor); else the floor r - e is what no interval removes (a missing force, the
    dumps' own consistency) and e the part that shrinks. The residual at h' is forecast
    as floor + anchor (h'/h)^q, q from :data:`FORECAST_ORDERS` (toward shorter intervals
    where r is above the target, else toward longer); the interval named is where that
    reaches the target, or target / :data:`MARGIN` toward longer intervals and where the
    error's measured order (``meta["time"]["quadrature"]``) is at least 1 (the frames
    resolve the collisions). None is named where the floor is above it. Checked on the
    collapse from frames every 1 to 200 steps (0.02-4 contact durations) and the silo
    from 20 to 200: the residual at the interval named is at most the target, at 4
    times it more (docs/time.md)."""
    found = _relative(p)
    interval = (p.meta or {}).get("time", {}).get("interval")
    if found is None or found[1] is None or not interval:
        return None
    rel, quad = found[0], found[1]
    r, e = _median(rel), _median(quad)
    if not (np.isfinite(r) and np.isfinite(e)):
        return None
    quadrature = e >= 0.5 * r
    anchor, floor = (r, 0.0) if quadrature else (e, r - e)
    width = (p.meta["time"].get("width") or np.inf)
    order = (p.meta["time"].get("quadrature") or {}).get("order")
    resolved = order is not None and np.isfinite(order) and order >= 1.0
    toward = "shorter" if r > target else "longer"
    margin = MARGIN if resolved or toward == "longer" else 1.0
    aim = target / margin
    out = {"target": target, "interval": float(interval), "residual_median": r,
           "quadrature_median": e, "floor": floor,
           "residual_is": "the time quadrature's" if quadrature else
           "mostly not the time quadrature's", "order_measured": order,
           "collisions": "resolved: order >= 1" if resolved else
           "not resolved: order < 1, the frames alias them",
           "toward": toward, "order_used": FORECAST_ORDERS[toward], "margin": margin,
           "time_unit": p.unit_system.unit("{time}"), "yardstick": found[3]}
    if floor >= aim:
        out.update(forecast_interval=None, why=(
            f"the residual the quadrature does not explain ({floor:.3g}) is above "
            f"{aim:.3g}: no dump interval reaches {target:g}; look for a force the balance "
            "lacks (a body force, a wall) or the dumps' own consistency (docs/time.md)"))
        return out
    # an anchor of zero (no residual, no error): any interval up to the time kernel's
    # width (the widest a kernel takes frames at)
    h = float(interval) * ((aim - floor) / anchor) ** (1.0 / FORECAST_ORDERS[toward]) \
        if anchor > 0 else np.inf
    out["forecast_interval"] = float(min(h, width))
    if h > width:
        out["capped"] = "at the time kernel's width: frames no sparser than it"
    return out


def forecast_line(f: dict) -> str:
    """The forecast in words, for the log."""
    unit = f["time_unit"]
    head = (f"momentum balance in time at the frames' interval {f['interval']:.4g} {unit}: "
            f"median residual {f['residual_median']:.3g} of {f['yardstick']}, estimated "
            f"time-quadrature error {f['quadrature_median']:.3g} ({f['residual_is']}; "
            f"collisions {f['collisions']})")
    if f["forecast_interval"] is None:
        return f"{head}; {f['why']}"
    return (f"{head}; for a median residual of {f['target']:g} dump every "
            f"{f['forecast_interval']:.3g} {unit} or less (forecast: order "
            f"{f['order_used']:g} toward {f['toward']} intervals, margin "
            f"{f['margin']:.2g})")


def time_summary(p) -> dict:
    """The balance laws in time of fields in time: the two claims where the fields hold
    their residuals (a time kernel and a smoothing kernel in space), else why not."""
    out = {"times": np.asarray(p.times).tolist(), "kind": p.meta.get("time", {}).get("kind")}
    found = {"continuity": continuity(p), "continuity_v": continuity(p, "continuity_v"),
             "momentum": momentum(p), "impulse": momentum(p, "impulse_balance")}
    out.update({k: v for k, v in found.items() if v is not None})
    forecast = interval_forecast(p)
    if forecast is not None:
        out["forecast"] = forecast
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
                             ("continuity_v", CONTINUITY_TOLERANCE, "^"),
                             ("momentum", MOMENTUM_TOLERANCE, "s"),
                             ("impulse", MOMENTUM_TOLERANCE, "v")):
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
    if tb.get("forecast"):
        table += f"<p>The dump interval: {html.escape(forecast_line(tb['forecast']))}.</p>"
    return (f"<h2>{html.escape(s['profile'])}</h2><p>{s['n_cells']} "
            f"{html.escape(p.cells.kind)} at {s['n_times']} times ({html.escape(str(tb['kind']))}), "
            f"{s['n_frames']} frames, units {html.escape(str(s['units']))}.</p>" + table + img)
