"""Which contact law or preparation gives a steady, jammed shear state? (issue 12)

Usage::

    python workflows/steady_state.py OUT [--seeds 2] [--t-end 250] [--only NAME ...]
                                         [--baseline ENSEMBLE_DIR]
    python workflows/steady_state.py OUT --score NAME ENSEMBLE_DIR [--t-min S]
    python workflows/steady_state.py OUT --table

Every candidate keeps the paper's geometry, disk counts, sizes and Omega and runs as an
ensemble of independent packings (``granavg simulate --seeds``, dask). Each run is
averaged over 20 and 60 rings from two rotations on (its time series and the steadiness
test included), and the candidate is scored on the issue's targets: bulk coordination
>= 3 and rattlers < 15% after the transient, a steady window (the bulk pressure's trend
within 3% per rotation by 2 errors, C_bulk's and nu_bulk's within 2 errors of none, and
with 3 or more runs no drift by the spread between them; "too short to tell" when the
pressure's trend is neither shown within nor beyond 3%), dynamic/static stress <= 0.01
in the bulk, v0/(Omega R_i) within 10% of 0.645 and s within 15% of 12.7 mm (by the band
estimator of granavg.analysis.shear_band, within the tolerance by 2 combined statistical
and systematic errors). Resumable: candidates already in OUT are not run again. Writes
OUT/candidates.csv, prints a markdown table and draws OUT/timeseries.png. ``--score``
scores the runs of an ensemble made otherwise (e.g. ``granavg simulate --preset paper
--seeds 4``) as candidate NAME, over its preset's window or from ``--t-min``.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd

CANDIDATES = {
    "paper: gran/hooke/history, mu 0.8": [],
    "higher friction: mu 2": ["mu=2", "mu_wall=2"],
    "rolling resistance: mu_roll 0.1": ["mu_roll=0.1"],
    "rolling resistance: mu_roll 0.3": ["mu_roll=0.3"],
    "higher disk friction: mu 2, mu_wall 0.8": ["mu=2"],
    "denser (last resort): area fraction 0.830, mu 0.8": ["n_small=2590", "n_large=415"],
}
TARGETS = {"C_bulk": 3.0, "rattler_fraction": 0.15, "dyn_over_static_bulk": 0.01,
           "v0": (0.645, 0.10), "s": (0.0127, 0.15)}
log = logging.getLogger("steady")


def slug(name: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in name).strip("_")


def run_candidate(out: Path, overrides, seeds: int, t_end: float) -> list:
    from granavg.sim.realisations import simulate_ensemble
    from granavg.pipeline.spec import Execution
    from granavg.sim.scene import preset

    scene = preset("paper-hooke").with_overrides([*overrides, f"t_end={t_end}", "dump_dt=5",
                                            f"restart_dt={t_end}"])
    return simulate_ensemble(scene, out, seeds, Execution(workers=min(seeds, 2)),
                             preset="paper-hooke")


def score(runs, t_min=None) -> dict:
    """The targets measured on the runs (window: t_min, default the scene's discarded
    rotations, to the end)."""
    from granavg.analysis.regime import dynamic_over_static
    from granavg.paper.claims import analyze
    from granavg.paper.verdicts import bulk
    from granavg.pipeline.runs import average_run
    from granavg.engine.combine import combine_runs

    p20s, p60s = ([average_run(r, bins=n, t_min=t_min, progress=False) for r in runs]
                  for n in (20, 60))
    for run, p in zip(runs, p20s):
        p.timeseries.to_csv(run.parent / f"{run.name}.timeseries.csv", index=False)
    p20 = combine_runs(p20s, [str(r) for r in runs]) if len(runs) > 1 else p20s[0]
    p60 = combine_runs(p60s, [str(r) for r in runs]) if len(runs) > 1 else p60s[0]
    summary = analyze(p20, p60, p20.meta["run_manifest"])
    t_min = p20.meta["frames"]["t_min_s"]
    ts = [p.timeseries[p.timeseries.t_s >= t_min] for p in p20s]
    window = pd.concat(ts)
    drift = {q: [(lambda r: bool(r.get("drifts") or r.get("undetermined")))(
                 p.meta["stationarity"].get(q, {})) for p in p20s]
             for q in ("C_bulk", "P_bulk_Pa", "nu_bulk")}
    ensemble = next((v for k, v in summary["stationarity"].items()
                     if k.startswith("ensemble")), {})
    first = pd.concat([p.timeseries[p.timeseries.t_s < 20] for p in p20s])
    period = 2 * math.pi / p20.meta["run_manifest"]["scene"]["Omega"]
    trends = {f"{q}_trend_per_rotation{suffix}": v for q, rel, suffix in
              (("P_bulk_Pa", True, "_rel"), ("C_bulk", False, ""), ("nu_bulk", False, ""))
              for key, v in zip(("", "_err"), trend_per_rotation(ts, q, period, rel))
              for suffix in [suffix + key]}
    sb = summary["numbers"]["shear_band"]
    ratio = dynamic_over_static(p20)[bulk(p20.cells.n)]
    return {
        "runs": len(runs), "t_min_s": t_min,
        "C_bulk_start": first.C_bulk.mean(), "P_bulk_start_Pa": first.P_bulk_Pa.mean(),
        "C_bulk": window.C_bulk.mean(), "C_bulk_err": _between(ts, "C_bulk"),
        "rattler_fraction": window.rattler_fraction.mean(),
        "P_bulk_Pa": window.P_bulk_Pa.mean(), "P_bulk_Pa_err": _between(ts, "P_bulk_Pa"),
        "psi6_bulk_ordered": window.psi6_bulk_ordered.mean(),
        "pressure_drifts": sum(bool(d) for d in drift["P_bulk_Pa"]),
        "C_drifts": sum(bool(d) for d in drift["C_bulk"]),
        "nu_drifts": sum(bool(d) for d in drift["nu_bulk"]),
        # the window judged from the spread between >= 3 realisations (z in errors)
        "ensemble_z": {q: ensemble[q]["z"] for q in ("C_bulk", "P_bulk_Pa", "nu_bulk")
                       if q in ensemble},
        "ensemble_drifts": [q for q in ("C_bulk", "P_bulk_Pa", "nu_bulk")
                            if q in ensemble and ensemble[q]["drifts"]],
        "dyn_over_static_bulk": float(np.nanmax(ratio)),
        "v0": sb["v0_over_omega_Ri"], "v0_err": sb["v0_over_omega_Ri_err"],
        "v0_sys": sb["v0_over_omega_Ri_sys"],
        "s": sb["s_m"], "s_err": sb["s_m_err"], "s_sys": sb["s_m_sys"],
        "claims": {c["claim"]: c["verdict"] for c in summary["claims"]},
        **trends,
    }


def trend_per_rotation(parts, q, period, relative=False):
    """The linear trend of quantity ``q`` per inner-ring rotation over each run's window
    (relative to its mean where ``relative``), mean over the runs, and its error: the
    spread between the runs, but never below the mean's error from each fit's own
    error (from the fluctuations about its line, by blocking: a lower bound); two runs'
    spread alone is too uncertain."""
    from granavg.engine.stationarity import _fluctuation_error

    slopes, errs = [], []
    for p in parts:
        t, x = p.t_s.to_numpy(float), p[q].to_numpy(float)
        ok = np.isfinite(x)
        t, x = t[ok], x[ok]
        if len(t) < 4:
            continue
        scale = period / (np.mean(x) if relative else 1.0)
        slopes.append(np.polyfit(t, x, 1)[0] * scale)
        sem, _ = _fluctuation_error(t, x)        # of the mean; the slope's from the spread
        errs.append(sem * np.sqrt(12) / (t[-1] - t[0]) * scale)
    if not slopes:
        return math.nan, math.nan
    own = float(np.sqrt(np.sum(np.square(errs)))) / len(slopes)
    between = float(np.std(slopes, ddof=1) / math.sqrt(len(slopes))) if len(slopes) > 1 \
        else 0.0
    return float(np.mean(slopes)), max(own, between)


def _between(parts, q):
    means = [p[q].mean() for p in parts]
    return float(np.std(means, ddof=1) / math.sqrt(len(means))) if len(means) > 1 else math.nan


def meets(row) -> dict:
    v0, tol_v = TARGETS["v0"]
    s, tol_s = TARGETS["s"]
    return {"C_bulk >= 3": row["C_bulk"] >= TARGETS["C_bulk"],
            "rattlers < 15%": row["rattler_fraction"] < TARGETS["rattler_fraction"],
            "steady window": _steady(row),
            "dyn/static <= 0.01": row["dyn_over_static_bulk"] <= TARGETS["dyn_over_static_bulk"],
            "v0 within 10%": _within(row, "v0", v0, tol_v),
            "s within 15%": _within(row, "s", s, tol_s)}


def _within(row, key, target, tol) -> bool:
    """The value within ``tol`` of ``target`` (relative) by 2 combined errors (statistical
    and the band estimator's systematic; granavg.paper.claims' comparison), or, for
    rows scored before the estimator had a systematic error, its central value."""
    sys = row.get(f"{key}_sys")
    if sys is None or not np.isfinite(sys):
        return abs(row[key] / target - 1) <= tol
    return abs(row[key] - target) + 2 * math.hypot(row[f"{key}_err"], sys) < tol * target


#: The physical tolerance of a steady window: the bulk pressure changes by less than this
#: share per inner-ring rotation (issue 28).
P_TREND_TOLERANCE = 0.03


def _steady(row):
    """Whether the window is steady: True when its bulk pressure's trend lies within
    :data:`P_TREND_TOLERANCE` per rotation by 2 errors, C_bulk's and nu_bulk's trends
    within 2 errors of none and the ensemble (>= 3 runs) finds no drift; False when the
    pressure's trend lies beyond the tolerance by 2 errors, C's or nu's beyond 2 errors,
    or the ensemble finds a drift; None (the window too short to tell) otherwise. Rows
    scored before the trends: :func:`_pressure_steady`."""
    p = row.get("P_bulk_Pa_trend_per_rotation_rel")
    if p is None or not np.isfinite(p):
        return _pressure_steady(row)
    err = row["P_bulk_Pa_trend_per_rotation_rel_err"]
    flat = all(abs(row[f"{q}_trend_per_rotation"]) < 2 * row[f"{q}_trend_per_rotation_err"]
               for q in ("C_bulk", "nu_bulk"))
    z = row.get("ensemble_z")
    drifts = isinstance(z, dict) and bool(row.get("ensemble_drifts"))
    if drifts or not flat or abs(p) - 2 * err > P_TREND_TOLERANCE:
        return False
    return True if abs(p) + 2 * err < P_TREND_TOLERANCE else None


def _pressure_steady(row) -> bool:
    """The ensemble's verdict where >= 3 realisations judged it, else no run drifting or
    undetermined."""
    z = row.get("ensemble_z")
    if isinstance(z, dict) and "P_bulk_Pa" in z:
        return "P_bulk_Pa" not in row["ensemble_drifts"]
    return row["pressure_drifts"] == 0


def _ensemble(row) -> str:
    """The ensemble's departures from steady of C_bulk, P_bulk and nu_bulk, in errors
    (marked * where it drifts), or - with fewer than 3 runs."""
    z = row.get("ensemble_z")
    if not isinstance(z, dict) or not z:
        return "-"
    return " / ".join(f"{z[q]:.1f}" + ("*" if q in row["ensemble_drifts"] else "")
                      for q in ("C_bulk", "P_bulk_Pa", "nu_bulk") if q in z)


def markdown(df: pd.DataFrame) -> str:
    head = ["candidate", "runs", "C_bulk (t<20 s -> window)", "rattlers", "P_bulk (Pa)",
            "P not shown steady (runs)", "ensemble: C / P / nu (errors)",
            "trend per rotation: P / C / nu", "ordered share", "dyn/static bulk",
            "v0/(Omega R_i)", "s (mm)", "targets met"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, r in df.iterrows():
        ok = meets(r)
        lines.append(
            f"| {name} | {r.runs} | {r.C_bulk_start:.2f} -> {r.C_bulk:.2f} +- {r.C_bulk_err:.2f} "
            f"| {r.rattler_fraction:.0%} | {r.P_bulk_start_Pa:.3g} -> {r.P_bulk_Pa:.3g} +- "
            f"{r.P_bulk_Pa_err:.2g} | {r.pressure_drifts} | {_ensemble(r)} | {_trends(r)} | "
            f"{r.psi6_bulk_ordered:.2f} | "
            f"{r.dyn_over_static_bulk:.3f} | {r.v0:.3f} +- {r.v0_err:.3f}{_sys(r, 'v0', 1)} | "
            f"{1e3 * r.s:.1f} +- {1e3 * r.s_err:.1f}{_sys(r, 's', 1e3)} | "
            f"{sum(v is True for v in ok.values())}/6: "
            + ", ".join(k + ("" if v is False else " (too short to tell)")
                        for k, v in ok.items() if v is not True).join(["missing: ", ""])
            + " |")
    return "\n".join(lines)


def _trends(row) -> str:
    """P's relative, C's and nu's absolute trend per rotation with errors, or -."""
    p = row.get("P_bulk_Pa_trend_per_rotation_rel")
    if p is None or not np.isfinite(p):
        return "-"
    return (f"{100 * p:+.1f} +- {100 * row['P_bulk_Pa_trend_per_rotation_rel_err']:.1f}% / "
            f"{row['C_bulk_trend_per_rotation']:+.3f} +- {row['C_bulk_trend_per_rotation_err']:.3f}"
            f" / {row['nu_bulk_trend_per_rotation']:+.4f} +- "
            f"{row['nu_bulk_trend_per_rotation_err']:.4f}")


