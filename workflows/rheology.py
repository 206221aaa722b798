"""mu(I) and phi(I) from two sweeps of our own decks, each fitted with errors from the
runs' replicates, and compared (docs/rheology.md):

1. the chute sweep: lammps_inputs/chute_3d.lmp (1000 spheres, 13.6 d deep, rough base)
   at 21 to 26 degrees, 40 frames over 2 s after 4 s of flow; slabs 1 d thick across z;
   per angle the stress ratio -S_xz / S_zz at every bulk depth against tan(theta) (the
   momentum balance of steady uniform flow) and mu there against tau / P from the stress
   components by hand;
2. the simple-shear sweep: lammps_inputs/shear_2d.lmp (500 disks, Lees-Edwards) at area
   fraction 0.83 and rates 1 to 100 /s, 25 frames over a strain of 5 after 3; 4 slabs
   across y;
3. mu(I) and phi(I) fitted to each sweep (Jop et al. 2006; phi_max - a I), and the two
   fits compared where their I overlap.

Both decks share the contact law (pair gran/hooke/history, kn 1000 N/m, en 0.5,
mu 0.5, d 2 mm, rho 2500 kg/m^3); the chute's particles are spheres, the shear's disks.

    python workflows/rheology.py OUT [--angles 21 22 ...] [--rates 1 3 ...] [--jobs 2]

Runs are kept in OUT/chute_THETA and OUT/shear_RATE (a run whose dumps are there is not
run again); OUT/rheology.md holds the tables, OUT/mu_I.png and OUT/phi_I.png the figures,
OUT/fits.json the fits.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import granavg
from granavg.analysis.rheology import fit_mu_I, fit_phi_I, plot_fit
from granavg.sim.lammps_session import lammps_session

DECKS = Path(__file__).resolve().parents[1] / "lammps_inputs"
D, RHO, G = 0.002, 2500.0, 9.81
MAP2 = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
        "ftx=c_pl[5],fty=c_pl[6]")
MAP3 = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
        "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]")
ANGLES = (21, 22, 23, 24, 25, 26)
#: The decks' normal spring (N/m): the stiffness number kn / (P d) says how rigid.
KN = 1000.0
RATES = (1, 3, 10, 30, 100)
PHI = 0.83
#: Bulk slabs of the chute: at least this many diameters from the base and the surface.
SKIN = 3
log = logging.getLogger("rheology")


def _map(text: str) -> dict:
    return dict(kv.split("=") for kv in text.split(","))


def run_deck(deck: str, out: Path, **variables) -> Path:
    """Run ``deck`` into ``out`` (skipped where its dumps are there)."""
    if (out / "contacts.dump").exists():
        return out
    out.mkdir(parents=True, exist_ok=True)
    args = ["-log", str(out / "log.lammps"), "-screen", "none", "-var", "out", str(out)]
    for k, v in variables.items():
        args += ["-var", k, str(v)]
    with lammps_session(args, log_hint=str(out / "log.lammps")) as lmp:
        lmp.file(str(DECKS / deck))
    return out


def _job(job):
    deck, out, variables = job
    return run_deck(deck, Path(out), **variables)


def gravity(theta: float) -> tuple:
    t = math.radians(theta)
    return (G * math.sin(t), 0.0, -G * math.cos(t))


def chute_fields(run: Path, theta: float):
    """Slabs 1 d thick across z over the layer (the base at z = 0), with the tilted
    gravity."""
    top = 20 * D
    return granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                           contact_map=_map(MAP3), wall_types=[2], gravity=gravity(theta),
                           cells={"slabs": "z", "bins": 20, "range": (0.0, top)},
                           progress=False)


def bulk(fields) -> np.ndarray:
    """The chute's bulk slabs: at least :data:`SKIN` d above the base and below the
    surface (the highest slab whose nu is half the layer's largest)."""
    z_lo = fields.cells.edges[:-1]
    z_hi = fields.cells.edges[1:]
    nu = fields.values["nu"]
    full = np.flatnonzero(nu >= 0.5 * np.nanmax(nu))
    surface = z_hi[full[-1]]
    return (z_lo >= SKIN * D) & (z_hi <= surface - SKIN * D)


def stress_ratio(fields) -> tuple:
    """-S_xz / S_zz per slab (S = sigma - dsigma_fluct, symmetrised) and its error from
    the fields' replicates."""
    def ratio(v):
        sxz = 0.5 * (v["sigma_xz"] + v["sigma_zx"]) - 0.5 * (v["dsigma_fluct_xz"]
                                                           + v["dsigma_fluct_zx"])
        szz = v["sigma_zz"] - v["dsigma_fluct_zz"]
        return -sxz / szz
    value = ratio(fields.values)
    reps = fields.replicates
    each = ratio(reps.values)
    return value, np.array([reps.error(each[:, k]) for k in range(len(value))])


def friction_by_hand(fields) -> np.ndarray:
    """tau / P from the stress components (3D): S = sym(sigma - dsigma_fluct),
    P = -tr S / 3, tau = sqrt(s:s / 2)."""
    v = fields.values
    S = np.array([[v[f"sigma_{a}{b}"] - v[f"dsigma_fluct_{a}{b}"] for b in "xyz"]
                  for a in "xyz"])
    S = 0.5 * (S + S.transpose(1, 0, 2))
    P = -np.trace(S) / 3
    s = S + P * np.eye(3)[:, :, None]
    return np.sqrt(0.5 * np.sum(s * s, axis=(0, 1))) / P


def only(rheo, keep: np.ndarray):
    """The rheology with the cells outside ``keep`` undefined (NaN): the points a fit
    takes."""
    for name in ("friction", "inertial_number", "nu"):
        rheo.values[name] = np.where(keep, rheo.values[name], np.nan)
        if rheo.replicates is not None:
            rheo.replicates.values[name] = np.where(keep, rheo.replicates.values[name],
                                                    np.nan)
    return rheo


def shear_fields(run: Path):
    return granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                           contact_map=_map(MAP2), cells={"slabs": "y", "bins": 4,
                                                          "thickness": D},
                           progress=False)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path)
    p.add_argument("--angles", type=float, nargs="+", default=ANGLES)
    p.add_argument("--rates", type=float, nargs="+", default=RATES)
    p.add_argument("--jobs", type=int, default=2, help="decks run at once (one core each)")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    out = a.out
    out.mkdir(parents=True, exist_ok=True)
    jobs = [("chute_3d.lmp", str(out / f"chute_{t:g}"), {"theta": t}) for t in a.angles]
    jobs += [("shear_2d.lmp", str(out / f"shear_{r:g}"),
              {"phi": PHI, "rate": r, "settle": 3, "strain": 5, "frames": 25})
             for r in a.rates]
    with ProcessPoolExecutor(a.jobs) as pool:
        list(pool.map(_job, jobs))

    lines = ["# mu(I) and phi(I) of the chute and simple-shear sweeps", "",
             f"`python workflows/rheology.py OUT` (d = {D} m, rho_p = {RHO:g} kg/m^3; "
             "errors from each run's replicates)", ""]
    chutes, labels = [], []
    lines += ["## The chute sweep: momentum balance and friction by hand", "",
              "| theta | tan theta | bulk slabs | -S_xz/S_zz, range over the bulk | "
              "largest |ratio - tan theta| / error | largest |mu - tau/P by hand| | "
              "I over the bulk | kn / (P d) over the bulk |", "|---|---|---|---|---|---|---|---|"]
    for t in a.angles:
        f = chute_fields(out / f"chute_{t:g}", t)
        rheo = granavg.rheology(f, diameter=D, density=RHO)
        inner = bulk(f)
        r, e = stress_ratio(f)
        tan = math.tan(math.radians(t))
        off = np.abs(r[inner] - tan) / e[inner]
        by_hand = np.abs(rheo.values["friction"][inner] - friction_by_hand(f)[inner])
        I = rheo.values["inertial_number"][inner]
        flowing = np.isfinite(I).any()
        lines.append(f"| {t:g} | {tan:.4f} | {inner.sum()} | {r[inner].min():.4f} - "
                     f"{r[inner].max():.4f} | {off.max():.2f} | {np.nanmax(by_hand):.1e} | "
                     + (f"{np.nanmin(I):.3f} - {np.nanmax(I):.3f} |" if flowing else
                        "stopped: no shear rate |")
                     + f" {_stiffness(rheo, inner)} |")
        chutes.append(only(rheo, inner))
        labels.append(f"chute {t:g} deg")
    shears, slabels = [], []
    lines += ["", "## The simple-shear sweep (area fraction %.2f)" % PHI, "",
              "| rate 1/s | I | mu | nu | P (Pa) | kn / (P d) |",
              "|---|---|---|---|---|---|"]
    for r in a.rates:
        f = shear_fields(out / f"shear_{r:g}")
        rheo = granavg.rheology(f, diameter=D, density=RHO)
        v, s = rheo.values, rheo.sem
        lines.append(f"| {r:g} | {np.nanmean(v['inertial_number']):.4g} | "
                     f"{np.nanmean(v['friction']):.4f} +- {np.nanmean(s['friction']):.4f} | "
                     f"{np.nanmean(v['nu']):.4f} | {np.nanmean(v['pressure']):.4g} | "
                     f"{_stiffness(rheo, np.ones(rheo.cells.n, bool))} |")
        shears.append(rheo)
        slabels.append(f"shear {r:g}/s")

    fits = {"chute": {"mu(I)": fit_mu_I(chutes, labels=labels)},
            "shear": {"mu(I)": fit_mu_I(shears, labels=slabels)}}
    # the shear sweep holds one packing fraction (its volume is imposed): no phi(I)
    fits["chute"]["phi(I)"] = fit_phi_I(chutes, labels=labels, exclude=fits["chute"]["mu(I)"])
    lines += ["", "## Fits (errors from the runs' replicates, the runs independent)", "",
              "| sweep | law | parameters | chi2/dof |", "|---|---|---|---|"]
    for name, laws in fits.items():
        for law, fit in laws.items():
            ps = ", ".join(f"{k} = {fit.params[k]:.4g} +- {fit.errors[k]:.2g}"
                           + (" (at its bound: not determined)" if _at_bound(fit, k) else "")
                           for k in fit.params)
            lines.append(f"| {name} | {law} | {ps} | {fit.chi2_dof:.2f} |")
    lines += ["", "## Where the sweeps' I overlap", ""]
    lines += _overlap(fits["chute"]["mu(I)"], fits["shear"]["mu(I)"])
    (out / "rheology.md").write_text("\n".join(lines) + "\n")
    (out / "fits.json").write_text(json.dumps(
        {n: {k: f.to_dict() for k, f in laws.items()} for n, laws in fits.items()},
        indent=1, default=float))
    _figures(out, fits)
    log.info("wrote %s", out / "rheology.md")


