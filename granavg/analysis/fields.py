"""Fields of any cells (rings, slabs, grids; 3D slabs, boxes and shells; anyone's
dumps, no run manifest): the fields plotted against position (slices through 3D grids),
the balance of forces (:mod:`granavg.analysis.balance`) per cell with its errors, and a
summary. The paper's ring-specific checks (:mod:`granavg.paper.claims`) are not made
here.

Plotting functions take ``ax=None`` (a new figure) and return the axes.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from granavg.analysis.balance import balance  # noqa: E402
from granavg.analysis.spin_balance import has_couples, spin_balance  # noqa: E402
from granavg.analysis.time_balance import time_row, time_summary  # noqa: E402
from granavg.engine.quantities import columns  # noqa: E402

OKABE_ITO = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000"]
#: Markers, with the colours: every component of a panel looks different (9 in 3D).
MARKERS = "os^Dv<>P*X"
#: Quantities drawn together, one panel each, all of a panel in one unit.
PANELS = [("volume fraction", ("nu",)), ("velocity", ("v",)),
          ("static stress", ("sigma",)), ("dynamic stress", ("dsigma",)),
          ("force densities", ("body", "boundary"))]


def _style(k):
    """Colour and marker of the k-th series of a panel."""
    return {"color": OKABE_ITO[k % len(OKABE_ITO)], "marker": MARKERS[k % len(MARKERS)]}


def _axis_label(p, name):
    """A coordinate's axis label with the profile's length unit: ``z (m)``."""
    unit = (p.meta.get("columns") or {}).get(name)
    return f"{name} ({unit})" if unit else name


def position(p):
    """(name, coordinate per cell) of a 1D profile (rings, slabs, shells of one layer);
    None for cells that form a plane or a volume (:func:`slice_panels`)."""
    return p.cells.position()


#: The fields a slice shows, when present: volume fraction, speed and pressure.
SLICED = ("nu", "speed", "pressure")


def _field(p, name):
    """A field of the slices: a value, the speed |v| or the pressure -tr sigma / D."""
    axes = p.cells.axes
    if name == "speed":
        if not all(f"v_{i}" in p.values for i in axes):
            return None
        return np.sqrt(sum(p.values[f"v_{i}"] ** 2 for i in axes))
    if name == "pressure":
        if not all(f"sigma_{i}{i}" in p.values for i in axes):
            return None
        return -sum(p.values[f"sigma_{i}{i}"] for i in axes) / len(axes)
    return p.values.get(name)


def slice_panels(p, ax=None):
    """Maps of :data:`SLICED` over the planes the cells draw (their ``planes()``: a 2D
    grid or a polar grid whole, the middle z layer and y plane of boxes, the r-z plane of
    shells), one row per plane."""
    planes = p.cells.planes()
    fields = [f for f in SLICED if _field(p, f) is not None]
    if ax is None:
        _, ax = plt.subplots(len(planes), len(fields), squeeze=False,
                             figsize=(3.8 * len(fields), 3.2 * len(planes)),
                             constrained_layout=True)
    ax = np.atleast_2d(ax)
    units = p.meta.get("columns", {})
    for row, (title, (hx, he), (vx, ve), cut) in enumerate(planes):
        for col, name in enumerate(fields):
            a = ax[row, col]
            mesh = a.pcolormesh(he, ve, cut(np.asarray(_field(p, name), float)),
                                cmap="viridis", shading="flat")
            unit = units.get({"speed": f"v_{p.cells.axes[0]}",
                              "pressure": f"sigma_{p.cells.axes[0] * 2}"}.get(name, name), "")
            a.figure.colorbar(mesh, ax=a, label=f"{name} ({unit})" if unit else name)
            a.set(xlabel=_axis_label(p, hx), ylabel=_axis_label(p, vx), title=f"{name}: {title}")
            a.set_aspect("equal")
    return ax


def profile_panels(p, ax=None):
    """Each panel of :data:`PANELS` against position, values with their errors, the
    y axis labelled with the panel's unit."""
    where = position(p)
    panels = [(t, [c for q in qs for c in columns(q, p.cells.axes) if c in p.values])
              for t, qs in PANELS]
    panels = [(t, ks) for t, ks in panels if ks]
    if ax is None:
        _, ax = plt.subplots(1, len(panels), figsize=(4.0 * len(panels), 4.0),
                             constrained_layout=True)
    ax = np.atleast_1d(ax)
    units = p.meta.get("columns", {})
    for a, (title, keys) in zip(ax, panels):
        for k, key in enumerate(keys):
            if where is None:
                continue
            a.errorbar(where[1], p.values[key], yerr=p.sem.get(key), ls="-", ms=3,
                       label=key, **_style(k))
        unit = units.get(keys[0])
        a.set(title=title, xlabel=_axis_label(p, where[0]) if where else "cell",
              ylabel=f"{title} ({'-' if unit in (None, '', '1') else unit})")
        if len(keys) > 3:                           # many: under the axes, off the data
            a.legend(fontsize=6, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.2),
                     frameon=False)
        else:
            a.legend(fontsize=6)
    return ax