def _sys(row, key, scale) -> str:
    sys = row.get(f"{key}_sys")
    return f" +- {scale * sys:.2g} (sys)" if sys is not None and np.isfinite(sys) else ""


def plot(out: Path, runs_of: dict):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from granavg.analysis.figures import OKABE_ITO

    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6), constrained_layout=True)
    for k, (name, runs) in enumerate(runs_of.items()):
        for j, run in enumerate(runs):
            ts = pd.read_csv(run.parent / f"{run.name}.timeseries.csv")
            for a, q in zip(ax, ("C_bulk", "P_bulk_Pa", "rattler_fraction")):
                if q in ts:
                    a.plot(ts.t_s, ts[q], color=OKABE_ITO[k % 7], lw=0.8,
                           label=name if j == 0 else None)
    for a, (q, lab) in zip(ax, (("C_bulk", "bulk coordination (-)"),
                                ("P_bulk_Pa", "bulk pressure (Pa)"),
                                ("rattler_fraction", "rattler fraction (-)"))):
        a.set(xlabel="t (s)", ylabel=lab)
    ax[1].set_yscale("log")
    ax[0].legend(fontsize=7)
    fig.savefig(out / "timeseries.png", dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--t-end", type=float, default=250.0)
    ap.add_argument("--only", nargs="+", help="candidate names (default: all)")
    ap.add_argument("--baseline", type=Path, help="an existing ensemble of the paper preset "
                    "to use as the first candidate instead of running it")
    ap.add_argument("--score", nargs=2, metavar=("NAME", "ENSEMBLE_DIR"),
                    help="score an existing ensemble's runs as candidate NAME")
    ap.add_argument("--t-min", type=float, help="with --score: window start (s)")
    ap.add_argument("--table", action="store_true",
                    help="print the table of every candidate scored in OUT; run nothing")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    table_path = args.out / "candidates.json"
    done = json.loads(table_path.read_text()) if table_path.exists() else {}
    runs_of = {}
    if args.table:
        print(markdown(pd.DataFrame.from_dict(done, orient="index")))
        return
    if args.score:
        name, where = args.score[0], Path(args.score[1])
        runs_of[name] = sorted(p for p in where.iterdir() if (p / "manifest.json").exists())
        done[name] = score(runs_of[name], args.t_min)
        table_path.write_text(json.dumps(done, indent=2, default=float) + "\n")
    for name, overrides in ({} if args.score else CANDIDATES).items():
        if args.only and name not in args.only:
            continue
        where = args.baseline if (args.baseline and not overrides) else args.out / slug(name)
        if not where.exists():
            log.info("running %s (%s)", name, " ".join(overrides) or "paper preset")
            run_candidate(where, overrides, args.seeds, args.t_end)
        runs_of[name] = sorted(p for p in where.iterdir() if (p / "manifest.json").exists())
        if name not in done:
            done[name] = score(runs_of[name])
            table_path.write_text(json.dumps(done, indent=2, default=float) + "\n")
    df = pd.DataFrame.from_dict(done, orient="index")
    df.drop(columns=["claims"]).to_csv(args.out / "candidates.csv", float_format="%.5g")
    print(markdown(df.loc[[n for n in runs_of if n in df.index]]))
    plot(args.out, runs_of)


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="steady: %(message)s")
    main()
