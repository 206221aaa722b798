"""The speed/accuracy trade of the paper scene, measured (issue 6).

    python workflows/sweep.py OUT [--reference RUN] [--workers 2 | --scheduler ADDR]
    python workflows/sweep.py OUT --table      # the markdown table of OUT/sweep.csv

Each setting is the `paper-hooke` preset (the plain-law scene, `paper` when this
sweep was measured) with some knobs changed. Simulation settings (k_n with
the same restitution, steps per contact n = t_c/dt, Omega with the total strain held)
run as independent dask tasks (a local cluster of single-threaded processes by default,
or the workers of a scheduler); averaging settings (run length, dump interval, ring
count) reuse the reference run's dumps. Every run is averaged over 20 and 60 rings (other
ring counts for the ring-count settings) and analysed; the headline numbers are compared
with the reference's, each with its statistical error. Writes OUT/sweep.csv and
OUT/pareto.png/.pdf and prints the markdown table. Settings already in OUT/sweep.csv are
kept, so a sweep can be extended (add a setting, run again) or resumed.

The reference is that preset's own run (--reference RUN reuses one, e.g. the run of
workflows/reproduce_paper.sh); it is the stiffest, finest, longest run afforded here.
"""

from __future__ import annotations

import argparse
import logging
import json
import math
import resource
import time
from pathlib import Path

import numpy as np
import pandas as pd

SIMULATED = {          # name: --set overrides of the paper-hooke preset
    "k_n=2.5": ["k_n=2.5"],
    "n_per_tc=25": ["n_per_tc=25"],
    "Omega=0.2": ["Omega=0.2", "t_end=250", "restart_dt=12.5", "dump_dt=0.25"],
    "k_n=2.5, n=25, Omega=0.2": ["k_n=2.5", "n_per_tc=25", "Omega=0.2", "t_end=250",
                                 "restart_dt=12.5", "dump_dt=0.25"],
}
AVERAGED = {           # name: (t_end s, keep every k-th frame, ring counts) on the reference's dumps
    "t_end=250": (250.0, 1, (20, 60)),
    "t_end=375": (375.0, 1, (20, 60)),
    "dump_dt=2": (None, 4, (20, 60)),
    "rings=10/30": (None, 1, (10, 30)),
    "rings=40/120": (None, 1, (40, 120)),
}
COST_COLUMNS = ["sim_cpu_s", "sim_wall_s", "avg_cpu_s", "avg_wall_s"]
#: headline numbers: (label, key in metrics, relative tolerance applies)
HEADLINES = ["v0", "s", "nu_bulk", "trF_bulk", "p_over_kn_bulk", "stiffness_slope",
             "eom_residual"]


#: the paper's regime must be kept too (granavg.analysis.claims.QUASI_STATIC_LIMIT)
QUASI_STATIC_LIMIT = 0.1
log = logging.getLogger("sweep")


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def simulate_and_report(out: str, overrides: list) -> dict:
    """One dask task: simulate the paper-hooke preset with overrides, average, analyse."""
    from granavg.analysis.pipeline import report_run
    from granavg.sim.scene import preset
    from granavg.sim.simulate import simulate

    out = Path(out)
    c0, t0 = cpu_seconds(), time.perf_counter()
    simulate(preset("paper-hooke").with_overrides(overrides), out / "run", progress=False,
             preset="paper-hooke")
    c1, t1 = cpu_seconds(), time.perf_counter()
    report_run(out / "run", out / "report", progress=False)
    return {"sim_cpu_s": c1 - c0, "sim_wall_s": t1 - t0,
            "avg_cpu_s": cpu_seconds() - c1, "avg_wall_s": time.perf_counter() - t1}


