"""The speed/accuracy trade of the paper scene, measured with ensembles against the stiff
limit (issues 14 and 40).

    python workflows/sweep.py OUT [--seeds 4] [--workers 2 | --scheduler ADDR]
    python workflows/sweep.py OUT --table       # re-judge OUT/sweep.csv, print the table
    python workflows/sweep.py OUT --table --ship   # and write granavg/sim/trade.json

Every setting is an ensemble: one short run of the `paper` preset (rolling resistance, the
base plate's regularised Coulomb law, its coefficient renewed every 10 steps) from each of
its shipped sheared packings (seeds 20011, 27930, ...: the same starting states for every
setting), so
that the slow ageing of the packing (docs/steady-state.md) is the same for all settings
and a difference is called a bias only when it exceeds the combined ensemble error. A run
shears WINDOW (20 s of the 62.8 s rotation, dumps every 0.5 s) and is averaged from the
preset's discard time (0.1 rotation) on, over 20 and 60 rings; the realisations are
combined with between-run errors (granavg.engine.combine.combine_runs) and analysed.
A difference from the limit is called a bias only when it exceeds twice the combined
error; each setting also gets the resolution of its comparisons (the smallest bias they
could show), since "no bias above 5%" means no more than the resolution allows.

Simulation settings (SIMULATED: k_n at the same restitution, steps per contact time
n = t_c/dt, Omega at the same strain) are dask tasks, one per realisation (a local cluster
of single-threaded workers, or a scheduler's). Averaging settings (AVERAGED: dump interval,
window length, ring count, number of realisations, error sectors) reuse the `base`
runs' dumps. The plate's knobs (base_every, v_base) are numerics; rolling resistance
(mu_roll, and the law without it) is the material: measured, never forecast from.

The reference is the stiff, fine-step limit of each headline number: a weighted fit of
X(k_n) = X_inf + b k_n^-1/2 through k_n = 10, 100, 1000 N/m (the contact time, and with it
the quasi-static parameter, scales as k_n^-1/2), plus the step-size correction from a fit
X(n) = X_0 + c/n through n = t_c/dt = 25, 50, 100 at k_n = 10 N/m (first order in dt:
the damping and the Coulomb cap make the integrator so). Both are propagated into the
limit's error; a fit whose chi^2 exceeds its degrees of freedom has its errors scaled by
sqrt(chi^2/dof). Writes OUT/sweep.csv, OUT/limit.csv, OUT/pareto.png/.pdf;
settings already in OUT/sweep.csv are kept (a sweep can be extended or resumed).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import resource
import time
from pathlib import Path

import numpy as np
import pandas as pd

#: the scene measured: `paper` (rolling resistance, the plate near its Coulomb limit, its
#: coefficient renewed every 10 steps); `paper-rolling` (no plate) was measured 2026-11-23
PRESET = "paper"
WINDOW = ["t_end=20", "dump_dt=0.5", "restart_dt=20"]
SIMULATED = {          # name: --set overrides of the preset (after WINDOW)
    "base": [],                                   # k_n = 10 N/m, n = 50, Omega = 0.1 rad/s
    "k_n=1000": ["k_n=1000"],
    "k_n=100": ["k_n=100"],
    "n_per_tc=100": ["n_per_tc=100"],
    "n_per_tc=25": ["n_per_tc=25"],
    "k_n=2.5": ["k_n=2.5"],
    "Omega=0.05": ["Omega=0.05", "t_end=40", "dump_dt=1", "restart_dt=40"],  # same strain
    "Omega=0.2": ["Omega=0.2", "t_end=10", "dump_dt=0.25", "restart_dt=10"],
    "k_n=2.5, n=25": ["k_n=2.5", "n_per_tc=25"],
    # the plate: its law in full each step, its coefficient renewed every 1 or 50 steps
    # (the preset: 10), and its regularisation speed (the preset: 0.1 mm/s)
    "base_every=0": ["base_every=0"],
    "base_every=1": ["base_every=1"],
    "base_every=50": ["base_every=50"],
    "base_every=200": ["base_every=200"],          # 4 and 20 contact times: where the
    "base_every=1000": ["base_every=1000"],        # renewal breaks (docs/stability.md)
    "v_base=0.03 mm/s": ["v_base=3e-5"],
    "v_base=0.3 mm/s": ["v_base=3e-4"],
    # rolling resistance (the preset: 0.3): a material constant, measured, not forecast from
    "mu_roll=0.1": ["mu_roll=0.1"],
    "mu_roll=0.5": ["mu_roll=0.5"],
    "law: no rolling resistance": ["mu_roll=0"],  # pair gran/hooke/history, same packings
}
#: settings that change the scene's material, not its numerics: measured, not forecast from
OTHER_SCENE = ("mu_roll=0.1", "mu_roll=0.5", "law: no rolling resistance")
#: numerical knobs that a forecast matches besides (k_n, n_per_tc, Omega)
NUMERICS = ("v_base", "base_every")
AVERAGED = {           # name: (t_end s or None, every k-th frame, ring counts, realisations,
    #                    sectors per ring for the errors)
    "dump_dt=2": (None, 4, (20, 60), None, "auto"),
    "t_end=13": (13.0, 1, (20, 60), None, "auto"),
    "rings=10/30": (None, 1, (10, 30), None, "auto"),
    "rings=40/120": (None, 1, (40, 120), None, "auto"),
    "seeds=2": (None, 1, (20, 60), 2, "auto"),
    "errors: time only": (None, 1, (20, 60), None, None),
}
STIFF = ("base", "k_n=100", "k_n=1000")           # the k_n ladder at n = 50
FINE = ("n_per_tc=25", "base", "n_per_tc=100")   # 2 dt, dt, dt/2 at k_n = 10 N/m
HEADLINES = ["v0", "s", "nu_bulk", "trF_bulk", "p_over_kn_bulk", "stiffness_slope",
             "eom_residual"]
#: the paper's regime must be kept too (granavg.paper.claims.QUASI_STATIC_LIMIT)
QUASI_STATIC_LIMIT = 0.1
COST_COLUMNS = ["sim_cpu_s", "sim_wall_s", "lammps_s", "frames_s", "avg_cpu_s", "avg_wall_s"]
log = logging.getLogger("sweep")


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def simulate_one(scene_dict: dict, out: str) -> dict:
    """One dask task: one realisation of a setting; its cost from its own records."""
    import granavg.sim.scene as scene_mod
    from granavg.sim.scene import Scene
    from granavg.sim.simulate import simulate

    scene_mod.MAX_RENEWAL_CONTACTS = math.inf     # the study measures beyond that bound
    c0, t0 = cpu_seconds(), time.perf_counter()
    simulate(Scene.from_dict(scene_dict), out, progress=False, preset=PRESET)
    timing = json.loads((Path(out) / "manifest.json").read_text())["timing"]
    return {"sim_cpu_s": cpu_seconds() - c0, "sim_wall_s": time.perf_counter() - t0,
            "lammps_s": timing["lammps_steps_s"], "frames_s": timing["frames_s"]}


def average_ensemble(run_dirs: list, out: str, t_end=None, every=1, bins=(20, 60),
                     sectors="auto") -> dict:
    """One dask task: average the realisations over both ring counts (the frames up to
    ``t_end``, every ``every``-th), combine them, analyse; returns the averaging cost."""
    from granavg.pipeline.reporting import report_profiles
    from granavg.engine.combine import combine_runs
    from granavg.io.profiles_io import write_profiles
    from granavg.io.run_directory import read_manifest
    from granavg.pipeline.runs import run_averager

    c0, t0 = cpu_seconds(), time.perf_counter()
    profiles = []
    for n in bins:
        per_run = []
        for run in run_dirs:
            m = read_manifest(run)["derived"]
            last = int(round(t_end / m["dt_s"])) if t_end else m["n_shear_steps"]
            per_run.append(run_averager(run, bins=n, steps=(m["first_dump_step"], last, every),
                                        sectors=sectors).run(False))
        profiles.append(combine_runs(per_run, [str(r) for r in run_dirs]))
    report = Path(out) / "report"
    for n, p in zip(bins, profiles):
        write_profiles(p, report / f"profiles{n}.csv")
    report_profiles(*profiles, report)
    return {"avg_cpu_s": cpu_seconds() - c0, "avg_wall_s": time.perf_counter() - t0}


def metrics(report_dir: Path) -> dict:
    """Headline numbers and their (ensemble) standard errors from a report directory."""
    from granavg.io.profiles_io import read_profiles

    s = json.loads((report_dir / "summary.json").read_text())
    n = s["numbers"]
    coarse = min((f for f in report_dir.glob("profiles*.csv") if f.stem[8:].isdigit()),
                 key=lambda f: int(f.stem[8:]))
    p = read_profiles(coarse)
    kn = s["run"]["scene"]["k_n"]
    w = bulk_weights(p.cells.edges)

    def mean_sem(v, e):
        return float(np.sum(w * v)), float(np.sqrt(np.sum((w * e) ** 2)))

    nu, nu_e = mean_sem(p.values["nu"], p.sem["nu"])
    trf, trf_e = mean_sem(p.values["F_rr"] + p.values["F_phiphi"],
                          np.hypot(p.sem["F_rr"], p.sem["F_phiphi"]))
    pr, pr_e = mean_sem(-(p.values["sigma_rr"] + p.values["sigma_phiphi"]) / (2 * kn),
                        np.hypot(p.sem["sigma_rr"], p.sem["sigma_phiphi"]) / (2 * kn))
    sb = n["shear_band"]
    return {"v0": sb["v0_over_omega_Ri"], "v0_err": sb["v0_over_omega_Ri_err"],
            "s": sb["s_m"], "s_err": sb["s_m_err"], "nu_bulk": nu, "nu_bulk_err": nu_e,
            "trF_bulk": trf, "trF_bulk_err": trf_e, "p_over_kn_bulk": pr,
            "p_over_kn_bulk_err": pr_e, "stiffness_slope": n["stiffness"]["bulk_slope_per_m"],
            "stiffness_slope_err": n["stiffness"]["bulk_slope_per_m_err"],
            "eom_residual": n["equations_of_motion"]["bulk_median_residual"],
            "eom_residual_err": n["equations_of_motion"]["bulk_median_residual_err"],
            "dynamic_over_static": n["quasi_static"]["dynamic_over_static_max"]}


def bulk_weights(edges) -> np.ndarray:
    """Weights of the rings in a mean over the middle half of the annulus in r (each ring
    by the length of its overlap with it), so that ring sets of any count average the
    same stretch; shape (n_rings,), summing to 1."""
    e = np.asarray(edges)
    lo, hi = e[0] + (e[-1] - e[0]) / 4, e[-1] - (e[-1] - e[0]) / 4
    overlap = np.clip(np.minimum(e[1:], hi) - np.maximum(e[:-1], lo), 0.0, None)
    return overlap / overlap.sum()


def extrapolate(x, y, err) -> tuple:
    """Weighted straight-line fit y = a + b x.

    Returns (a, a's standard error, b, b's standard error, chi^2/dof). With more points
    than parameters, errors are scaled by sqrt(chi^2/dof) when that exceeds 1 (the
    scatter says the quoted errors are too small); with two points the line goes
    through them and the errors are propagated exactly."""
    x, y, err = (np.asarray(v, float) for v in (x, y, err))
    A = np.stack([np.ones_like(x), x], axis=1) / err[:, None]
    cov = np.linalg.inv(A.T @ A)
    coef = cov @ A.T @ (y / err)
    dof = len(x) - 2
    chi2 = float(np.sum(((y - coef[0] - coef[1] * x) / err) ** 2))
    red = chi2 / dof if dof > 0 else float("nan")
    scale = math.sqrt(red) if dof > 0 and red > 1 else 1.0
    return (float(coef[0]), float(math.sqrt(cov[0, 0]) * scale), float(coef[1]),
            float(math.sqrt(cov[1, 1]) * scale), red)


def stiff_limit(rows: dict) -> pd.DataFrame:
    """Each headline number in the stiff (k_n -> inf), fine-step (dt -> 0) limit.

    The k_n ladder (STIFF, n = 50) is fitted in k_n^-1/2 to its intercept; the step
    ladder (FINE, k_n = 10 N/m) in 1/n, whose slope gives the correction from n = 50 to
    dt -> 0, -b_n / 50 (the same at any k_n: dt/t_c is what matters). The two errors are
    added in quadrature (the base runs are in both fits; that correlation is ignored).
    Returns a frame indexed by headline with columns ``value``, ``err`` (standard
    error), ``k_limit``, ``k_limit_err``, ``chi2_dof`` of the k_n fit, ``dt_correction``,
    ``dt_correction_err``, ``dt_chi2_dof`` and ``err_scale``: sqrt of the two fits' pooled
    chi^2/dof when above 1, the factor by which the ensembles' quoted errors of that
    number are too small (applied to every setting's error in :func:`compare`)."""
    from granavg.sim.scene import preset

    def setting(names, key):
        return [preset(PRESET).with_overrides(SIMULATED[s]).to_dict()[key] for s in names]

    x_k = [v ** -0.5 for v in setting(STIFF, "k_n")]
    n_base = preset(PRESET).n_per_tc
    x_n = [1.0 / v for v in setting(FINE, "n_per_tc")]
    out = {}
    for k in HEADLINES:
        def fit(names, x):
            return extrapolate(x, [rows[s][k] for s in names], [rows[s][f"{k}_err"] for s in names])
        a, a_err, _, _, red = fit(STIFF, x_k)
        _, _, b, b_err, red_n = fit(FINE, x_n)
        corr, corr_err = -b / n_base, b_err / n_base
        out[k] = {"value": a + corr, "err": math.hypot(a_err, corr_err), "k_limit": a,
                  "k_limit_err": a_err, "chi2_dof": red, "dt_correction": corr,
                  "dt_correction_err": corr_err, "dt_chi2_dof": red_n,
                  "err_scale": math.sqrt(max(1.0, (red + red_n) / 2))}
    return pd.DataFrame(out).T


def compare(row: dict, limit: pd.DataFrame) -> dict:
    """Each headline number's relative error against the limit, its uncertainty, and
    the verdicts. A difference is a bias only when it exceeds twice the combined error
    of the setting's ensemble and the limit; a setting is ``within_10`` (``within_5``)
    when no number shows a bias larger than 10% (5%). ``resolution`` is the largest
    2-sigma relative error of the comparisons: a bias below it cannot be seen, so a pass
    means "no bias above max(class, resolution)". The residual of the equations of motion
    is compared by level (a bias only when it is more than 0.05 above the limit's)."""
    out = {}
    ok10 = ok5 = True
    resolution = 0.0
    for k in HEADLINES:
        ref, ref_err = limit.loc[k, "value"], limit.loc[k, "err"]
        diff = row[k] - ref
        scale = limit.loc[k, "err_scale"] if "err_scale" in limit else 1.0
        noise = math.hypot(scale * row[f"{k}_err"], ref_err)
        out[f"{k}_relerr"] = diff / abs(ref)
        out[f"{k}_relerr_err"] = noise / abs(ref)
        biased = abs(diff) > 2 * noise
        if k == "eom_residual":
            bound10 = bound5 = not (biased and diff > 0.05)
        else:
            bound10 = not (biased and abs(diff) > 0.10 * abs(ref))
            bound5 = not (biased and abs(diff) > 0.05 * abs(ref))
            resolution = max(resolution, 2 * noise / abs(ref))
        out[f"{k}_within_10"], out[f"{k}_within_5"] = bound10, bound5
        ok10 &= bound10
        ok5 &= bound5
    out["resolution"] = resolution
    out["quasi_static"] = row["dynamic_over_static"] < QUASI_STATIC_LIMIT
    # a number the setting (or the limit) could not measure, e.g. a band too coarse to
    # fit, vouches for nothing
    out["unjudged"] = ", ".join(k for k in HEADLINES if not all(math.isfinite(v) for v in (
        row[k], row[f"{k}_err"], limit.loc[k, "value"], limit.loc[k, "err"])))
    if out["unjudged"]:
        out["resolution"] = float("nan")
    out["within_10"] = ok10 and out["quasi_static"] and not out["unjudged"]
    out["within_5"] = ok5 and out["quasi_static"] and not out["unjudged"]
    out["max_relerr"] = max((abs(out[f"{k}_relerr"]) for k in HEADLINES if k != "eom_residual"
                             and math.isfinite(out[f"{k}_relerr"])), default=float("nan"))
    return out


def pooled(rows: dict, limit: pd.DataFrame) -> dict:
    """The numerical settings at each k_n pooled, judged as one setting (:func:`compare`).

    Each setting's ensemble resolves the band's numbers (v0, s) only to 30-40%, and whether
    one crosses 2 combined errors is then a matter of its noise; but a bias that comes from
    the springs' softness is shared by every setting at that k_n. The pool is the mean of
    the settings at one k_n (two or more) with the mean of their errors (not reduced by
    the square root of their number: they start from the same packings). Only settings
    granavg runs are pooled (not those it refuses, measured beyond a bound), and only
    those that measured every headline number. Returns {k_n: (name, the pooled row with
    its verdicts, the settings pooled)}."""
    from granavg.errors import UserError
    from granavg.sim.scene import preset

    by_k = {}
    for name in SIMULATED:
        if name in OTHER_SCENE or name not in rows or \
                not all(math.isfinite(rows[name][h]) for h in HEADLINES):
            continue
        scene = preset(PRESET).with_overrides(WINDOW + SIMULATED[name])
        try:
            scene.derive()
        except UserError:
            continue
        by_k.setdefault(scene.law.k_n, []).append(name)
    out = {}
    for k, names in by_k.items():
        if len(names) < 2:
            continue
        row = {c: float(np.mean([rows[n][c] for n in names]))
               for c in [*COST_COLUMNS, *HEADLINES, *(f"{h}_err" for h in HEADLINES)]}
        row["dynamic_over_static"] = max(rows[n]["dynamic_over_static"] for n in names)
        out[k] = (f"k_n={k:g}: {len(names)} settings pooled", {**row, **compare(row, limit)},
                  names)
    return out


def pool_note(name: str, row: dict) -> str:
    """One sentence on a pool's verdict: its largest flagged bias or, with none, its
    largest difference (the number, its error, and how many combined errors)."""
    heads = [h for h in HEADLINES if h != "eom_residual"]
    flagged = [h for h in heads if not row[f"{h}_within_10"]]

    def z(h):
        return abs(row[f"{h}_relerr"]) / row[f"{h}_relerr_err"]
    k = max(flagged or heads, key=lambda h: abs(row[f"{h}_relerr"]))
    return (f"{name}: {k} {100 * row[f'{k}_relerr']:+.0f} +- "
            f"{100 * row[f'{k}_relerr_err']:.0f}% of the stiff limit ({z(k):.2f} combined "
            "errors)")


def pareto_plot(table: pd.DataFrame, path: Path, ax=None):
    """Cost (CPU s of one realisation, simulation + averaging) against the largest
    relative error of the headline numbers (against the stiff limit), with 1-sigma bars."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.2))
    cost = table["sim_cpu_s"] + table["avg_cpu_s"]
    err = table["max_relerr"].clip(lower=1e-3)
    worst = [max((k for k in HEADLINES if k != "eom_residual"),
                 key=lambda k: abs(r[f"{k}_relerr"])) for _, r in table.iterrows()]
    bars = [r[f"{k}_relerr_err"] for (_, r), k in zip(table.iterrows(), worst)]
    colors = np.where(table["within_5"], "#009E73",
                      np.where(table["within_10"], "#E69F00", "#D55E00"))
    ax.errorbar(cost, err, yerr=bars, fmt="none", ecolor="0.6", lw=0.8, zorder=2)
    ax.scatter(cost, err, c=list(colors), zorder=3)
    for name, x, y in zip(table.index, cost, err):
        ax.annotate(name, (x, y), fontsize=7, xytext=(4, 2), textcoords="offset points")
    ax.axhline(0.10, color="0.6", ls="--", lw=1)
    ax.axhline(0.05, color="0.8", ls="--", lw=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost of one realisation: CPU time of simulation + averaging (s)")
    ax.set_ylabel("largest |relative error| vs the stiff limit (-)")
    ax.set_title("paper scene, ensembles of short runs: cost against error\n(green: no bias "
                 "above 5%, orange: none above 10%; red: a bias above 10%)", fontsize=9)
    ax.figure.tight_layout()
    ax.figure.savefig(path.with_suffix(".png"), dpi=150)
    ax.figure.savefig(path.with_suffix(".pdf"))
    return ax


def run_missing(out: Path, have: set, args) -> dict:
    """Run on dask every setting not yet in OUT/sweep.csv; returns their costs (per
    realisation: the mean over its runs; averaging: the ensemble's over its runs)."""
    from dask.distributed import Client, as_completed

    from granavg.dask_cluster import local_cluster
    from granavg.sim.realisations import seeds_for
    from granavg.sim.scene import preset

    seeds = seeds_for(preset(PRESET), args.seeds)
    base_runs = [str(out / "base" / f"seed{s}") for s in seeds]
    done, runs_of = {}, {}
    cluster = None if args.scheduler else local_cluster(args.workers)
    with Client(args.scheduler or cluster) as client:
        futures = {}
        for rank, name in enumerate(n for n in SIMULATED if n not in have):
            scene = preset(PRESET).with_overrides(WINDOW + SIMULATED[name])
            runs_of[name] = []
            for s in seeds:
                d = out / _slug(name) / f"seed{s}"
                runs_of[name].append(str(d))
                if (d / "manifest.json").exists() and \
                        json.loads((d / "manifest.json").read_text())["status"] == "complete":
                    futures[client.submit(_recorded_cost, str(d), pure=False)] = (name, s)
                    continue
                scene_s = scene.with_overrides([f"seed={s}"])
                futures[client.submit(simulate_one, scene_s.to_dict(), str(d), pure=False,
                                      priority=-rank)] = (name, s)
        pending = as_completed(list(futures))
        costs = {}
        for fut in pending:
            tag = futures[fut]
            if isinstance(tag, str):                       # an averaging task
                done[tag] = {**done.get(tag, {}), **fut.result()}
                log.info("%s: %s", tag, done[tag])
                continue
            name, s = tag
            costs.setdefault(name, []).append(fut.result())
            log.info("%s seed %d simulated: %s", name, s, costs[name][-1])
            if len(costs[name]) < len(seeds):
                continue
            done[name] = pd.DataFrame(costs[name]).mean().to_dict()
            jobs = {name: (runs_of[name], ())}
            if name == "base":
                for a, (t_end, every, _, k, _) in AVERAGED.items():
                    if a not in have:
                        jobs[a] = (base_runs[:k] if k else base_runs, (t_end, every))
            for job, (dirs, extra) in jobs.items():
                bins, sectors = (AVERAGED[job][2], AVERAGED[job][4]) if job in AVERAGED \
                    else ((20, 60), "auto")
                f = client.submit(average_ensemble, dirs, str(out / _slug(job)), *extra,
                                  bins=bins, sectors=sectors, pure=False, priority=10)
                futures[f] = job
                pending.add(f)
    if cluster is not None:
        cluster.close()
    for a, (t_end, every, _, k, _) in AVERAGED.items():   # simulation they would need
        if a in done:
            share = (t_end or 20.0) / 20.0
            done[a].update({c: share * done["base"][c] for c in COST_COLUMNS[:4]})
            done[a]["avg_cpu_s"] /= (k or args.seeds)
            done[a]["avg_wall_s"] /= (k or args.seeds)
    for name in SIMULATED:
        if name in done:
            done[name]["avg_cpu_s"] /= args.seeds
            done[name]["avg_wall_s"] /= args.seeds
    return done


def _recorded_cost(run: str) -> dict:
    """Cost of a realisation simulated before (its manifest's timing and wall clock)."""
    from datetime import datetime

    m = json.loads((Path(run) / "manifest.json").read_text())
    wall = (datetime.fromisoformat(m["finished"]) -
            datetime.fromisoformat(m["started"])).total_seconds()
    return {"sim_cpu_s": wall, "sim_wall_s": wall, "lammps_s": m["timing"]["lammps_steps_s"],
            "frames_s": m["timing"]["frames_s"]}


def markdown(table: pd.DataFrame, limit: pd.DataFrame) -> str:
    """The sweep as markdown: the stiff limit, then each setting's cost and each headline
    number's relative error against the limit (+- its 1-sigma uncertainty)."""
    lines = ["| headline | stiff limit | +- | k_n -> inf (n = 50) | chi^2/dof | dt correction "
             "| chi^2/dof | error scale |", "|---|---|---|---|---|---|---|---|"]
    for k, r in limit.iterrows():
        lines.append(f"| {k} | {r.value:.4g} | {r.err:.2g} | {r.k_limit:.4g} +- "
                     f"{r.k_limit_err:.2g} | {r.chi2_dof:.2f} | {r.dt_correction:+.2g} +- "
                     f"{r.dt_correction_err:.2g} | {r.dt_chi2_dof:.2f} | {r.err_scale:.2f} |")
    head = ["setting", "CPU s / realisation (sim + avg)", "wall s (sim + avg)", *HEADLINES,
            "dyn/static",
            "resolved to (2 sigma)", "within 10%", "within 5%"]
    lines += ["", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, r in table.iterrows():
        cells = [name, f"{r.sim_cpu_s:.0f} + {r.avg_cpu_s:.0f}",
                 f"{r.sim_wall_s:.0f} + {r.avg_wall_s:.0f}"]
        for k in HEADLINES:
            cells.append(f"{100 * r[f'{k}_relerr']:+.1f} +- {100 * r[f'{k}_relerr_err']:.1f}%")
        cells.append(f"{r.dynamic_over_static:.3f}")
        cells.append(f"{100 * r.resolution:.0f}%")
        cells += ["yes" if str(r[c]) == "True" else f"not judged ({r.unjudged} not measured)"
                  if isinstance(r.get("unjudged"), str) and r.unjudged else "no"
                  for c in ("within_10", "within_5")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ship(out: Path, table: pd.DataFrame, pools: dict, path: Path) -> dict:
    """Write what granavg forecasts from (granavg/sim/trade.json): seconds per disk-step of
    LAMMPS for each contact law (`pair granular` with rolling resistance, the plain
    `gran/hooke/history`) and plate mode measured (the law in full each step, "0", or its
    coefficient renewed every N steps, "N"), per disk-frame (from the runs' own timing
    records), and the accuracy class of each simulated setting of the scene."""
    from datetime import date

    from granavg.sim.scene import preset
    from granavg.sim.trade import plate_mode

    def per_disk(names):
        rates, frames = [], []
        for name in names:
            for f in (out / _slug(name)).glob("seed*/manifest.json"):
                m = json.loads(f.read_text())
                n = m["scene"]["n_small"] + m["scene"]["n_large"]
                rates.append(m["timing"]["lammps_steps_s"] / m["derived"]["n_shear_steps"] / n)
                frames.append(m["timing"]["frames_s"] / m["timing"]["frames"] / n)
        return np.asarray(rates), np.asarray(frames)

    def scene_of(name):
        return preset(PRESET).with_overrides(WINDOW + SIMULATED[name]).to_dict()

    numerics = [n for n in SIMULATED if n not in OTHER_SCENE]
    steps, spread, frame_rates = {"rolling": {}, "plain": {}}, [], []
    for name in SIMULATED:
        sc = scene_of(name)
        if name in OTHER_SCENE and sc["mu_roll"] > 0:
            continue                                  # another material, same law's cost
        law = "rolling" if sc["mu_roll"] > 0 else "plain"
        steps[law].setdefault(plate_mode(sc["mu_base"], sc["base_every"]), []).append(name)
    for law, by_mode in steps.items():
        for mode, names in by_mode.items():
            rates, frames = per_disk(names)
            by_mode[mode] = float(np.median(rates))
            spread += list(rates / by_mode[mode] - 1)
            frame_rates += list(frames)
    def verdict(r):
        return "5%" if str(r["within_5"]) == "True" else "10%" \
            if str(r["within_10"]) == "True" else "worse"

    rank = {"5%": 0, "10%": 1, "worse": 2}
    settings = []
    for name in numerics:
        sc, r = scene_of(name), table.loc[name]
        if isinstance(r.get("unjudged"), str) and r.unjudged:
            continue                          # measured no class: not forecast from
        cls, extra = verdict(r), {}
        pool = pools.get(sc["k_n"])
        if pool is not None and name in pool[2]:       # the class of its k_n, if worse
            pool_cls = verdict(pool[1])
            extra["pooled"] = f"{pool_note(pool[0], pool[1])}: {pool_cls}"
            cls = max(cls, pool_cls, key=rank.get)
        settings.append({"name": name, **{k: sc[k] for k in ("k_n", "n_per_tc", "Omega",
                                                            *NUMERICS)},
                         "class": cls, "max_relerr": float(r.max_relerr),
                         "resolution": float(r.resolution), **extra})
    study = {"measured": f"workflows/sweep.py, {date.today().isoformat()} (docs/sweep/)",
             "machine": "2 cores, one single-threaded LAMMPS per core", "preset": PRESET,
             "seconds_per_disk_step": steps,
             "seconds_per_disk_frame": float(np.median(frame_rates)),
             "time_spread": float(np.max(np.abs(spread))),
             "scene": preset(PRESET).to_dict(), "settings": settings}
    path.write_text(json.dumps(study, indent=1) + "\n")
    return study


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "=._" else "_" for c in name)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--seeds", type=int, default=4, help="realisations per setting")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", help="dask scheduler address")
    ap.add_argument("--table", action="store_true", help="only re-judge and print the table")
    ap.add_argument("--ship", action="store_true", help="also write granavg/sim/trade.json, "
                    "what 'granavg simulate' forecasts from")
    args = ap.parse_args(argv)
    out = Path(args.out)
    csv = out / "sweep.csv"
    measured = pd.read_csv(csv, index_col="setting") if csv.exists() else pd.DataFrame()
    costs = {name: r[COST_COLUMNS].to_dict() for name, r in measured.iterrows()}
    if not args.table:
        out.mkdir(parents=True, exist_ok=True)
        costs.update(run_missing(out, set(costs), args))
    rows = {name: {**cost, **metrics(out / _slug(name) / "report")}
            for name, cost in costs.items()}
    limit = stiff_limit(rows)
    limit.index.name = "headline"
    limit.to_csv(out / "limit.csv")
    table = pd.DataFrame({n: {**r, **compare(r, limit)} for n, r in rows.items()}).T
    table.index.name = "setting"
    table.to_csv(csv)
    pools = pooled(rows, limit)
    pd.DataFrame({name: row for name, row, _ in pools.values()}).T.rename_axis(
        "pool").to_csv(out / "pooled.csv")
    pareto_plot(table, out / "pareto")
    print(markdown(table, limit))
    print("\n" + markdown(pd.DataFrame({name: row for name, row, _ in pools.values()}).T,
                          limit).split("\n\n", 1)[1])
    if args.ship:
        ship(out, table, pools,
             Path(__file__).resolve().parents[1] / "granavg" / "sim" / "trade.json")


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="sweep: %(message)s")
    main()
