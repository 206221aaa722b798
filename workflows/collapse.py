"""A 2D granular column collapse, its fields in time and their balance laws
(docs/time.md): the deck lammps_inputs/collapse_2d.lmp run once, then

1. a space-time map (kymograph) of the area fraction nu in 2 mm slabs along x, one field
   per 10 ms window (OUT/kymograph.png);
2. the front against time, two ways: from the particles (the rightmost disk's edge,
   each frame) and from the fields (the upper edge of the last slab with nu > 0 in each
   window, which must lie within one slab of the particles' farthest front in that
   window) (OUT/front.csv, OUT/front.png);
3. the continuity and momentum balance in time (Lucy kernel in space, w = 6 mm; Gauss
   in time, w_t = 1 ms) over a window dumped every step, thinned to every 1, 2, 4, 8,
   16 and 32 steps: the residuals against the frame interval, with their order (the
   continuity residual with the dumped velocities, and with the displacements' flux)
   (OUT/balance.md).

    python workflows/collapse.py OUT [--steps-per-tc N]     # about 3 min, 0.5 GB


SI units. The deck's contact law has a viscous normal dashpot; LAMMPS' contact dump
(compute pair/local) evaluates it at the dump's full-step velocities, not at the
half-step velocities the step used, which leaves the dumped contact forces off the ones
that moved the disks by about gamma_n dt / 2 of their damping part (docs/time.md). The
workflow's timestep is therefore t_c/200 (``--steps-per-tc``; the deck's default is
t_c/50), which makes that share 4 times smaller.
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path

import numpy as np

import granavg
from granavg.analysis.time_balance import continuity, momentum
from granavg.io.reader import DumpReader
from granavg.sim.lammps_session import lammps_session

DECK = Path(__file__).resolve().parents[1] / "lammps_inputs" / "collapse_2d.lmp"
MAP = dict(kv.split("=") for kv in
           "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
           "ftx=c_pl[5],fty=c_pl[6]".split(","))
COMMON = dict(contact_map=MAP, wall_types=[2], gravity=(0.0, -9.81))
#: The dumps: every 500 steps (5.2 ms) to 0.6 s, every step over the dense window (s).
DENSE = (0.0605, 0.0695)
#: Where the balance laws are evaluated (s): inside the dense window by 3 w_t.
BALANCE_TIMES = (0.064, 0.066, 0.001)
THINNING = (1, 2, 4, 8, 16, 32)


def deck_numbers(run: Path) -> dict:
    """The contact duration t_c and timestep dt (s) the deck printed in its log."""
    line = next(ln for ln in (run / "log.lammps").read_text().splitlines()
                if ln.startswith("collapse_2d: n_disks"))
    words = line.replace(",", "").split()
    return {"t_c": float(words[words.index("t_c") + 1]),
            "dt": float(words[words.index("dt") + 1])}
log = logging.getLogger("collapse")


def run_deck(out: Path, steps_per_tc: int = 200, dense=DENSE, duration=0.6,
             step: int = 1, every: int | None = None, mean_forces: bool = False) -> Path:
    """Run the collapse deck into ``out`` (skipped where its dumps are there): dumps
    every 5.2 ms (``every`` steps), and every ``step`` steps over ``dense`` (s; None:
    no dense window); ``mean_forces``: the atom dump holds the disks' mean forces over
    each interval (fix ave/atom; no dense window)."""
    if (out / "contacts.dump").exists():
        return out
    out.mkdir(parents=True, exist_ok=True)
    every = every or 500 * steps_per_tc // 50
    args = {"out": out, "every": every, "duration": duration, "steps_per_tc": steps_per_tc,
            "dense_every": step if dense else 0, "mean_forces": int(mean_forces)}
    if dense:
        args.update(dense_from=dense[0], dense_until=dense[1])
    cmd = ["-log", str(out / "log.lammps")]
    for k, v in args.items():
        cmd += ["-var", k, str(v)]
    with lammps_session(cmd, log_hint=str(out / "log.lammps")) as lmp:
        lmp.file(str(DECK))
    return out


def thin(src: Path, dst: Path, every: int) -> Path:
    """Copy every ``every``-th frame of a LAMMPS text dump, from its first (a frame
    starts at its ITEM: TIME or ITEM: TIMESTEP; ITEM: UNITS is in the first only)."""
    with open(src) as fin, open(dst, "w") as fout:
        block, rows, index = [], False, 0
        for line in fin:
            if line.startswith("ITEM: TIME") and rows:
                units = block[:2] if block[0].startswith("ITEM: UNITS") else []
                fout.writelines(block if index % every == 0 else units)
                block, rows, index = [], False, index + 1
            block.append(line)
            rows = rows or line.startswith("ITEM: NUMBER OF")
        if index % every == 0:
            fout.writelines(block)
    return dst


def thin_steps(src: Path, dst: Path, every: int, first: int = 0,
               last: int | None = None) -> Path:
    """Copy the frames of a LAMMPS text dump whose time step is a multiple of ``every``,
    between steps ``first`` and ``last`` (what a dump every ``every`` steps would have
    held; ITEM: UNITS kept)."""
    def flush(block, out):
        if "ITEM: TIMESTEP\n" not in block:
            out.writelines(block)               # ITEM: UNITS, before the first frame
            return
        step = int(block[block.index("ITEM: TIMESTEP\n") + 1])
        if step % every == 0 and first <= step and (last is None or step <= last):
            out.writelines(block)

    with open(src) as fin, open(dst, "w") as fout:
        block = []
        for line in fin:
            if line.startswith("ITEM: TIME") and not line.startswith("ITEM: TIMESTEP") \
                    and block:
                flush(block, fout)
                block = []
            block.append(line)
        if block:
            flush(block, fout)
    return dst


def particle_front(run: Path) -> tuple:
    """Times (s) and the front (m): the rightmost moving disk's edge in each frame."""
    t, front = [], []
    for frame in DumpReader(run / "atoms.dump", ["type", "x", "diameter"]):
        mobile = frame.column("type") == 1
        t.append(frame.time)
        front.append(float(np.max(frame.column("x")[mobile]
                                  + frame.column("diameter")[mobile] / 2)))
    return np.asarray(t), np.asarray(front)


