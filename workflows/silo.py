"""A small 3D silo discharge in time (docs/time.md): the deck lammps_inputs/silo_3d.lmp
run once, then

1. a space-time map (kymograph) of the solid fraction nu in 2 mm slabs along z (the
   bed empties from above, the jet below the floor), one field per 10 ms window
   (OUT/kymograph.png);
2. the mass flow rate two ways over the steady discharge: from the coarse-grained
   momentum density rho v_z in a slab under the orifice, times the box's cross-section,
   and from counting the mass of the spheres above the slab's middle (its decrease over
   blocks of time); each with its standard error (OUT/rate.md);
3. both set against Beverloo's law W = C rho_b sqrt(g) (D - k d)^(5/2) (C = 0.58,
   k = 1.5, rho_b the bed's bulk density from the fields).

    python workflows/silo.py OUT [--duration 0.35] [--steady 0.1]    # about 1 min

SI units. The two rates agree in exact arithmetic up to the slab's change of mass over
the time averaged (continuity in the slab), which the errors cover when the slab's
content fluctuates about a steady mean.
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path

import numpy as np

import granavg
from granavg.io.reader import DumpReader
from granavg.sim.lammps_session import lammps_session

DECK = Path(__file__).resolve().parents[1] / "lammps_inputs" / "silo_3d.lmp"
MAP = dict(kv.split("=") for kv in
           "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
           "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]".split(","))
G = 9.81
#: The slab the fields' flux is taken in (m): under the floor (its spheres' centres at
#: z = 0), above where the deck drops the spheres (z = -0.01).
SLAB = (-0.008, -0.002)
#: Blocks of time for the count's error (s).
BLOCK = 0.025
#: Beverloo's constants (Nedderman 1992): C, k.
BEVERLOO = (0.58, 1.5)
log = logging.getLogger("silo")


def run_deck(out: Path, duration: float = 0.35, plug: str = "spheres", **extra) -> Path:
    """Run the silo deck into ``out`` (skipped where its dumps are there)."""
    if (out / "contacts.dump").exists():
        return out
    out.mkdir(parents=True, exist_ok=True)
    cmd = ["-log", str(out / "log.lammps")]
    for k, v in {"out": out, "duration": duration, "plug": plug, **extra}.items():
        cmd += ["-var", k, str(v)]
    with lammps_session(cmd, log_hint=str(out / "log.lammps")) as lmp:
        lmp.file(str(DECK))
    return out


def box_area(run: Path) -> float:
    """The box's cross-section normal to z (m^2), from the dump's first frame."""
    frame = next(iter(DumpReader(run / "atoms.dump", ["id"])))
    return float(np.prod(frame.box[:2, 1] - frame.box[:2, 0]))


def mass_above(run: Path, z0: float) -> tuple:
    """Times (s) and the mass (kg) of the moving spheres (type 1) above z0, per frame."""
    t, mass = [], []
    for frame in DumpReader(run / "atoms.dump", ["type", "mass", "z"]):
        keep = (frame.column("type") == 1) & (frame.column("z") > z0)
        t.append(frame.time)
        mass.append(float(frame.column("mass")[keep].sum()))
    return np.asarray(t), np.asarray(mass)


def count_rate(t, mass, t0: float, t1: float, block: float = BLOCK) -> tuple:
    """The mass flow rate (kg/s) from the mass's decrease over blocks of ``block`` s in
    [t0, t1], and its standard error from the blocks' scatter (independent blocks: a
    lower bound if their rates are correlated)."""
    edges = np.arange(t0, t1 + 1e-12, block)
    m = np.interp(edges, t, mass)
    rates = -np.diff(m) / block
    return float(rates.mean()), float(rates.std(ddof=1) / math.sqrt(len(rates)))


def field_rate(run: Path, area: float, t0: float, t1: float, block: float = BLOCK) -> tuple:
    """The mass flow rate (kg/s) from the coarse-grained momentum density rho v_z in
    SLAB (mass-weighted v: rho v_z is sum m v_z / V exactly), times the cross-section,
    per window of ``block`` s in [t0, t1]: their mean and its standard error from the
    windows' scatter (as :func:`count_rate`), and the per-window rates."""
    f = granavg.average(run / "atoms.dump", wall_types=[2], t_min=t0, t_max=t1,
                        windows=block, cells={"slabs": "z", "range": SLAB, "bins": 1},
                        quantities=["rho", "v"])
    rates = -np.asarray(f.values["rho"])[:, 0] * np.asarray(f.values["v_z"])[:, 0] * area
    return float(rates.mean()), float(rates.std(ddof=1) / math.sqrt(len(rates))), rates


def bulk_density(run: Path, t0: float, t1: float, z=(0.004, 0.016)) -> tuple:
    """The bed's bulk density (kg/m^3) in a slab of the bed, averaged over [t0, t1],
    and its standard error."""
    f = granavg.average(run / "atoms.dump", wall_types=[2], t_min=t0, t_max=t1,
                        cells={"slabs": "z", "range": z, "bins": 1}, quantities=["rho"])
    return float(f.values["rho"][0]), float(f.sem["rho"][0])


def beverloo(rho_bulk: float, d_orifice: float, d: float) -> float:
    """Beverloo's mass flow rate (kg/s) of a circular orifice."""
    c, k = BEVERLOO
    return c * rho_bulk * math.sqrt(G) * (d_orifice - k * d) ** 2.5


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--duration", type=float, default=0.35, help="s after the opening")
    ap.add_argument("--steady", type=float, default=0.1,
                    help="the discharge is steady from this time on (s)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    import matplotlib
    matplotlib.use("Agg")

    run = run_deck(args.out / "run", args.duration)
    kymo = granavg.average(run / "atoms.dump", wall_types=[2], windows=0.01,
                           cells={"slabs": "z", "range": (-0.01, 0.04), "bins": 25},
                           quantities=["nu"])
    kymo.plot("nu").figure.savefig(args.out / "kymograph.png", dpi=120)
    t0, t1 = args.steady, args.duration
    area = box_area(run)
    t, mass = mass_above(run, sum(SLAB) / 2)
    counted, counted_err = count_rate(t, mass, t0, t1)
    fields, fields_err, _ = field_rate(run, area, t0, t1)
    rho_b, rho_b_err = bulk_density(run, t0, t1)
    law = beverloo(rho_b, 0.012, 0.002)
    gap = abs(fields - counted) / math.hypot(fields_err, counted_err)
    lines = ["| mass flow rate | g/s |", "|---|---|",
             f"| fields: rho v_z in z in [{SLAB[0]}, {SLAB[1]}] m, times {area:.4g} m^2 "
             f"| {1e3 * fields:.2f} +- {1e3 * fields_err:.2f} |",
             f"| particles: mass above z = {sum(SLAB) / 2} m, its decrease "
             f"| {1e3 * counted:.2f} +- {1e3 * counted_err:.2f} |",
             f"| Beverloo, C = {BEVERLOO[0]}, k = {BEVERLOO[1]}, D = 12 mm, d = 2 mm, "
             f"rho_b = {rho_b:.0f} +- {rho_b_err:.0f} kg/m^3 | {1e3 * law:.2f} |",
             "", f"Over t in [{t0}, {t1}] s, blocks of {BLOCK} s. Fields minus particles: "
             f"{gap:.2f} combined standard errors (they agree within errors where this is "
             "at most 2). Measured over Beverloo: "
             f"{fields / law:.2f}."]
    text = "\n".join(lines)
    (args.out / "rate.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
