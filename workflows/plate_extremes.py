"""Where the new parts of the `paper` scene break: the base plate's law as v_base -> 0,
its coefficient renewed every `base_every` steps, rolling resistance, and restitution
from 0 to 1 with the plate (issue 40).

    python workflows/plate_extremes.py OUT [--t-end 2] [--workers 2]
    python workflows/plate_extremes.py OUT --jitter   # the plate's chatter, small cell

With ``--jitter``: the small cell of tests/test_plate_extremes.py at rest on a plate with
mu_base = 0.5, every step of its last 0.01 s dumped, at lambda dt = 0.9, 1.8, 2.2 and 4
with the plate's law each step and renewed every 10 steps; prints the rms of the part
of the disks' step-to-step displacement that flips sign every step (the tests' own
scene and measure) against the analytic dt v* of the law each step.

Each probe shears one of the `paper` preset's shipped packings (seed 20011) for T s of
the scene (2 s: 8600 steps, 0.03 rotation) with one knob changed and granavg's own
refusals lifted, so that a setting beyond them is run, not refused. Measured per probe,
from the run itself: whether it completed or LAMMPS' blow-up halt stopped it; the disks'
kinetic energy (thermo, every 21 steps) over the run against the same run with the
preset's value (`ke_ratio`: median over the second half of the run; `ke_growth`: the
largest over the median); the largest overlap. Writes OUT/extremes.csv and prints a
markdown table (docs/stability.md holds the measured one).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

#: probe name: --set overrides of the preset (v_base in m/s)
PROBES = {
    "preset": [],
    # the plate's law -> a step: lambda dt = mu_base g dt / v_base (0.113 at the preset)
    **{f"v_base={v:g}": [f"v_base={v:g}"] for v in (3e-5, 1.5e-5, 1e-5, 7e-6, 6e-6, 5e-6)},
    **{f"v_base={v:g}, every step": [f"v_base={v:g}", "base_every=0"]
       for v in (1e-4, 1e-5, 6e-6, 5e-6)},
    # the coefficient renewed rarely against the contact time (n_per_tc = 50 steps)
    **{f"base_every={k}": [f"base_every={k}"] for k in (0, 1, 50, 200, 1000)},
    # rolling resistance: the cap and the rolling spring at the smallest step allowed
    **{f"mu_roll={m:g}": [f"mu_roll={m:g}"] for m in (0.1, 0.5, 1, 3)},
    **{f"mu_roll={m:g}, n_per_tc=10": [f"mu_roll={m:g}", "n_per_tc=10"] for m in (0.3, 3)},
    "n_per_tc=10": ["n_per_tc=10"],
    "mu_roll=0, n_per_tc=10": ["mu_roll=0", "n_per_tc=10"],
    # ... and below that step (beyond the refusal): does the rolling spring break first?
    **{f"mu_roll={m:g}, n_per_tc={n:g}": [f"mu_roll={m:g}", f"n_per_tc={n:g}"]
       for m in (0, 0.3, 3) for n in (5, 3, 2)},
    # restitution with the plate
    **{f"e_n={e:g}": [f"e_n={e:g}"] for e in (1e-19, 1e-17, 1e-12, 1e-6, 3e-6, 1e-5, 1e-4,
                                                1e-3, 0.01, 0.1, 0.5, 0.99, 1.0)},
    # ... at finer steps: is it the dashpot's damping per step, gamma_n dt, that decides?
    "e_n=1e-06, n_per_tc=100": ["e_n=1e-6", "n_per_tc=100"],
    "e_n=1e-12, n_per_tc=200": ["e_n=1e-12", "n_per_tc=200"],
    "e_n=1e-12, n_per_tc=120": ["e_n=1e-12", "n_per_tc=120"],
}


def thermo(log: Path) -> np.ndarray:
    """(time s, kinetic energy J) of every thermo line of a run's LAMMPS log, shape (n, 2)."""
    rows, on = [], False
    for line in log.read_text(errors="replace").splitlines():
        words = line.split()
        if words[:3] == ["Step", "Time", "c_ke_mob"]:
            on = True
            continue
        if on and len(words) == 4:
            try:
                rows.append((float(words[1]), float(words[2])))
                continue
            except ValueError:
                pass
        on = False
    return np.asarray(rows, float).reshape(-1, 2)