def balance_panel(p, result, ax=None, spins=False):
    """The balance residual per cell (each component, relative to the stress scale),
    with its errors; the band +-0.1 for scale. ``spins``: the spins' balance
    (:mod:`granavg.analysis.spin_balance`; one component in 2D, about z)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(4.8, 3.2), constrained_layout=True)
    where = position(p)
    x = where[1] if where else np.arange(p.cells.n)
    comps = ("z",) if spins and p.cells.dim == 2 else p.cells.axes
    for k, comp in enumerate(comps):
        ax.errorbar(x, result["residual"][k], yerr=result["residual_err"][k], ls="none",
                    ms=4, label=f"{comp} component", **_style(k))
    ax.axhspan(-0.1, 0.1, color="0.9", zorder=0)
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel(_axis_label(p, where[0]) if where else "cell")
    if spins:
        ax.set_ylabel("unbalanced moment density / stress scale (-)")
        ax.set_title(f"balance of the spins ({result['form']} form, lever arm to the "
                     f"{'contact point' if result['arm'] == 'contact' else 'surface'})",
                     fontsize=9)
    else:
        ax.set_ylabel("net force on a cell / (stress scale x face) (-)")
        terms = ", ".join(result["terms"]) or "none"
        ax.set_title(f"balance (force densities: {terms})", fontsize=9)
    ax.legend(fontsize=7)
    return ax


def spin_summary(p, closed=False, arm="contact") -> dict | None:
    """The spins' balance of a profile (None without the stress and couple fields): the
    cells' form where the profile holds the couples passed (``couple_density``), else
    the field's; median and largest |residual| with the residuals and errors."""
    if not has_couples(p.values, p.cells):
        return None
    form = "cells" if any(k.startswith("couple_density") for k in p.values) else "field"
    b = spin_balance(p, arm=arm, closed=closed, form=form)
    occupied = np.asarray(p.values.get("nu", np.ones(p.cells.n))) > 0
    res = np.abs(b["residual"])[:, occupied]
    return {"form": form, "arm": arm, "stress_scale": b["scale"], "terms": b["terms"],
            "median_abs_residual": float(np.nanmedian(res)) if res.size else None,
            "max_abs_residual": float(np.nanmax(res)) if res.size else None,
            "residual": b["residual"].tolist(), "residual_err": b["residual_err"].tolist()}


def analyze_fields(profiles, names, closed=False, arm="contact") -> dict:
    """The summary of profiles of any cells: per profile its geometry, units, the
    balance of forces (median and largest |residual| with errors; with and without the
    force densities) and, where the profile holds the couple stress, the spins' balance
    (:func:`spin_summary`; ``arm``: the contact law's lever arm for the torque)."""
    out = {"kind": "fields", "closed": bool(closed), "profiles": []}
    for p, name in zip(profiles, names):
        if p.in_time:                      # the balance laws in time instead
            out["profiles"].append({
                "profile": str(name), "geometry": p.cells.describe(), "n_cells": p.cells.n,
                "units": p.meta.get("units"), "n_times": len(p.times),
                "n_frames": (p.meta.get("frames") or {}).get("n"),
                "time_balance": time_summary(p)})
            continue
        full, bare = balance(p, closed=closed), balance(p, terms=(), closed=closed)
        occupied = np.asarray(p.values.get("nu", np.ones(p.cells.n))) > 0
        res = np.abs(full["residual"])[:, occupied]
        out["profiles"].append({
            "profile": str(name), "geometry": p.cells.describe(), "n_cells": p.cells.n,
            "units": p.meta.get("units"), "n_frames": p.n_frames,
            "boundary": p.meta.get("boundary", "not averaged"),
            "balance": {"terms": full["terms"], "stress_scale": full["scale"],
                        "median_abs_residual": float(np.nanmedian(res)) if res.size else None,
                        "max_abs_residual": float(np.nanmax(res)) if res.size else None,
                        "max_abs_residual_without_forces":
                            float(np.nanmax(np.abs(bare["residual"])[:, occupied]))
                            if res.size else None,
                        "residual": full["residual"].tolist(),
                        "residual_err": full["residual_err"].tolist()},
            "spin_balance": spin_summary(p, closed, arm)})
    return out