def average_and_report(ref_run: str, out: str, t_end, every, bins=(20, 60)) -> dict:
    """Averaging settings on the reference run's dumps (no new simulation): the first
    t_end seconds (all with None), every k-th frame, averaged over (coarse, fine) rings."""
    from granavg.io.runs import run_averager
    from granavg.analysis.pipeline import report_profiles
    from granavg.io.profiles_io import write_profiles
    from granavg.io.rundir import read_manifest

    m = read_manifest(ref_run)["derived"]
    last = int(round(t_end / m["dt_s"])) if t_end else m["n_shear_steps"]
    c0, t0 = cpu_seconds(), time.perf_counter()
    profiles = [run_averager(ref_run, bins=n, steps=(m["first_dump_step"], last, every))
                .run(False) for n in bins]
    report = Path(out) / "report"
    for n, p in zip(bins, profiles):     # what a run of this length would record
        p.meta["run_manifest"]["derived"]["t_end_s"] = last * m["dt_s"]
        write_profiles(p, report / f"profiles{n}.csv")
    report_profiles(*profiles, report)
    return {"sim_cpu_s": 0.0, "sim_wall_s": 0.0, "avg_cpu_s": cpu_seconds() - c0,
            "avg_wall_s": time.perf_counter() - t0}


def attribute_simulation_cost(rows: dict) -> None:
    """Averaging settings reuse the reference's dumps; charge them the part of its
    simulation they would need (t_end / 500 s of it; all of it for a dump interval)."""
    ref = rows["reference"]
    for name, (t_end, _, _) in AVERAGED.items():
        if name in rows and not rows[name]["sim_cpu_s"]:
            frac = (t_end or 500.0) / 500.0
            rows[name]["sim_cpu_s"] = frac * ref["sim_cpu_s"]
            rows[name]["sim_wall_s"] = frac * ref["sim_wall_s"]


def metrics(report_dir: Path) -> dict:
    """Headline numbers and their statistical errors from a report directory."""
    from granavg.io.profiles_io import read_profiles

    s = json.loads((report_dir / "summary.json").read_text())
    n = s["numbers"]
    coarse = min(report_dir.glob("profiles*.csv"), key=lambda f: int(f.stem[8:]))
    p = read_profiles(coarse)
    kn = s["run"]["scene"]["k_n"]
    w = bulk_weights(p.rings.edges)

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


def compare(row: dict, ref: dict) -> dict:
    """Relative error against the reference, its noise level, and the verdict."""
    out, ok = {}, True
    for k in HEADLINES:
        diff = abs(row[k] - ref[k])
        noise = 2 * math.hypot(row[f"{k}_err"], ref[f"{k}_err"])
        rel = diff / abs(ref[k])
        out[f"{k}_relerr"] = rel
        out[f"{k}_within_noise"] = diff <= noise
        if k == "eom_residual":           # a residual: compare its level, not its value
            good = row[k] <= max(1.05 * ref[k], ref[k] + 0.05)
        else:
            good = rel <= 0.05 or diff <= noise
        out[f"{k}_ok"] = good
        ok &= good
    out["quasi_static"] = row["dynamic_over_static"] < QUASI_STATIC_LIMIT
    out["all_ok"] = ok and out["quasi_static"]
    out["max_relerr"] = max(out[f"{k}_relerr"] for k in HEADLINES if k != "eom_residual")
    return out


