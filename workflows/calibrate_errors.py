"""Are granavg's within-run errors honest? Measured on independent realisations.

Usage::

    python workflows/calibrate_errors.py OUT RUN RUN RUN RUN [--bins 20] [--t-min T]

Each run is averaged alone (its errors from the blocking analysis, and, for contrast,
from the old fixed 20 blocks); the realisations' spread is the truth the within-run
errors should predict. For every quantity and bulk ring (middle half of the rings) and
every run, z = |run - ensemble mean| / within-run error; honest errors give z < 2 in
about 95% of cases (>= 90% is the target). Also the ratio of the between-run standard
deviation to the rms within-run error (1 when honest). Writes OUT/calibration.csv (one
row per quantity, method and window) and prints a markdown table.
"""

from __future__ import annotations

import argparse
import logging
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from granavg.pipeline.runs import run_averager
from granavg.engine.profiles import block_values
from granavg.engine.uncertainty import spread_error

QUANTITIES = ["nu", "v_phi", "omega", "coordination", "F_rr", "F_rphi", "F_phiphi",
              "sigma_rr", "sigma_rphi", "sigma_phiphi", "dsigma_rr", "dsigma_phiphi",
              "eps_rr", "eps_rphi", "eps_phiphi"]
log = logging.getLogger("calibrate")


def one_run(run, bins, t_min):
    """(values, blocking errors, old 20-block errors) of one run; dicts name -> (n_rings,)."""
    avg = run_averager(run, bins=bins, t_min=t_min)
    prof = avg.run(False)
    counts, sums = avg.acc.block_sums()
    groups = np.array_split(np.arange(len(counts)), 20)
    c20 = np.array([counts[g].sum() for g in groups])
    s20 = np.stack([sums[g].sum(axis=0) for g in groups])
    per_block = block_values(s20 / c20[:, None, None], avg.rings.volume, avg.rho_p, avg.groups)
    old = {k: spread_error(v) for k, v in per_block.items()}
    return prof, old


def calibrate(runs, bins, t_min) -> pd.DataFrame:
    results = [one_run(r, bins, t_min) for r in runs]
    n = results[0][0].rings.n
    bulk = slice(n // 4, n - n // 4)
    rows = []
    for q in QUANTITIES:
        x = np.stack([p.values[q][bulk] for p, _ in results])
        mean = x.mean(axis=0)
        for method, errs in (("blocking", [p.sem[q][bulk] for p, _ in results]),
                             ("20 fixed blocks", [o[q][bulk] for _, o in results])):
            e = np.stack(errs)
            with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                z = np.abs(x - mean) / e
                ratio = np.nanmedian(x.std(axis=0, ddof=1) / np.sqrt(np.nanmean(e**2, axis=0)))
            ok = np.isfinite(z)
            flagged = np.zeros_like(z, dtype=bool)
            for i, (p, _) in enumerate(results):
                idx = np.array(p.meta["errors"]["lower_bound"].get(q, []), dtype=int)
                flagged[i, idx[(idx >= bulk.start) & (idx < bulk.stop)] - bulk.start] = True
            lb = int(flagged.sum())
            plateau = ok & ~flagged
            rows.append({"quantity": q, "method": method, "t_min_s": results[0][0].meta[
                "frames"]["t_min_s"], "runs": len(runs), "bulk_rings": x.shape[1],
                "fraction_z_below_2": float(np.mean(z[ok] < 2)),
                "fraction_z_below_2_plateau": float(np.mean(z[plateau] < 2))
                if plateau.any() else float("nan"), "cases_plateau": int(plateau.sum()),
                "median_between_over_within": float(ratio),
                "lower_bound_rings": int(lb) if method == "blocking" else -1})
    return pd.DataFrame(rows)


def markdown(df: pd.DataFrame) -> str:
    lines = ["| quantity | t_min (s) | blocking: z < 2 | between/within | lower-bound cases "
             "| z < 2 where a plateau was found (cases) | 20 blocks: z < 2 | between/within |",
             "|---|---|---|---|---|---|---|---|"]
    for (q, t), g in df.groupby(["quantity", "t_min_s"], sort=False):
        b = g[g.method == "blocking"].iloc[0]
        o = g[g.method == "20 fixed blocks"].iloc[0]
        lines.append(f"| {q} | {t:.0f} | {b.fraction_z_below_2:.0%} | "
                     f"{b.median_between_over_within:.2f} | {b.lower_bound_rings} of "
                     f"{b.runs * b.bulk_rings} | {b.fraction_z_below_2_plateau:.0%} "
                     f"({b.cases_plateau}) | "
                     f"{o.fraction_z_below_2:.0%} | {o.median_between_over_within:.2f} |")
    for (m, t), g in df.groupby(["method", "t_min_s"], sort=False):
        lines.append(f"\nall quantities, {m}, t >= {t:.0f} s: z < 2 in "
                     f"{g.fraction_z_below_2.mean():.0%} (mean over quantities)")
        if m == "blocking":
            w = g.cases_plateau
            lines.append(f"where the blocking analysis found a plateau: z < 2 in "
                         f"{np.nansum(g.fraction_z_below_2_plateau * w) / w.sum():.0%} of "
                         f"{w.sum()} cases; lower-bound cases {g.lower_bound_rings.sum()}")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--bins", type=int, default=20)
    ap.add_argument("--t-min", type=float, nargs="+", default=[None],
                    help="start(s) of the average, s (default: two rotations)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    df = pd.concat([calibrate(args.runs, args.bins, t) for t in args.t_min], ignore_index=True)
    df.to_csv(args.out / "calibration.csv", index=False, float_format="%.4g")
    print(markdown(df))


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="calibrate: %(message)s")
    main()
