"""The packing's state over time, as in issue 12's table, from a time series that
`granavg average` wrote (``<out>.timeseries.csv``; an ensemble's carries a ``run`` column).

Usage::

    python workflows/state_over_time.py SERIES.csv [--times 0 10 20 30 40] [--width 5]

Each row: the means over the frames with t <= time < t + width of every run, then over the
runs (SI units; d_s is the small disks' diameter): coordination overall and in the bulk,
mean overlap / d_s, bulk static pressure (Pa), rattler share (< 2 contacts) and the bulk
share of hexatically ordered disks (|psi_6| > 0.8). The +- is the between-run standard
error (independent realisations), given with 3 or more runs.
"""

from __future__ import annotations

import argparse
import math
import sys

import pandas as pd

COLUMNS = {"C": "C all", "C_bulk": "C bulk", "overlap_mean_over_d": "mean overlap / d_s",
           "P_bulk_Pa": "bulk P (Pa)", "rattler_fraction": "rattlers",
           "psi6_bulk_ordered": "ordered share, bulk"}


def over_time(series: pd.DataFrame, times, width: float) -> pd.DataFrame:
    """Rows per time: the mean over runs of each run's mean in [t, t + width), and the
    between-run standard error (``<column>_err``, NaN with fewer than 3 runs)."""
    series = series.assign(run=series["run"] if "run" in series else "run")
    rows = []
    for t in times:
        part = series[(series.t_s >= t) & (series.t_s < t + width)]
        per_run = part.groupby("run")[[c for c in COLUMNS if c in part]].mean()
        n = len(per_run)
        row = {"t_s": t, "runs": n}
        for c in per_run:
            row[c] = per_run[c].mean()
            row[f"{c}_err"] = per_run[c].std(ddof=1) / math.sqrt(n) if n >= 3 else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


def markdown(table: pd.DataFrame) -> str:
    def cell(r, c, fmt):
        err = r.get(f"{c}_err", math.nan)
        return format(r[c], fmt) + ("" if math.isnan(err) else " +- " + format(err, ".1g"))
    head = ["t (s)", "C all / bulk", "mean overlap / d_s", "bulk P (Pa)", "rattlers",
            "ordered share, bulk"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, r in table.iterrows():
        lines.append(f"| {r.t_s:g} | {r.C:.2f} / {r.C_bulk:.2f} | "
                     f"{cell(r, 'overlap_mean_over_d', '.4f')} | {cell(r, 'P_bulk_Pa', '.1f')} | "
                     f"{r.rattler_fraction:.1%} | {cell(r, 'psi6_bulk_ordered', '.3f')} |")
    return "\n".join(lines)


def refuse(message: str):
    """One line on stderr and exit code 2 (a user mistake)."""
    print(f"state_over_time: {message}", file=sys.stderr)
    sys.exit(2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("series")
    ap.add_argument("--times", type=float, nargs="+", default=[0, 10, 20, 30, 40])
    ap.add_argument("--width", type=float, default=5.0, help="s averaged from each time")
    args = ap.parse_args(argv)
    try:
        series = pd.read_csv(args.series)
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as err:
        refuse(f"cannot read {args.series}: {err}; give a time series written by "
               "`granavg average`")
    missing = [c for c in ("t_s", *COLUMNS) if c not in series]
    if missing:
        refuse(f"{args.series} has no column {missing[0]}; give a time series written by "
               "`granavg average` with the contact dump")
    print(markdown(over_time(series, args.times, args.width)))


if __name__ == "__main__":
    main()
