"""The dump interval as a trade (docs/time.md): the 2D column collapse
(lammps_inputs/collapse_2d.lmp at its own timestep, t_c/50) dumped every step over
84-136 ms, and the same frames thinned to every k steps, as a dump every k steps would
hold them (one trajectory, so that the residuals differ by the frames alone). For each
k, fields in time at 100-120 ms (Lucy in space, w = 4 mm on a 30 x 8 grid; Gauss in
time, w_t = 500 steps, 5 intervals of 100 steps, the same at every k):

- the momentum balance's residual, median and largest over bulk node-times (nu at
  least half the time's largest), of rho g;
- its estimated time-quadrature error (``momentum_quadrature``, from the frames at k
  alone) against how far the residual moved from the one of frames every step (rms
  over bulk node-times);
- the continuity residual with the displacements' mass flux and with the dumped
  velocities, of the largest |d rho/dt|;
- the interval forecast for a median residual of 1% from the frames at k alone, and
  the residual measured at it (whole steps, rounded down) and at 4 times it.

    python workflows/dump_interval.py OUT [--steps 1 2 4 10 20 40 100 200]  # ~3 min, 0.7 GB

``--scene silo``: the 3D silo (lammps_inputs/silo_3d.lmp) dumped every 20 steps (0.4
contact durations) over 0.1 s and thinned to every 40, 100 and 200 steps (Lucy, w = 4
mm, on a 4 x 4 x 24 grid over 0 <= z <= 0.11 m, above where spheres leave; Gauss w_t =
500 steps; fields at 40-80 ms); the change of the residual is from the frames every 20
steps, and the forecasts are checked by runs of their own dumped at the interval named
and at 4 times it (LAMMPS on one process repeats the trajectory whatever it dumps).
About 4 min, 0.8 GB.

SI units. Writes OUT/dump_interval.md and OUT/dump_interval.csv.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

import numpy as np

import granavg
from granavg.analysis.time_balance import continuity, interval_forecast, momentum

sys.path.insert(0, str(Path(__file__).resolve().parent))
import collapse  # noqa: E402
import silo  # noqa: E402

#: The window dumped every step (s) and the times of the fields in it.
EVERY_STEP, TIMES = (0.084, 0.136), (0.10, 0.12, 0.005)
#: The time kernel's width in steps (5 intervals of 100 steps).
WIDTH_STEPS = 500
QUANTITIES = ["nu", "rho", "v", "drho_dt", "continuity", "continuity_v", "dmomentum_dt",
              "divsigma", "divdsigma", "body", "boundary", "momentum_balance",
              "momentum_quadrature"]
log = logging.getLogger("dump_interval")


class Silo:
    """The silo dumped every :attr:`BASE` steps into ``work``/run; :meth:`fields` as
    :class:`Thinned`'s, at multiples of :attr:`BASE`, and at other intervals from runs of
    their own (deleted once averaged)."""

    BASE, DURATION, TIMES = 20, 0.1, (0.04, 0.08, 0.01)

    def __init__(self, work: Path):
        self.work = Path(work)
        self.run = silo.run_deck(self.work / "run", duration=self.DURATION, every=self.BASE)
        self.dt = float(next(ln for ln in (self.run / "log.lammps").read_text().splitlines()
                             if ln.startswith("silo_3d: L =")).split(" dt ")[1].split()[0])
        self.cache = {}

    def fields(self, k: int):
        if k in self.cache:
            return self.cache[k]
        if k % self.BASE == 0:
            run = self.run
            a = collapse.thin_steps(run / "atoms.dump", self.work / "a.dump", k)
            c = collapse.thin_steps(run / "contacts.dump", self.work / "c.dump", k)
        else:
            run = silo.run_deck(self.work / f"run{k}", duration=self.DURATION, every=k)
            a, c = run / "atoms.dump", run / "contacts.dump"
        self.cache[k] = granavg.average(
            a, contacts=c, contact_map=silo.MAP, wall_types=[2], gravity=(0.0, 0.0, -9.81),
            cells={"grid": (4, 4, 24), "z_range": (0.0, 0.11)}, kernel="lucy", width=0.004,
            t_min=0.02, t_max=self.DURATION, time_kernel="gauss",
            time_width=WIDTH_STEPS * self.dt, times=self.TIMES, quantities=QUANTITIES)
        if run != self.run:
            for f in run.iterdir():
                f.unlink()
            run.rmdir()
        return self.cache[k]


class Thinned:
    """The collapse dumped every step into ``work``/run (run once); :meth:`fields` are its
    fields from the frames every k steps (kept)."""

    def __init__(self, work: Path):
        self.work = Path(work)
        self.run = collapse.run_deck(self.work / "run", 50, dense=EVERY_STEP, duration=0.14,
                                     step=1)
        self.dt = collapse.deck_numbers(self.run)["dt"]
        self.first = int(np.ceil(EVERY_STEP[0] / self.dt))
        self.last = int(EVERY_STEP[1] / self.dt)
        self.cache = {}

    def fields(self, k: int):
        """The fields of the frames every ``k`` steps."""
        if k not in self.cache:
            a = collapse.thin_steps(self.run / "atoms.dump", self.work / "a.dump", k,
                                    self.first, self.last)
            c = collapse.thin_steps(self.run / "contacts.dump", self.work / "c.dump", k,
                                    self.first, self.last)
            self.cache[k] = granavg.average(
                a, contacts=c, **collapse.COMMON, cells={
                    "grid": (30, 8), "x_range": (0.0, 0.15), "y_range": (0.0, 0.04),
                    "thickness": 0.002},
                kernel="lucy", width=0.004, time_kernel="gauss",
                time_width=WIDTH_STEPS * self.dt, times=TIMES, quantities=QUANTITIES)
        return self.cache[k]


def bulk_rms(f, a) -> float:
    """The rms of |a| / (rho g) over the bulk node-times of fields ``f``."""
    nu, rho_g = f.values["nu"], f.values["rho"] * 9.81
    bulk = (nu >= 0.5 * nu.max(axis=1, keepdims=True)) & (rho_g > 0)
    return float(np.sqrt(np.mean((a[bulk] / rho_g[bulk]) ** 2)))


def residual(f) -> np.ndarray:
    """The momentum residual's components, shape (D, n_times, n_cells)."""
    return np.stack([f.values[f"momentum_balance_{x}"] for x in f.cells.axes])


