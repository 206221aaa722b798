"""The ``rheology`` command: field tables of ``granavg average`` -> their local rheology
(:func:`granavg.pipeline.api.rheology`, the API's one path) written as profile tables,
the fits mu(I) and phi(I) across all of them in ``fits.json``, and their figure
(docs/rheology.md)."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from granavg.analysis import rheology as rh
from granavg.analysis.rounding import pm
from granavg.io.profiles_io import write_profiles
from granavg.pipeline import api
from granavg.pipeline.reporting import new_directory, staged_directory

log = logging.getLogger(__name__)


def table_names(paths) -> list:
    """The output table of each input: its file name (``p8.csv``; a Parquet input's as
    ``.csv``), numbered where two inputs share one."""
    names = [Path(p).with_suffix(".csv").name for p in paths]
    return [f"{k + 1}-{n}" if names.count(n) > 1 else n for k, n in enumerate(names)]


def rheology_command(paths, out, *, figures=True, **material) -> Path:
    """The ``rheology`` command -> ``out/`` (new or empty; written only when complete):
    one table per input (the rheology's columns, errors, flags, its sidecar and
    replicates), ``fits.json`` (mu(I) and phi(I) over every input's cells, or why a fit
    could not be made) and ``fits.png`` / ``.pdf``.

    Parameters
    ----------
    paths : sequence of path
        Tables of ``granavg average`` (with their sidecars and replicates).
    out : path
    figures : bool
        Draw the fits.
    **material
        ``diameter`` and ``density``: d_p and rho_p of I (default: each table's
        sidecar).

    Returns
    -------
    Path
        ``out/fits.json``.
    """
    out = new_directory(out)
    results = [api.rheology(p, **material) for p in paths]
    names = table_names(paths)
    fits, summary = rh.fit_laws(results, labels=names), {"sources": [], "units": {}}
    for path, name, res in zip(paths, names, results):
        meta = res.meta["rheology"]
        summary["sources"].append({"fields": str(path), "table": name,
                                   "diameter": meta.get("diameters", meta["diameter"]),
                                   "density": meta["density"], "from": meta["from"]})
    summary["units"] = {c: u for c, u in results[0].units.items() if c in rh.COLUMNS}
    for key in ("mu_I", "phi_I"):
        fit = fits[key]
        summary[key] = fit.to_dict() if isinstance(fit, rh.Fit) else {"error": fit}
        if not isinstance(fit, rh.Fit):
            log.warning("no fit: %s", fit)
    with staged_directory(out) as tmp:
        for res, name in zip(results, names):
            write_profiles(res, tmp / name)
        (tmp / "fits.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
        made = {k: f for k, f in fits.items() if isinstance(f, rh.Fit)}
        if figures and made:
            import matplotlib.pyplot as plt

            axes = rh.plot_fits(made.get("mu_I"), made.get("phi_I"))
            for ext in ("png", "pdf"):
                axes[0].figure.savefig(tmp / f"fits.{ext}", dpi=130)
            plt.close(axes[0].figure)
    _log_summary(paths, results, [f for f in fits.values() if isinstance(f, rh.Fit)])
    log.info("rheology: %s", out)
    return out / "fits.json"


def _log_summary(paths, results, fits) -> None:
    """A few lines: each table's cells with an inertial_number and their flags, each fit's
    parameters."""
    for path, res in zip(paths, results):
        one = res.of(rh.MIXTURE) if res.species is not None else res
        flagged = {f: sum(f in str(x).split(";") for x in one.flags) for f in rh.FLAGS}
        said = ", ".join(f"{f} {n}" for f, n in flagged.items() if n)
        defined = int(np.sum(np.isfinite(one.values["inertial_number"])))
        log.info("%s: %d of %d cells with inertial_number and friction%s", path, defined,
                 one.cells.n, f" ({said})" if said else "")
    for fit in fits:
        shown = ", ".join(f"{k} = {pm(v, fit.errors[k])}" for k, v in fit.params.items())
        creep = sum(len(c) for c in fit.nonlocal_cells.values())
        log.info("%s: %s; chi^2/dof %.3g (%d dof)%s", fit.law.name, shown, fit.chi2_dof,
                 fit.dof, f"; {creep} nonlocal cells left out" if creep else "")
