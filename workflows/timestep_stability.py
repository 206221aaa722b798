"""Where the time step breaks the contact law: energy conservation and overlap of an
elastic, frictionless head-on collision against dt/t_c, in LAMMPS and the reference DEM.

    python workflows/timestep_stability.py [OUT.csv]

Two small disks of the paper (k_n = 10 N/m, e_n = 1, mu = 0) meet head-on at 0.01 m/s
(the inner ring's speed). For n = t_c/dt steps per contact: the kinetic energy after the
contact over before (1 exactly for the model), and the largest overlap over the analytic
v/omega_n. Prints a markdown table (docs/stability.md holds the measured one).
"""

from __future__ import annotations

import sys

import pandas as pd

from granavg.sim.collision import elastic_head_on

STEPS_PER_CONTACT = [1.0, 1.5, 1.6, 2.0, 3.0, 5.0, 10.0, 20.0, 50.0, 100.0]
PHASES = [0.1, 0.3, 0.5, 0.7, 0.9]


def main(out=None):
    rows = [elastic_head_on(n, e, f) for n in STEPS_PER_CONTACT for e in ("lammps", "reference")
            for f in PHASES]
    table = pd.DataFrame(rows)
    if out:
        table.to_csv(out, index=False)
    table["energy_error"] = (table["energy_ratio"] - 1).abs()
    worst = table.groupby(["n", "engine"]).agg(
        energy_error=("energy_error", "max"), e_min=("energy_ratio", "min"),
        e_max=("energy_ratio", "max"), overlap=("max_overlap_over_analytic", "max"))
    print(f"worst over {len(PHASES)} contact phases\n")
    print("| n = t_c/dt | engine | E_after/E_before (min - max) | max abs energy error | "
          "max overlap / (v/omega_n) |")
    print("|---|---|---|---|---|")
    for (n, engine), r in worst.iterrows():
        print(f"| {n:g} | {engine} | {r.e_min:.4g} - {r.e_max:.4g} | {r.energy_error:.2e} | "
              f"{r.overlap:.4g} |")


if __name__ == "__main__":
    main(*sys.argv[1:2])