def _stiffness(rheo, keep) -> str:
    """kn / (P d) over the cells ``keep`` (2D: P d h with h = d): the rigid limit is
    large (the overlaps are about its inverse of d)."""
    k = KN / (rheo.values["pressure"][keep] * D)
    return f"{np.nanmin(k):.3g} - {np.nanmax(k):.3g}" if len(k) > 1 else f"{k[0]:.3g}"


def _at_bound(fit, name) -> bool:
    """Whether a parameter sits at its lower bound (the data do not determine it)."""
    lower = dict(zip(fit.law.params, fit.law.lower))[name]
    return bool(np.isfinite(lower) and fit.params[name] <= lower + 1e-9 * max(1.0,
                                                                              abs(lower)))


def _range(fit) -> tuple:
    x = np.concatenate([p.x[p.used] for p in fit.points])
    return float(np.min(x)), float(np.max(x))


def _overlap(chute, shear) -> list:
    """The two mu(I) fits compared over the I both sweeps reach: their difference at the
    ends of the overlap, in units of its error (each fit's from its replicates: refits
    on each source's replicates)."""
    lo = max(_range(chute)[0], _range(shear)[0])
    hi = min(_range(chute)[1], _range(shear)[1])
    if not lo < hi:
        # the shear run of the highest I (its cells' mean; their errors correlated,
        # so the mean error) against the chute's fit extrapolated down to it
        top = max(shear.points, key=lambda p: np.nanmean(p.x[p.used]))
        I, mu = float(np.mean(top.x[top.used])), float(np.mean(top.y[top.used]))
        e_mu = float(np.mean(top.sy[top.used]))
        diff = float(chute(I)) - mu
        err = float(np.hypot(_law_error(chute, I), e_mu))
        return [f"The sweeps do not overlap in I (chute {_range(chute)[0]:.3g} - "
                f"{_range(chute)[1]:.3g}, shear {_range(shear)[0]:.3g} - "
                f"{_range(shear)[1]:.3g}). The shear run of the highest I ({top.label}): "
                f"I = {I:.3g}, mu = {mu:.4f} +- {e_mu:.4f}; the chute's fit extrapolated "
                f"down to it by {1 - I / _range(chute)[0]:.0%}: {float(chute(I)):.4f} +- "
                f"{_law_error(chute, I):.4f}; difference {diff:+.4f} = {diff / err:+.1f} "
                "errors (the fit's error from its parameters' errors taken as "
                "independent)."]
    out = []
    for I in (lo, hi):
        diff = float(chute(I) - shear(I))
        err = float(np.hypot(_law_error(chute, I), _law_error(shear, I)))
        out.append(f"- I = {I:.3g}: chute {float(chute(I)):.4f}, shear "
                   f"{float(shear(I)):.4f}, difference {diff:+.4f} = {diff / err:+.1f} "
                   "errors")
    return out


def _law_error(fit, I) -> float:
    """The law's error at I from its parameters' errors, taken as independent (an
    estimate: their correlation is not kept)."""
    p = np.array(list(fit.params.values()))
    e = np.array(list(fit.errors.values()))
    grad = []
    for k in range(len(p)):
        h = 1e-6 * max(abs(p[k]), 1e-9)
        q = p.copy()
        q[k] += h
        grad.append((fit.law.f(np.asarray(I), *q) - fit.law.f(np.asarray(I), *p)) / h)
    return float(np.sqrt(np.sum((np.array(grad) * e) ** 2)))


def _figures(out: Path, fits) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for law, name in (("mu(I)", "mu_I"), ("phi(I)", "phi_I")):
        fig, ax = plt.subplots(figsize=(6, 4))
        for sweep, laws in fits.items():
            if law in laws:
                plot_fit(laws[law], ax=ax)
        fig.tight_layout()
        fig.savefig(out / f"{name}.png", dpi=120)
        plt.close(fig)


if __name__ == "__main__":
    main()