def kymograph(run: Path, window=0.01, t_max=0.5, slab=0.002, length=0.30):
    """nu in slabs along x, one field per window (Fields with a time axis)."""
    bins = int(round(length / slab))
    return granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                           cells={"slabs": "x", "range": (0.0, length), "bins": bins,
                                  "thickness": 0.002},
                           quantities=["nu"], windows=window, t_max=t_max, **COMMON)


def field_front(fields) -> np.ndarray:
    """The upper edge of the last slab with nu > 0, per window (m)."""
    edges = fields.cells.edges
    nu = np.asarray(fields.values["nu"])
    last = np.array([np.flatnonzero(row > 0)[-1] for row in nu])
    return edges[last + 1]


def fronts(fields, t, front) -> list:
    """Per window: its times, the fields' front and the particles' farthest front."""
    rows = []
    for j, (lo, hi) in enumerate(zip(fields.time_edges[:-1], fields.time_edges[1:])):
        inside = (t >= lo) & (t < hi)
        rows.append({"t_lo": lo, "t_hi": hi, "front_fields": field_front(fields)[j],
                     "front_particles": float(front[inside].max())})
    return rows


def balance(run: Path, work: Path) -> list:
    """The continuity and momentum residuals against the frame interval."""
    rows = []
    for every in THINNING:
        atoms = thin(run / "atoms.dump", work / f"atoms.{every}.dump", every)
        contacts = thin(run / "contacts.dump", work / f"contacts.{every}.dump", every)
        f = granavg.average(atoms, contacts=contacts, **COMMON,
                            cells={"grid": (24, 10), "x_range": (0.0, 0.12),
                                   "y_range": (0.0, 0.05), "thickness": 0.002},
                            kernel="lucy", width=0.006, t_min=DENSE[0], t_max=DENSE[1],
                            time_kernel="gauss", time_width=0.001, times=BALANCE_TIMES)
        c, m = continuity(f, "continuity_v"), momentum(f)
        rows.append({"steps": every, "continuity": c["ratio"], "momentum": m["ratio"],
                     "continuity_verdict": c["claim"]["verdict"],
                     "momentum_verdict": m["claim"]["verdict"],
                     "continuity_flux": continuity(f)["ratio"]})
        atoms.unlink()
        contacts.unlink()
    return rows


def orders(rows, key) -> list:
    """The observed order between successive frame intervals: log(r2/r1)/log(k2/k1)."""
    return [math.log(b[key] / a[key]) / math.log(b["steps"] / a["steps"])
            for a, b in zip(rows, rows[1:])]


def markdown(rows) -> str:
    oc, om = orders(rows, "continuity"), orders(rows, "momentum")
    lines = ["| frames every (steps) | continuity with the dumped velocities / max abs d "
             "rho/dt | order | with the displacements' flux | momentum / rho g | order |",
             "|---|---|---|---|---|---|"]
    for i, r in enumerate(rows):
        a = f"{oc[i - 1]:.1f}" if i else ""
        b = f"{om[i - 1]:.1f}" if i else ""
        lines.append(f"| {r['steps']} | {r['continuity']:.2g} ({r['continuity_verdict']}) "
                     f"| {a} | {r['continuity_flux']:.1g} | {r['momentum']:.2g} "
                     f"({r['momentum_verdict']}) | {b} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--steps-per-tc", type=int, default=200,
                    help="timesteps per contact duration, a multiple of 50")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    run = run_deck(args.out / "run", args.steps_per_tc)
    fields = kymograph(run)
    ax = fields.plot("nu")
    ax.figure.savefig(args.out / "kymograph.png", dpi=120)
    t, front = particle_front(run)
    table = pd.DataFrame(fronts(fields, t, front))
    table.to_csv(args.out / "front.csv", index=False)
    fig, ax = plt.subplots()
    ax.plot(t, front, ".", ms=2, label="particles (each frame)")
    ax.step(table.t_hi, table.front_fields, where="pre", label="fields (each window)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("front x (m)")
    ax.legend()
    fig.savefig(args.out / "front.png", dpi=120)
    slab = fields.cells.edges[1] - fields.cells.edges[0]
    off = table.front_fields - table.front_particles
    log.info("front: fields minus particles' farthest, per window: %.2g to %.2g m "
             "(must lie in [0, %.3g m], one slab)", off.min(), off.max(), slab)
    rows = balance(run, args.out)
    text = markdown(rows)
    (args.out / "balance.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