def _saved(draw, path, figures: bool) -> str:
    """``draw()``'s figure saved as ``path`` and its ``<img>`` tag, or nothing without
    ``figures``."""
    if not figures:
        return ""
    fig = draw().figure
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return f"<img src='figures/{path.name}'>"


def _spin_row(p, s, k, out, figures: bool = True) -> str:
    """The spins' balance of one profile: its panel (saved) and sentence."""
    sb = s.get("spin_balance")
    if not sb:
        return ""
    img = _saved(lambda: balance_panel(p, {
        "residual": np.array(sb["residual"]), "residual_err": np.array(sb["residual_err"]),
        "form": sb["form"], "arm": sb["arm"]}, spins=True),
        out / "figures" / f"spin_balance{k}.png", figures)
    return (f"<p>Balance of the spins ({sb['form']} form, the law's lever arm to the "
            f"{html.escape(sb['arm'])}): median |residual| {sb['median_abs_residual']:.3g}, "
            f"largest {sb['max_abs_residual']:.3g} of the stress scale; the forces' moment "
            f"density alone reaches {sb['terms']['tau']:.3g}.</p>" + img)


def write_field_report(summary, profiles, out, figures: bool = True) -> Path:
    """Figures (PNG; none without ``figures``), ``summary.json`` and a small
    ``report.html`` into ``out``; fields in time with their balance laws in time
    (:func:`~granavg.analysis.time_balance.time_row`)."""
    out = Path(out)
    if figures:
        (out / "figures").mkdir(parents=True, exist_ok=True)
    rows = []
    for k, (p, s) in enumerate(zip(profiles, summary["profiles"])):
        if "time_balance" in s:
            rows.append(time_row(p, s, out / "figures" / f"time{k}.png", figures,
                                 _saved))
            continue
        res = {"residual": np.array(s["balance"]["residual"]),
               "residual_err": np.array(s["balance"]["residual_err"]),
               "terms": s["balance"]["terms"]}
        imgs = _saved(lambda: (profile_panels(p) if position(p) else
                               slice_panels(p).ravel())[0],
                      out / "figures" / f"profiles{k}.png", figures) + \
            _saved(lambda: balance_panel(p, res), out / "figures" / f"balance{k}.png",
                   figures)
        b = s["balance"]
        rows.append(f"<h2>{html.escape(s['profile'])}</h2><p>{s['n_cells']} "
                    f"{html.escape(p.cells.kind)}, {s['n_frames']} frames, units "
                    f"{html.escape(str(s['units']))}. Balance of forces (force densities: "
                    f"{html.escape(', '.join(b['terms']) or 'none')}; outer faces "
                    f"{'closed' if summary['closed'] else 'open: edge cells not judged'}; "
                    f"boundary term: {html.escape(s['boundary'])}): "
                    f"median |residual| {b['median_abs_residual']:.3g}, largest "
                    f"{b['max_abs_residual']:.3g} (without the force densities "
                    f"{b['max_abs_residual_without_forces']:.3g}) of the stress scale "
                    f"{b['stress_scale']:.4g}.</p>" + imgs + _spin_row(p, s, k, out, figures))
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "report.html").write_text(
        "<!doctype html><meta charset='utf-8'><title>granavg fields</title><body>"
        "<h1>granavg: fields and their balance laws</h1>" + "".join(rows) + "</body>")
    return out / "report.html"
