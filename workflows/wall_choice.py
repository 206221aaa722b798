"""Which wall and friction reproduce the paper's shear band? (docs/scene.md, "Walls").

Runs the paper geometry with three wall/friction variants for T_END s of shear and prints
v_phi / (Omega R_i) in the first 8 of 20 rings, averaged over frames t >= T_MIN (two
rotations, as in the paper), beside the paper's fit v0 = 0.645 Omega R_i, s = 0.0127 m.
The ring mean here is the quick centre-in-ring mean of the disks' v_phi (not the
area-weighted Eq. 3): enough to tell a band from slip.

    python workflows/wall_choice.py OUTDIR [VARIANT ...]    # SI units; ~5 min a variant
"""

import sys
from pathlib import Path

import numpy as np

from granavg.io.reader import DumpReader
from granavg.sim.scene import preset
from granavg.sim.simulate import simulate

T_END, T_MIN, RINGS = 160.0, 125.0, 20
VARIANTS = {
    "ring0.5-mu0.5": ["wall_spacing=0.5", "mu=0.5", "mu_wall=0.5"],
    "ring0.9-mu0.5": ["wall_spacing=0.9", "mu=0.5", "mu_wall=0.5"],
    "ring0.9-mu0.8": ["wall_spacing=0.9", "mu=0.8", "mu_wall=0.8"],
}


def ring_profile(run: Path, scene) -> np.ndarray:
    """Mean v_phi / (Omega R_i) of the disks whose centre is in each ring, t >= T_MIN."""
    edges = np.linspace(scene.R_i, scene.R_o, RINGS + 1)
    total, count = np.zeros(RINGS), np.zeros(RINGS)
    dt = scene.derive().dt
    for frame in DumpReader(run / "atoms.dump.gz"):
        if frame.timestep * dt < T_MIN:
            continue
        x, y, vx, vy = (frame.column(c) for c in ("x", "y", "vx", "vy"))
        r = np.hypot(x, y)
        ring = np.clip(np.searchsorted(edges, r) - 1, 0, RINGS - 1)
        total += np.bincount(ring, (x * vy - y * vx) / r, RINGS)
        count += np.bincount(ring, minlength=RINGS)
    return total / count / (scene.Omega * scene.R_i)


def main(out, names):
    base = preset("paper-hooke")
    centres = base.R_i + (np.arange(8) + 0.5) * (base.R_o - base.R_i) / RINGS
    print(f"{'paper fit':>14s} " + " ".join(
        f"{0.645 * np.exp(-(c - base.R_i) / 0.0127):.3f}" for c in centres))
    for name in names:
        scene = base.with_overrides([f"t_end={T_END}", "t_dump_start=60", "contacts=0",
                                     *VARIANTS[name]])
        run = Path(out) / name
        if not (run / "manifest.json").exists():
            simulate(scene, run, progress=False, preset="paper-hooke")
        print(f"{name:>14s} " + " ".join(f"{v:.3f}" for v in ring_profile(run, scene)[:8]))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:] or list(VARIANTS))
