"""Are one run's errors honest? Single-run errors against the spread of realisations.

Usage::

    python workflows/calibrate_errors.py OUT RUN RUN RUN RUN [--bins 20] [--t-min T]
                                         [--quantities paper|micropolar]

Each run is read once and its errors made several ways from the same accumulators: from
time alone (blocking analysis), and from time and structure with the rings split into
sectors (K chosen from the data, ``auto``, and K pinned to 4, 6, 8, 12, 24;
:mod:`granavg.engine.uncertainty.structure`). The realisations' spread is the truth the single-run
errors should predict. For every quantity, bulk ring (middle half of the rings) and run
i, the leave-one-out score

    z = (x_i - mean of the other runs) / sqrt(sem_i^2 + sum_j sem_j^2 / (n - 1)^2)

is a standard normal if the errors are honest: |z| < 2 in 95% of cases, median |z|
0.67. Also the between-run standard deviation over the rms single-run error (about 1
when honest). Writes OUT/calibration.csv (one row per quantity and method) and prints
a markdown table.
"""

from __future__ import annotations

import argparse
import logging
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from granavg.engine.uncertainty import structure as replicas
from granavg.pipeline.runs import run_averager

QUANTITIES = ["nu", "coordination", "sigma_rr", "sigma_rphi", "v_phi", "omega", "F_rr",
              "F_phiphi",
              "sigma_phiphi", "eps_rr", "eps_phiphi"]
METHODS = ["time", "auto", 4, 6, 8, 12, 24]
log = logging.getLogger("calibrate")


def one_run(run, bins, t_min) -> dict:
    """Fields of one run with every method's errors, from one pass over its frames."""
    avg = run_averager(run, bins=bins, t_min=t_min)
    avg.run(False)
    out, replica_acc = {}, avg.replica_acc
    for method in METHODS:
        avg.replica_acc = None if method == "time" else replica_acc
        avg.sectors = "auto" if method == "time" else method
        out[method] = avg.conclude()
    return out


def scores(x, e):
    """Leave-one-out z of every run and ring, shape (n_runs, n_rings)."""
    n = len(x)
    z = np.empty_like(x)
    for i in range(n):
        rest = np.delete(np.arange(n), i)
        z[i] = (x[i] - x[rest].mean(axis=0)) / np.sqrt(
            e[i] ** 2 + np.sum(e[rest] ** 2, axis=0) / (n - 1) ** 2)
    return z


#: The micropolar and energy fields (issue 39): ``--quantities micropolar``.
MICROPOLAR = ["mu_r", "mu_phi", "dmu_phi", "spin_density", "couple_density", "ekin", "erot",
              "temperature", "temperature_rot", "contact_power"]


def calibrate(runs, bins, t_min, quantities=QUANTITIES) -> pd.DataFrame:
    results = [one_run(r, bins, t_min) for r in runs]
    n = results[0]["time"].cells.n
    bulk = slice(n // 4, n - n // 4)
    rows = []
    for method in METHODS:
        for q in quantities:
            x = np.stack([r[method].values[q][bulk] for r in results])
            e = np.stack([r[method].sem[q][bulk] for r in results])
            with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                z = np.abs(scores(x, e))
                ratio = np.nanmedian(x.std(axis=0, ddof=1) / np.sqrt(np.nanmean(e**2, axis=0)))
            ok = np.isfinite(z)
            sec = [r[method].meta["errors"].get("sectors") or {} for r in results]
            rows.append({"quantity": q, "method": str(method), "runs": len(runs),
                         "t_min_s": results[0][method].meta["frames"]["t_min_s"],
                         "bulk_rings": x.shape[1], "cases": int(ok.sum()),
                         "fraction_z_below_2": float(np.mean(z[ok] < 2)),
                         "median_abs_z": float(np.median(z[ok])),
                         "between_over_within": float(ratio),
                         "sectors": ",".join(str(s.get("sectors", "-")) for s in sec),
                         "flagged_lower_bound": int(sum(
                             np.sum((np.array(r[method].meta["errors"]["lower_bound"].get(
                                 q, []), int) >= bulk.start) &
                                 (np.array(r[method].meta["errors"]["lower_bound"].get(
                                     q, []), int) < bulk.stop)) for r in results))})
    return pd.DataFrame(rows)


def markdown(df: pd.DataFrame) -> str:
    lines = ["| quantity | " + " | ".join(f"{m}: z<2, median, between/within"
                                          for m in df.method.unique()) + " |",
             "|---|" + "---|" * df.method.nunique()]
    for q, g in df.groupby("quantity", sort=False):
        cells = [f"{r.fraction_z_below_2:.0%}, {r.median_abs_z:.2f}, "
                 f"{r.between_over_within:.2f}" for r in g.itertuples()]
        lines.append(f"| {q} | " + " | ".join(cells) + " |")
    auto = df[df.method == "auto"]
    lines.append(f"\nsectors chosen (auto) per run: {auto.sectors.iloc[0]}")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--bins", type=int, default=20)
    ap.add_argument("--t-min", type=float, default=None,
                    help="start of the average, s (default: the run's discarded transient)")
    ap.add_argument("--sectors-for-stress", action="store_true",
                    help="give sigma_rr, sigma_rphi, sigma_phir sector errors too (to measure "
                         "why granavg gives them time errors only)")
    ap.add_argument("--quantities", choices=["paper", "micropolar"], default="paper",
                    help="the paper's quantities (default) or the micropolar and energy "
                         "fields")
    args = ap.parse_args(argv)
    if args.sectors_for_stress:
        replicas.balanced_names = lambda groups, across="r": set()
    if len(args.runs) < 3:
        ap.error("give at least three independent realisations")
    args.out.mkdir(parents=True, exist_ok=True)
    df = calibrate(args.runs, args.bins, args.t_min,
                   MICROPOLAR if args.quantities == "micropolar" else QUANTITIES)
    df.to_csv(args.out / "calibration.csv", index=False, float_format="%.4g")
    print(markdown(df))


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING, format="calibrate: %(message)s")
    main()
