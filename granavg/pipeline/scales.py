"""The ``scales`` command: a scale study of one run (or ensemble) or of anyone's dumps -
the same frames averaged with the exact weights and with a smoothing kernel at several
widths (in mean diameters), each field's change from one width to the next against
its error, the plateau where it stops depending on the width
(:mod:`granavg.analysis.scales`), written as one set: the table, a JSON summary and the
figure (:func:`granavg.analysis.figures.fig_scales`)."""

from __future__ import annotations

import json
import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from granavg.analysis.scales import FLAT, plateau, steps
from granavg.engine import smoothing
from granavg.engine.smoothing import get
from granavg.errors import ParameterError
from granavg.io import formats, validate
from granavg.io.output_set import OutputSet
from granavg.io.profiles_io import write_csv
from granavg.io.run_directory import read_manifest
from granavg.pipeline import api
from granavg.pipeline.runs import chosen_sectors
from granavg.pipeline.spec import Source, Spec

log = logging.getLogger(__name__)

#: The fields drawn by default: the density, then the first three of these present.
DRAWN = ("v_phi", "v_x", "omega", "omega_z", "sigma_rphi", "sigma_zz", "sigma_yy",
         "sigma_xy", "dsigma_fluct_phiphi")

#: The format's options that read the first frame's diameters.
_SOURCE = ("atom_map", "wall_types", "dt", "units", "dim")


def diameters(source: Source) -> tuple:
    """The particles' mean diameter and smallest radius: of a run's scene (its
    manifest's counts and diameters), or over the first frame with particles of the
    dumps."""
    if source.runs:
        scene = read_manifest(validate.run_directory(source.runs[0]))["scene"]
        n = np.array([scene["n_small"], scene["n_large"]], float)
        d = np.array([scene["d_s"], scene["d_l"]])
        return float(n @ d / n.sum()), float(0.5 * d[n > 0].min())
    options = {k: source.options[k] for k in _SOURCE if k in source.options}
    for frame in formats.open_frames(source.atoms, None, fmt=source.fmt, **options):
        a = np.asarray(frame.atoms["radius"], float)
        if len(a):
            return float(2.0 * a.mean()), float(a.min())
    raise ParameterError("atoms", "{param}: no frame holds particles")


def scale_study(spec: Spec, *, widths, diameter=None):
    """The exact weights' profiles and the kernel's at each width.

    Parameters
    ----------
    spec : Spec
        The average (:class:`~granavg.pipeline.spec.Spec`: run directories, one run or
        an ensemble, or anyone's dumps), its kernel the study's
        (:mod:`granavg.engine.smoothing`; default its ``DEFAULT``), its width unset.
    widths : sequence of float
        Kernel widths in mean diameters, increasing.
    diameter : float, optional
        The mean diameter (length unit of the data); default :func:`diameters`.

    Returns
    -------
    exact : Fields
    profiles : list of Fields, one per width
    diameter : float
    """
    kernel = spec.kernel or smoothing.DEFAULT
    if kernel == smoothing.EXACT:
        raise ParameterError("kernel", f"{{param}} {kernel} has no width: a scale study "
                             f"needs a smoothing kernel ({smoothing.names()})")
    widths = [float(w) for w in widths]
    if any(b <= a for a, b in zip(widths, widths[1:])) or widths[0] <= 0:
        raise ParameterError("widths", f"{{param}} {' '.join(f'{w:g}' for w in widths)}: "
                             "give positive widths in increasing order")
    validate.positive("diameter", diameter)
    if not spec.source.runs:
        if not spec.source.atoms:
            raise ParameterError("atoms", "give a run directory, or a LAMMPS dump with "
                                 "{param} (and {contacts})")
        validate.existing_file("atoms", spec.source.atoms)
        validate.existing_file("contacts", spec.source.contacts)
    get(kernel)                                     # an unknown name refused here
    mean, smallest = diameters(spec.source)
    d = diameter or mean
    if widths[0] * d < 0.5 * smallest:              # refused before any work
        raise ParameterError("widths", f"{{param}} {widths[0]:g}: {widths[0]:g} d = "
                             f"{widths[0] * d:g} is below half the smallest particle radius "
                             f"({smallest:g}), where the fields resolve single particles; "
                             f"start at {0.5 * smallest / d:.3g} d or more")

    exact = api.run(replace(spec, kernel="exact", width=None))
    same = replace(spec.averaging, sectors=chosen_sectors(exact, spec.averaging.sectors))
    profiles = []                                                   # the same replicas
    for f in widths:
        log.info("%s kernel, w = %g d = %g", kernel, f, f * d)
        profiles.append(api.run(replace(spec, kernel=kernel, width=f * d, averaging=same)))
    return exact, profiles, d


