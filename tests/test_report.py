"""Analysis, figures and report of a real (small) run, and degenerate input."""

import json

import matplotlib.image as mpimg
import numpy as np
import pandas as pd
import pytest

from granavg.analysis.claims import analyze
from granavg.analysis.figures import FIGURES, fig2, fig4
from granavg.io.profiles_io import read_profiles

from .conftest import run_cli


@pytest.fixture(scope="module")
def profiles(small_run, tmp_path_factory):
    d = tmp_path_factory.mktemp("profiles")
    for n in (8, 16):
        proc = run_cli("average", small_run, "--bins", n, "--t-min", 1, "--block-time", 0.5,
                       "--out", d / f"p{n}.csv", "--no-progress")
        assert proc.returncode == 0, proc.stderr
    return d / "p8.csv", d / "p16.csv"


@pytest.fixture(scope="module")
def report(profiles, tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "r"
    proc = run_cli("analyze", *profiles, "--out", out)
    assert proc.returncode == 0, proc.stderr
    return out


def test_every_figure_is_a_valid_image_in_png_and_pdf(report):
    for name in FIGURES:
        img = mpimg.imread(report / "figures" / f"{name}.png")
        assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 300
        assert (report / "figures" / f"{name}.pdf").read_bytes().startswith(b"%PDF")


def test_the_axes_hold_the_plotted_profiles(profiles):
    p8, p16 = (read_profiles(p) for p in profiles)
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    ax = fig2(p8, p16, summary)
    nu_lines = [ln for ln in ax[0].get_lines() if "nu (8 rings)" in ln.get_label()]
    assert len(nu_lines) == 1
    assert np.allclose(nu_lines[0].get_xdata(), p8.cells.centre)
    assert np.allclose(nu_lines[0].get_ydata(), p8.values["nu"])
    # 3 s of shear leave v_phi beyond the first layer within 2 errors of 0: no band fit
    assert not np.isfinite(summary["numbers"]["shear_band"]["s_m"])
    fit = [ln for ln in ax[1].get_lines() if ln.get_label().startswith("fit")]
    assert not fit and ax[1].get_yscale() == "log" and "Omega" in ax[1].get_ylabel()
    ax4 = fig4(p8, p16, summary)
    labels = [ln.get_label() for ln in ax4[0].get_lines()]
    assert "sigma_rphi (16 rings)" in labels
    line = next(ln for ln in ax4[0].get_lines() if ln.get_label() == "sigma_rphi (16 rings)")
    assert np.allclose(line.get_ydata(), p16.values["sigma_rphi"])
    assert "(Pa)" in ax4[0].get_ylabel()


def test_report_and_summary_hold_the_headline_numbers(report):
    summary = json.loads((report / "summary.json").read_text())
    html = (report / "report.html").read_text()
    sb = summary["numbers"]["shear_band"]
    assert f"{sb['v0_over_omega_Ri']:.4g}" in html and f"{sb['s_m']:.4g}" in html
    assert "0.645" in html and "0.0127" in html                  # the paper's values beside
    assert len(summary["claims"]) == 14
    text = html.replace("&#x27;", "'")
    for claim in summary["claims"]:
        assert claim["claim"] in text and claim["evidence"] in text
    assert html.count("data:image/png;base64,") == len(FIGURES) + 1   # + Fig. 1; self-contained
    assert "src='http" not in html and 'src="http' not in html
    # the run table as a person writes it; no path of this machine in the summary
    assert "<th>packing</th><td>None" not in html and "grown linearly" in html
    assert "<th>averaged from t (s)</th><td>1</td>" in html
    strings = []

    def walk(x):
        if isinstance(x, dict):
            strings.extend(map(str, x))
            [walk(v) for v in x.values()]
        elif isinstance(x, list):
            [walk(v) for v in x]
        elif isinstance(x, str):
            strings.append(x)
    walk(summary)
    assert not [t for t in strings if "/tmp" in t or t.startswith("/")], strings
    # the speed/accuracy study's forecast: the small test cell is not the study's scene
    assert "accuracy class of the settings" in html and "not measured: the studies measured other scenes" in html


def test_a_band_that_cannot_be_fitted_leaves_its_numbers_undefined(profiles, tmp_path):
    """No flow, or an all-NaN v_phi on the finer profile: the report is made, the band's
    numbers are NaN, its claims inconclusive, and one warning says why."""
    p16 = pd.read_csv(profiles[1])
    for name, edit in (("noflow", lambda t: t.assign(v_phi=0.0)),
                       ("nan", lambda t: t.assign(v_phi=np.nan))):
        bad = tmp_path / f"{name}.csv"
        edit(p16).to_csv(bad, index=False)
        (tmp_path / f"{name}.csv.json").write_text((profiles[1].parent / "p16.csv.json").read_text())
        proc = run_cli("analyze", profiles[0], bad, "--out", tmp_path / f"out-{name}")
        assert proc.returncode == 0, proc.stderr
        assert proc.stderr.count("the shear band is not fitted") == 1
        assert "no decay to fit" in proc.stderr and "Traceback" not in proc.stderr
        assert "RuntimeWarning" not in proc.stderr
        summary = json.loads((tmp_path / f"out-{name}" / "summary.json").read_text())
        assert np.isnan(summary["numbers"]["shear_band"]["s_m"])
        verdicts = {c["claim"]: c["verdict"] for c in summary["claims"]}
        assert verdicts["decay length s within 15% of the paper's 12.7 mm"] == "inconclusive"


def test_a_single_ring_is_refused(small_run, tmp_path):
    one = tmp_path / "p1.csv"
    assert run_cli("average", small_run, "--bins", 1, "--t-min", 1, "--out", one,
                   "--no-progress").returncode == 0
    proc = run_cli("analyze", one, one, "--out", tmp_path / "r")
    assert proc.returncode == 2 and "at least 4 rings" in proc.stderr


@pytest.mark.parametrize("name", [n for n in FIGURES if n.startswith("fig")])
def test_every_panel_plots_both_ring_counts(profiles, name):
    p8, p16 = (read_profiles(p) for p in profiles)
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    axes = FIGURES[name](p8, p16, summary)
    for ax in axes:
        lengths = {len(ln.get_xdata()) for ln in ax.get_lines()
                   if np.isfinite(np.asarray(ln.get_ydata(), float)).any()}
        near_wall = name == "fig9"                   # only the rings near the inner wall
        assert near_wall or {8, 16} <= lengths, (name, ax.get_title(), lengths)
        assert lengths and ax.get_xlabel() and "(" in ax.get_ylabel()   # labelled with units
    axes[0].figure.clf()


def test_the_time_series_figure_shows_every_frame_and_the_window(profiles):
    p8, p16 = (read_profiles(p) for p in profiles)
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    axes = FIGURES["timeseries"](p8, p16, summary)
    n = len(p8.timeseries)
    t_min = p8.meta["frames"]["t_min_s"]
    for ax in axes:
        assert {len(ln.get_xdata()) for ln in ax.get_lines()} == {n}, ax.get_ylabel()
        shaded = [pt for pt in ax.patches if pt.get_label() == "averaged"]
        assert shaded and shaded[0].get_x() == pytest.approx(t_min)
        assert ax.get_xlabel() == "t (s)" and "(" in ax.get_ylabel()
    axes[0].figure.clf()


def test_fig1_draws_every_disk_and_every_contact_in_thirds(small_run, tmp_path):
    """Fig. 1 from the run's dumps: one patch per disk, coloured by its stripe at the
    first frame; one segment per disk-disk contact, a third of them in each colour."""
    from granavg.pipeline.runs import run_averager
    from granavg.analysis.figures import fig1

    frames = list(run_averager(small_run, quantities=["nu", "sigma"]).frames)
    first, last = frames[0], frames[-1]
    m = json.loads((small_run / "manifest.json").read_text())["scene"]
    ax = fig1(first.atoms, last.atoms, last.contacts, m["R_i"], m["R_o"])
    assert len(ax[0].collections[0].get_paths()) == len(last.atoms["x"])
    colours = {tuple(c) for c in ax[0].collections[0].get_facecolors()}
    assert len(colours) == 2                                   # alternating stripes
    n_pairs = int(np.sum(last.contacts["wall"] == 0))
    counts = [len(c.get_segments()) for c in ax[1].collections]
    assert sum(counts) == n_pairs and max(counts) - min(counts) <= 2
    assert ax[0].get_aspect() == 1.0 and ax[0].get_xlabel() == "x (m)"
    ax[0].figure.clf()


def test_the_report_of_a_run_includes_fig1(report):
    assert (report / "figures" / "fig1.png").exists() and (report / "figures" / "fig1.pdf").exists()


def test_a_shipped_packings_description_names_no_path_of_the_machine_that_made_it():
    from granavg.sim import packings
    text = packings.describe("rolling-coulomb-sheared", 20011)
    assert "sheared 150 s" in text and "workflows/sheared_packings.py OUT" in text
    assert not [w for w in text.split() if w.startswith("/")], text