def probe(name: str, sets: list, out: str, t_end: float) -> dict:
    """One probe run; its outcome from its own log and manifest."""
    import granavg.sim.scene as scene_mod
    from granavg.errors import UserError
    from granavg.sim.scene import preset
    from granavg.sim.simulate import simulate

    scene_mod.MAX_BASE_DAMPING = math.inf          # probe beyond granavg's refusals: the
    scene_mod.MIN_STEPS_PER_CONTACT = 1e-9         # plate's, the time step's, the dashpot's
                                                   # and the plate's renewal
    scene_mod.max_stable_timestep = lambda *_: math.inf
    scene_mod.MAX_DASHPOT_DAMPING = scene_mod.MAX_RENEWAL_CONTACTS = math.inf
    scene = preset("paper").with_overrides([f"t_end={t_end}", "dump_dt=0.5",
                                            f"restart_dt={t_end}", *sets])
    d = scene.derive()
    lam_dt = scene.mu_base * scene_mod.G * d.dt / scene.v_base
    row = {"probe": name, "lambda_dt": lam_dt, "gamma_n_dt": d.coeffs.gamma_n * d.dt,
           "base_every": scene.base_every,
           "base_every_over_n": scene.base_every / scene.n_per_tc, "mu_roll": scene.law.mu_roll,
           "e_n": scene.law.e_n, "n_per_tc": scene.n_per_tc}
    try:
        simulate(scene, out, progress=False, preset="paper")
        row["status"] = "complete"
    except UserError as e:
        row["status"] = "blew up" if "blew up" in str(e) else f"refused: {e}"
    ke = thermo(Path(out) / "log.lammps")
    ke = ke[ke[:, 0] > 0] if len(ke) else ke
    if len(ke):
        late = ke[ke[:, 0] >= ke[-1, 0] / 2, 1]
        row.update(ke_median=float(np.median(late)), ke_max=float(ke[:, 1].max()),
                   t_reached=float(ke[-1, 0]))
    m = Path(out) / "manifest.json"
    if m.exists():
        ov = json.loads(m.read_text()).get("overlap") or {}
        row["max_overlap_over_d_s"] = ov.get("max_over_d_s_all_frames")
    return row


def jitter_table(out: Path) -> None:
    """Print the plate's chatter in the small cell (module docstring, ``--jitter``)."""
    import sys

    import granavg.sim.scene as scene_mod
    from granavg.errors import UserError
    from granavg.sim.simulate import simulate

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.test_plate_extremes import plate_scene, step_jitter

    scene_mod.MAX_BASE_DAMPING = math.inf
    print("| lambda dt | base_every 0 | base_every 10 | dt v* (analytic, base_every 0) |")
    print("|---|---|---|---|")
    for lam in (0.9, 1.8, 2.2, 4.0):
        cells = []
        for every in (0, 10):
            sc = plate_scene(lam, f"base_every={every}")
            run = out / f"jitter{lam}_{every}"
            try:
                simulate(sc, run, progress=False)
                cells.append(f"{step_jitter(run):.2g} m")
            except UserError as e:
                cells.append("blew up" if "blew up" in str(e) else f"refused: {e}")
        v_star = sc.v_base * math.sqrt(max((lam / 2) ** 2 - 1, 0.0))
        print(f"| {lam:g} | {cells[0]} | {cells[1]} | "
              f"{f'{sc.derive().dt * v_star:.3g} m' if v_star else '-'} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", nargs="*", help="probe names to run (default: all)")
    ap.add_argument("--jitter", action="store_true", help="only the plate's chatter in the "
                    "small cell")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.jitter:
        return jitter_table(out)
    names = args.only or list(PROBES)
    with ProcessPoolExecutor(args.workers) as pool:
        futs = [pool.submit(probe, n, PROBES[n], str(out / _slug(n)), args.t_end) for n in names
                if not (out / _slug(n)).exists()]
        rows = [f.result() for f in futs]
    csv = out / "extremes.csv"
    old = pd.read_csv(csv) if csv.exists() else pd.DataFrame()
    table = pd.concat([old, pd.DataFrame(rows)]).drop_duplicates("probe", keep="last")
    ref = table.set_index("probe").loc["preset", "ke_median"]
    table["ke_ratio"] = table["ke_median"] / ref
    table["ke_growth"] = table["ke_max"] / table["ke_median"]
    table.to_csv(csv, index=False)
    print("| probe | lambda dt | gamma_n dt | base_every / n | status | KE / preset's (2nd "
          "half) | KE max / median | max overlap / d_s |")
    print("|---|---|---|---|---|---|---|---|")
    for _, r in table.iterrows():
        print(f"| {r.probe} | {r.lambda_dt:.3g} | {r.gamma_n_dt:.3g} | "
              f"{r.base_every_over_n:.3g} | {r.status} | "
              f"{r.ke_ratio:.3g} | {r.ke_growth:.3g} | {r.max_overlap_over_d_s:.3g} |")


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "=._" else "_" for c in name)


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    main()
