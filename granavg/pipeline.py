"""End to end: profiles -> analysis -> figures -> report, and the demo (SI units)."""

from __future__ import annotations

import logging
from pathlib import Path

from .analysis import analyze
from .average import RingProfiles, average_run
from .errors import UserError
from .figures import save_all
from .report import write_report, write_summary

log = logging.getLogger(__name__)


def report_profiles(coarse: RingProfiles, fine: RingProfiles, out, title="granavg report") -> dict:
    """Analyse two ring profiles of one run and write figures, summary.json, report.html."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = (coarse.meta or {}).get("run_manifest")
    if manifest is None:
        raise UserError("the profiles carry no run manifest; make them with 'granavg average'")
    if coarse.rings.n > fine.rings.n:
        coarse, fine = fine, coarse
    summary = analyze(coarse, fine, manifest)
    figures = save_all(coarse, fine, summary, out / "figures")
    write_summary(summary, out / "summary.json")
    write_report(summary, figures, out / "report.html", title)
    log.info("report: %s", out / "report.html")
    return summary


def report_run(run_dir, out, bins=(20, 60), t_min=None, progress=None, title="granavg report"):
    """Average a run over two ring counts, then :func:`report_profiles`."""
    out = Path(out)
    profiles = []
    for n in bins:
        p = average_run(run_dir, bins=n, t_min=t_min, progress=progress)
        p.write(out / f"profiles{n}.csv")
        profiles.append(p)
    return report_profiles(*profiles, out, title)