def row(data, k: int, target: float = 0.01, reference: int = 1) -> dict:
    """One interval's numbers (module docstring); the change of the residual from the
    frames every ``reference`` steps."""
    f, ref = data.fields(k), data.fields(reference)
    m = momentum(f)
    change = bulk_rms(f, np.linalg.norm(residual(f) - residual(ref), axis=0))
    estimate = bulk_rms(f, f.values["momentum_quadrature"])
    forecast = interval_forecast(f, target)
    named = forecast.get("forecast_interval") if forecast else None
    steps = int(named / data.dt + 1e-6) if named else 0
    at = momentum(data.fields(steps))["median"] if steps >= 1 else float("nan")
    beyond = momentum(data.fields(4 * steps))["median"] if steps >= 1 else float("nan")
    return {"steps": k, "contact_durations": k / 50, "momentum_median": m["median"],
            "momentum_largest": m["ratio"], "estimate_rms": estimate, "change_rms": change,
            "estimate_over_change": estimate / change if change > 0 else float("nan"),
            "order": f.meta["time"]["quadrature"]["order"],
            "continuity_flux": continuity(f)["ratio"],
            "continuity_velocities": continuity(f, "continuity_v")["ratio"],
            "forecast_steps": named / data.dt if named else float("nan"),
            "dumped_at": steps, "median_at": at, "median_at_4x": beyond}


def markdown(rows) -> str:
    lines = ["| frames every (steps) | t_c | momentum / rho g: median (largest) | estimate / "
             "change (rms) | order | continuity: flux / velocities | forecast for 1% "
             "(steps) | median at it / at 4x |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['steps']} | {r['contact_durations']:.2g} | {r['momentum_median']:.2g} "
            f"({r['momentum_largest']:.2g}) | {r['estimate_rms']:.2g} / "
            f"{r['change_rms']:.2g} = {r['estimate_over_change']:.2f} | {r['order']:.2f} | "
            f"{r['continuity_flux']:.1g} / {r['continuity_velocities']:.2g} | "
            f"{r['forecast_steps']:.3g} | {r['median_at']:.3g} ({r['dumped_at']} steps) / "
            f"{r['median_at_4x']:.3g} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--steps", type=int, nargs="+",
                    help="the intervals (default: 1 2 4 10 20 40 100 200; silo: 20 40 100 200)")
    ap.add_argument("--scene", choices=["collapse", "silo"], default="collapse")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    import pandas as pd

    args.out.mkdir(parents=True, exist_ok=True)
    if args.scene == "silo":
        data, reference = Silo(args.out), Silo.BASE
        steps = args.steps or [20, 40, 100, 200]
    else:
        data, reference = Thinned(args.out), 1
        steps = args.steps or [1, 2, 4, 10, 20, 40, 100, 200]
    rows = [row(data, k, reference=reference) for k in steps]
    pd.DataFrame(rows).to_csv(args.out / "dump_interval.csv", index=False)
    (args.out / "dump_interval.md").write_text(markdown(rows) + "\n")
    print(markdown(rows))


if __name__ == "__main__":
    main()
