"""Are one run's errors of derived numbers honest? Against the spread of realisations.

Usage::

    python workflows/calibrate_derived.py OUT RUN RUN RUN RUN

Each run is reported alone (20 and 60 rings, as ``granavg demo`` does) twice: with errors
from time alone (``--sectors off``) and from time and structure (the default). For every
derived number of the report's summary (band fit, density, fabric, stress exponents,
stiffness, orientations, equations of motion, wall loads, eigen-rotation), the
between-run standard deviation over the rms single-run error is about 1 when the
errors are honest; also the largest leave-one-out |z| (see calibrate_errors.py).
Writes OUT/derived.csv and prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import logging
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from granavg.pipeline.reporting import report_run
from granavg.pipeline.spec import Spec

METHODS = {"time": None, "time+structure": "auto"}


def flat(d, prefix=""):
    """{"a": {"b": 1.0}} -> {"a.b": 1.0} (numbers only)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flat(v, f"{prefix}{k}."))
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            out[prefix + k] = float(v)
    return out


def numbers(run, out, sectors) -> dict:
    report_run(run, out, Spec.of(run, sectors=sectors))
    return flat(json.loads((out / "summary.json").read_text())["numbers"])


def calibrate(runs, out) -> pd.DataFrame:
    rows = []
    for method, sectors in METHODS.items():
        got = [numbers(r, out / f"{Path(r).name}-{method}", sectors) for r in runs]
        for key in (k for k in got[0] if f"{k}_err" in got[0]):
            x = np.array([g.get(key, np.nan) for g in got])
            e = np.array([g.get(f"{key}_err", np.nan) for g in got])
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(e)) and np.any(e > 0)):
                continue
            n = len(x)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                z = [abs(x[i] - np.delete(x, i).mean()) /
                     np.sqrt(e[i] ** 2 + np.sum(np.delete(e, i) ** 2) / (n - 1) ** 2)
                     for i in range(n)]
            rows.append({"number": key, "method": method, "runs": n,
                         "between_sd": x.std(ddof=1), "rms_error": np.sqrt(np.mean(e**2)),
                         "between_over_within": x.std(ddof=1) / np.sqrt(np.mean(e**2)),
                         "max_abs_z": max(z)})
    return pd.DataFrame(rows)


def markdown(df) -> str:
    wide = df.pivot(index="number", columns="method", values="between_over_within")
    wide = wide.loc[list(dict.fromkeys(df.number))]
    lines = ["| number | between/within, time | between/within, time + structure |",
             "|---|---|---|"]
    lines += [f"| {k} | {r['time']:.2f} | {r['time+structure']:.2f} |"
              for k, r in wide.iterrows()]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("runs", nargs="+", type=Path)
    args = ap.parse_args(argv)
    if len(args.runs) < 3:
        ap.error("give at least three independent realisations")
    args.out.mkdir(parents=True, exist_ok=True)
    df = calibrate(args.runs, args.out)
    df.to_csv(args.out / "derived.csv", index=False, float_format="%.4g")
    print(markdown(df))


if __name__ == "__main__":
    logging.basicConfig(level=logging.ERROR, format="calibrate: %(message)s")
    main()