def scale_study_to_file(spec: Spec, out, *, widths, diameter=None, fields=None) -> Path:
    """The ``scales`` command: :func:`scale_study` written to ``out`` (table, one row per
    width and cell, the exact weights' rows first with width 0, empty in the columns
    only a kernel gives: the gradients), ``<out>.json`` (the diameter, widths, each
    field's steps and plateau) and ``<out>.png`` / ``.pdf``."""
    kernel = spec.kernel or smoothing.DEFAULT
    from granavg.analysis import figures          # matplotlib, only where drawn

    out = validate.free_output(Path(out), ("", ".json", ".png", ".pdf"))
    exact, profiles, d = scale_study(spec, widths=widths, diameter=diameter)
    names = list(profiles[0].values)         # the gradients too: the exact rows leave them
    drawn = fields or (["nu"] + [n for n in DRAWN if n in names][:3])
    missing = [n for n in drawn if n not in names]
    if missing:
        raise ParameterError("fields", f"{{param}} {','.join(missing)}: not among the "
                             f"profiles' columns ({', '.join(names)})")
    width = [f * d for f in widths]
    cut = [get(kernel).cutoff(w) for w in width]
    judged = steps(width, profiles, cut, names)
    flat = {n: plateau(rows) for n, rows in judged.items()}
    units = (exact.meta.get("unit_system") or {}).get("length", "m")
    table = _table([0.0] + list(widths), [exact] + profiles, d, names)
    summary = {"kernel": kernel, "diameter": d, "length_unit": units,
               "widths_in_diameters": list(widths), "widths": width,
               "n_frames": exact.n_frames, "errors": exact.meta.get("errors", {}).get("kind"),
               "flat_sigmas": FLAT,
               "fields": {n: {"plateau": flat[n], "steps": judged[n]} for n in names}}
    with OutputSet(out) as outputs:
        of = profiles[0].units
        ax = figures.fig_scales(widths, d, profiles, exact, drawn, flat, unit=units,
                                units={n: of[n] for n in drawn})
        fig = ax[0].figure
        fig.savefig(outputs.temp(".png"), dpi=130, format="png")
        fig.savefig(outputs.temp(".pdf"), format="pdf")
        figures.plt.close(fig)
        outputs.temp(".json").write_text(json.dumps(summary, indent=2) + "\n")
        write_csv(outputs.temp(""), table, "%.10g")
        outputs.commit()
    for n in drawn:
        span = flat[n]
        log.info("%s: %s", n, f"no dependence on w from {span[0] / d:g} d to "
                 f"{span[1] / d:g} d" if span else "depends on w at every step")
    log.info("%d widths x %d %s -> %s (+ .json, .png, .pdf)", len(widths),
             exact.cells.n, exact.cells.kind, out)
    return out


def _table(widths_d, profiles, d, names) -> dict:
    """Columns: width_d, width, the cells' coordinates, each value and its error."""
    cols = {"width_d": np.repeat(widths_d, [p.cells.n for p in profiles])}
    cols["width"] = cols["width_d"] * d
    for key in profiles[0].cells.coordinates():
        cols[key] = np.concatenate([p.cells.coordinates()[key] for p in profiles])
    for n in names:
        for key, of in ((n, "values"), (f"{n}_sem", "sem")):
            cols[key] = np.concatenate([getattr(p, of).get(n, np.full(p.cells.n, np.nan))
                                        for p in profiles])
    return cols