def pareto_plot(table: pd.DataFrame, path: Path, ax=None):
    """Cost (CPU s, simulation + averaging) against the largest relative error."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    cost = table["sim_cpu_s"] + table["avg_cpu_s"]
    err = table["max_relerr"].clip(lower=1e-4)
    colors = np.where(table["all_ok"], "#009E73", "#D55E00")
    ax.scatter(cost, err, c=colors, zorder=3)
    for name, x, y in zip(table.index, cost, err):
        ax.annotate(name, (x, y), fontsize=7, xytext=(4, 2), textcoords="offset points")
    order = np.argsort(cost.values)
    front, best = [], math.inf
    for k in order:
        if err.iloc[k] < best:
            best = err.iloc[k]
            front.append(k)
    ax.step(cost.iloc[front], err.iloc[front], where="post", color="0.5", lw=1)
    ax.axhline(0.05, color="0.7", ls="--", lw=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: CPU time of simulation + averaging (s)")
    ax.set_ylabel("largest relative error of the headline numbers (-)")
    ax.set_title("paper scene: cost against error\n(green: all within 5% or noise, and "
                 "quasi-static)", fontsize=9)
    ax.figure.tight_layout()
    ax.figure.savefig(path.with_suffix(".png"), dpi=150)
    ax.figure.savefig(path.with_suffix(".pdf"))
    return ax


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--reference", help="an existing run of the paper-hooke preset to reuse")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", help="dask scheduler address")
    ap.add_argument("--table", action="store_true", help="only print the markdown table")
    args = ap.parse_args(argv)
    out = Path(args.out)
    csv = out / "sweep.csv"
    measured = pd.read_csv(csv, index_col="setting") if csv.exists() else pd.DataFrame()
    costs = {name: r[COST_COLUMNS].to_dict() for name, r in measured.iterrows()}
    if not args.table:
        out.mkdir(parents=True, exist_ok=True)
        costs.update(run_missing(out, set(costs), args))
    rows = {name: {**cost, **metrics(out / _slug(name) / "report")} for name, cost in costs.items()}
    attribute_simulation_cost(rows)
    table = pd.DataFrame({n: {**r, **compare(r, rows["reference"])} for n, r in rows.items()}).T
    table.index.name = "setting"
    table.to_csv(csv)
    pareto_plot(table, out / "pareto")
    print(markdown(table))


def run_missing(out: Path, have: set, args) -> dict:
    """Run on dask every setting not yet in OUT/sweep.csv; returns their costs.

    Settings measured before are kept as they are (a sweep can be extended or resumed
    without losing what it measured)."""
    from dask.distributed import Client, as_completed

    from granavg.io.parallel import local_cluster

    todo_sim = [n for n in SIMULATED if n not in have]
    todo_avg = [n for n in AVERAGED if n not in have]
    ref_run = Path(args.reference).resolve() if args.reference else out / "reference" / "run"
    done = {}
    cluster = None if args.scheduler else local_cluster(args.workers)
    with Client(args.scheduler or cluster) as client:
        futures = {}
        if "reference" not in have:
            if args.reference:
                m = json.loads((ref_run / "manifest.json").read_text())
                from datetime import datetime
                wall = (datetime.fromisoformat(m["finished"]) -
                        datetime.fromisoformat(m["started"])).total_seconds()
                done["reference"] = {"sim_cpu_s": wall, "sim_wall_s": wall}  # one core
                futures[client.submit(average_and_report, str(ref_run),
                                      str(out / "reference"), None, 1, pure=False)] = "reference"
            else:
                futures[client.submit(simulate_and_report, str(out / "reference"), [],
                                      pure=False)] = "reference"
        for name in todo_sim:
            futures[client.submit(simulate_and_report, str(out / _slug(name)),
                                  SIMULATED[name], pure=False)] = name

        def averaged():
            return {client.submit(average_and_report, str(ref_run), str(out / _slug(n)),
                                  *AVERAGED[n], pure=False): n for n in todo_avg}

        if "reference" in have:          # its dumps exist: the averaging can start now
            futures.update(averaged())
        pending = as_completed(list(futures))
        for fut in pending:
            name = futures[fut]
            done[name] = {**fut.result(), **done.get(name, {})}
            log.info("%s: %s", name, done[name])
            if name == "reference":
                more = averaged()
                futures.update(more)
                pending.update(more)
    if cluster is not None:
        cluster.close()
    return done


def markdown(table: pd.DataFrame) -> str:
    """The sweep as a markdown table: cost, each headline number's relative error
    against the reference (* = within 2 combined standard errors), verdict."""
    head = ["setting", "CPU s (sim + avg)", *HEADLINES, "dyn/static stress",
            "all within 5% or noise, quasi-static"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, r in table.iterrows():
        cells = [name, f"{r.sim_cpu_s:.0f} + {r.avg_cpu_s:.0f}"]
        for k in HEADLINES:
            star = "*" if str(r[f"{k}_within_noise"]) == "True" else ""
            cells.append(f"{r[k]:.4g} ({100 * r[f'{k}_relerr']:.1f}%{star})")
        cells.append(f"{r.dynamic_over_static:.3f}")
        cells.append("yes" if str(r.all_ok) == "True" else "no")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "=._" else "_" for c in name)


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="sweep: %(message)s")
    main()
