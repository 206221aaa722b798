"""Analysis, figures and report of a real (small) run, and degenerate input."""

import json
import re
from html import unescape
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pandas as pd
import pytest

import granavg
from granavg.paper.claims import analyze
from matplotlib.container import ErrorbarContainer

from granavg.analysis.figures import CAPTIONS, FIGURES, fig2, fig4, fig6
from granavg.paper.report import units_note, write_report
from granavg.analysis.rounding import pm
from granavg.io.profiles_io import read_profiles

from .conftest import run_cli
from .helpers import SCENE, profiles as helper_profiles


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


@pytest.mark.slow
def test_no_figures_gives_the_same_numbers_and_claims(report, profiles, tmp_path):
    """--no-figures: the same summary.json as the full report, a report.html that says
    it has no figures, and no figure written."""
    out = tmp_path / "r"
    proc = run_cli("analyze", *profiles, "--out", out, "--no-figures")
    assert proc.returncode == 0, proc.stderr
    assert (out / "summary.json").read_text() == (report / "summary.json").read_text()
    assert not (out / "figures").exists()
    assert "No figures" in (out / "report.html").read_text()
    assert "No figures" not in (report / "report.html").read_text()


@pytest.mark.slow
def test_every_figure_is_a_valid_image_in_png_and_pdf(report):
    for name in FIGURES:
        img = mpimg.imread(report / "figures" / f"{name}.png")
        assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 300
        assert (report / "figures" / f"{name}.pdf").read_bytes().startswith(b"%PDF")


def series(ax):
    """The labelled series of an axes: label -> (x, y, half heights of the error bars or
    None), of lines and of error bars alike."""
    out = {}
    for c in ax.containers:
        if isinstance(c, ErrorbarContainer):
            line, _, bars = c.lines
            err = None
            if c.has_yerr and bars:
                seg = bars[0].get_segments()
                err = np.array([0.5 * abs(s[1][1] - s[0][1]) if len(s) == 2 else np.nan
                                for s in seg])
            out[c.get_label()] = (line.get_xdata(), line.get_ydata(), err)
    for ln in ax.get_lines():
        if not ln.get_label().startswith("_"):
            out.setdefault(ln.get_label(), (ln.get_xdata(), ln.get_ydata(), None))
    return out


def test_the_axes_hold_the_plotted_profiles(profiles):
    """Figs. 2, 4 and 6 draw the profiles with their errors: a value's bar is its
    standard error (the replicates' for the derived orientations)."""
    p8, p16 = (read_profiles(p) for p in profiles)
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    ax = fig2(p8, p16, summary)
    x, y, err = series(ax[0])["nu (8 rings)"]
    assert np.allclose(x, p8.cells.centre) and np.allclose(y, p8.values["nu"])
    assert np.allclose(err, p8.sem["nu"])
    _, _, err = series(ax[1])["v_phi/(Omega r) (16 rings)"]
    omega = p16.meta["run_manifest"]["scene"]["Omega"]
    assert np.allclose(err, p16.sem["v_phi"] / (omega * p16.cells.centre))
    # 3 s of shear leave v_phi beyond the first layer within 2 errors of 0: no band fit
    assert not np.isfinite(summary["numbers"]["shear_band"]["s_m"])
    fit = [ln for ln in ax[1].get_lines() if ln.get_label().startswith("fit")]
    assert not fit and ax[1].get_yscale() == "log" and "Omega" in ax[1].get_ylabel()
    ax4 = fig4(p8, p16, summary)
    _, y, err = series(ax4[0])["sigma_rphi (16 rings)"]
    assert np.allclose(y, p16.values["sigma_rphi"])
    assert np.allclose(err, p16.sem["sigma_rphi"])
    assert "(Pa)" in ax4[0].get_ylabel()
    legend = ax4[0].get_legend().get_window_extent()       # under the axes, off the data
    assert legend.y1 <= ax4[0].get_window_extent().y0
    ax6 = fig6(p8, p16, summary)
    _, _, err = series(ax6[0])["phi_sigma (8 rings)"]
    assert err is not None and np.all(np.isfinite(err)) and np.all(err > 0)
    assert np.allclose(err, summary["series"]["errors_8"]["orientation_sigma"])


@pytest.mark.slow
def test_report_and_summary_hold_the_headline_numbers(report):
    summary = json.loads((report / "summary.json").read_text())
    html = (report / "report.html").read_text()
    sb = summary["numbers"]["shear_band"]
    # values rounded to their errors, the band's length in mm everywhere
    for key, f in (("v0_over_omega_Ri", 1.0), ("s_m", 1e3)):
        shown = pm(f * sb[key], f * sb[f"{key}_err"]).replace(" +- ", " &plusmn; ")
        assert shown in html, shown
    assert "<td>mm</td>" in html and "<td>m</td>" not in html
    assert "0.645" in html and "<td>12.7</td>" in html           # the paper's values beside
    assert len(summary["claims"]) == 15                          # 14 + the rheology's
    text = html.replace("&#x27;", "'")
    for claim in summary["claims"]:
        assert claim["claim"] in text
        assert claim["evidence"].replace("+-", "&plusmn;") in text
        assert claim["tolerance"] and f"<td>{claim['tolerance']}</td>" in text
    run_table = html.split("<h2>Run</h2>")[1].split("</table>")[0]
    entries = [c.split("</td>")[0] for c in run_table.split("<td>")[1:]]
    assert max(len(c.split(" <sup>")[0]) for c in entries) <= 70, entries
    # + Fig. 1 and the rheology's; self-contained
    assert html.count("data:image/png;base64,") == len(FIGURES) + 2
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


@pytest.mark.slow
def test_a_band_that_cannot_be_fitted_leaves_its_numbers_undefined(profiles, tmp_path):
    """No flow, or an all-NaN v_phi on the finer profile: the report is made, the band's
    numbers are NaN, its claims inconclusive, and one warning says why."""
    p16 = pd.read_csv(profiles[1])
    for name, edit in (("noflow", lambda t: t.assign(v_phi=0.0)),
                       ("nan", lambda t: t.assign(v_phi=np.nan))):
        bad = tmp_path / f"{name}.csv"
        edit(p16).to_csv(bad, index=False)
        (tmp_path / f"{name}.csv.json").write_text((profiles[1].parent / "p16.csv.json").read_text())
        proc = run_cli("analyze", profiles[0], bad, "--out", tmp_path / f"out-{name}",
                       "--no-figures")
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


@pytest.mark.slow
def test_the_report_of_a_run_includes_fig1(report):
    assert (report / "figures" / "fig1.png").exists() and (report / "figures" / "fig1.pdf").exists()


def test_a_shipped_packings_description_names_no_path_of_the_machine_that_made_it():
    from granavg.sim import packings
    text = packings.describe("rolling-coulomb-sheared", 20011)
    assert "sheared 150 s" in text and "workflows/sheared_packings.py OUT" in text
    assert not [w for w in text.split() if w.startswith("/")], text


@pytest.mark.slow
def test_the_report_of_anyones_dumps_labels_every_axis_with_its_unit(pile3d_soft, tmp_path):
    """``analyze`` of slab profiles of a user's 3D pile (no run manifest): every axis
    names its quantity and unit, each panel holds one unit (no power beside the force
    densities), and no two series of a panel look alike."""
    from granavg.analysis.fields import balance_panel, profile_panels
    from granavg.analysis.balance import balance

    out = tmp_path / "s.csv"
    cmap = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
            "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]")
    proc = run_cli("average", "--atoms", pile3d_soft / "atoms.dump", "--contacts",
                   pile3d_soft / "contacts.dump", "--contact-columns", cmap, "--slabs", "z",
                   "--range", 0, 0.024, "--bins", 12, "--gravity", 0, 0, -9.81, "--out", out,
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(out)
    units = p.meta["columns"]
    axes = [*profile_panels(p), balance_panel(p, balance(p, closed=False))]
    for ax in axes:
        assert ax.get_xlabel() == "z (m)", ax.get_xlabel()
        assert ax.get_ylabel().endswith(")") and "(" in ax.get_ylabel(), ax.get_ylabel()
        drawn = series(ax)
        labels = [k for k in drawn if k in units]
        assert len({units[k] for k in labels}) <= 1, labels          # one unit a panel
        looks = [(tuple(c.lines[0].get_color()) if not isinstance(c.lines[0].get_color(), str)
                  else c.lines[0].get_color(), c.lines[0].get_marker())
                 for c in ax.containers if isinstance(c, ErrorbarContainer)]
        assert len(looks) == len(set(looks)), ax.get_title()
    stress = next(a for a in axes if a.get_title() == "static stress")
    assert len(series(stress)) == 9 and stress.get_ylabel() == "static stress (Pa)"
    forces = next(a for a in axes if a.get_title() == "force densities")
    assert "body_power" not in series(forces) and forces.get_ylabel().endswith("(N/m^3)")
    proc = run_cli("analyze", out, "--out", tmp_path / "report")
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("name", list(FIGURES))
def test_no_axis_of_a_figure_lacks_its_quantity_and_unit(profiles, name):
    """Every axis of every figure of the paper's report (twin axes included) names its
    quantity with a unit in parentheses."""
    p8, p16 = (read_profiles(p) for p in profiles)
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    fig = np.atleast_1d(FIGURES[name](p8, p16, summary)).ravel()[0].figure
    for ax in fig.axes:
        if not ax.has_data():
            continue
        twin = len(ax.get_shared_x_axes().get_siblings(ax)) > 1     # its x axis is another's
        for label in (ax.get_ylabel(),) if twin else (ax.get_xlabel(), ax.get_ylabel()):
            assert "(" in label and label.endswith(")"), (name, ax.get_title(), label)
    fig.clf()


# -- the figures beside their claims, one sign for plus-minus, true units -----------------

def _html_text(page):
    """The report's HTML without its embedded images."""
    return re.sub(r"data:image/png;base64,[^']*", "", page)


def _figures_of(page):
    """(number, start, end, caption text) of every ``<figure>`` of a report, in order."""
    out = []
    for m in re.finditer(r"<figure id='figure-(\d+)'>(.*?)</figure>", page, re.S):
        cap = re.search(r"<figcaption>(.*?)</figcaption>", m.group(2), re.S)
        assert "<img" in m.group(2) and cap, m.group(0)[:200]
        out.append((int(m.group(1)), m.start(), m.end(),
                    unescape(re.sub(r"<[^>]+>", "", cap.group(1)))))
    return out


def _claim_rows(page):
    """(claim row's HTML, its start) of every row of the claims' tables."""
    claims = page.split("<h2>The paper's claims</h2>")[1].split("<h2>")[0]
    offset = page.index(claims)
    return [(m.group(0), offset + m.start())
            for m in re.finditer(r"<tr><td>.*?</tr>", claims, re.S)]


def check_figures_beside_their_claims(page, summary):
    """Every figure captioned with what it plots (not "Fig. N"), numbered in order,
    referenced outside itself, and each claim's figures referenced in its row and shown
    right after the table that holds it."""
    figures = _figures_of(page)
    assert len(figures) == page.count("<img")                 # every image a figure
    assert [n for n, *_ in figures] == list(range(1, len(figures) + 1))
    for n, start, end, caption in figures:
        text = re.sub(r"^Figure \d+\.\s*", "", caption)
        assert len(text) > 80 and not re.fullmatch(r"Figs?\. ?\d+.*", text), caption
        assert re.search(r"\((m|mm|Pa|1/s|1/m|deg|-|s|J)[,;) ]", text), caption
        outside = page[:start] + page[end:]
        assert f"href='#figure-{n}'>{n}</a>" in outside, n
    where = {n: start for n, start, _, _ in figures}
    rows = _claim_rows(page)
    assert len(rows) == len(summary["claims"])
    referenced = set()
    for claim, (row, at) in zip(summary["claims"], rows):
        numbers = [int(k) for k in re.findall(r"href='#figure-(\d+)'", row)]
        assert len(numbers) == len(claim.get("figures", ())), (claim["claim"], row[:300])
        if numbers:
            assert "(see Figure" in row
        for k in numbers:
            between = page[at:where[k]]
            assert where[k] > at and between.count("</table>") == 1, claim["claim"]
            assert "<table" not in between and "<h2>" not in between, claim["claim"]
        referenced.update(numbers)
    by_claims = {n for n, *_ in figures} - referenced
    assert len(by_claims) <= 2, by_claims          # Fig. 1 and the time series: sections'


def check_one_sign_and_true_units(page):
    """The report writes plus-minus one way (±), and says no "All quantities in SI"
    beside values in mm or degrees."""
    text = unescape(_html_text(page))
    assert "+-" not in text and "±" in text
    if re.search(r"(?<![\w/])(mm|deg)(?![\w/])", text):
        assert "All quantities in SI" not in text
        intro = text.split("<h2>")[0]
        for unit in ("mm", "deg"):
            if re.search(rf"(?<![\w/]){unit}(?![\w/])", text.split("<h2>", 1)[1]):
                assert f"{unit} (" in intro, unit


@pytest.mark.slow
def test_the_reports_figures_sit_beside_the_claims_they_show(report):
    """A real run's report: each figure after the claims it shows, with a caption that
    says what is plotted; one plus-minus sign; a true statement of the units."""
    summary = json.loads((report / "summary.json").read_text())
    page = (report / "report.html").read_text(encoding="utf-8")
    check_figures_beside_their_claims(page, summary)
    check_one_sign_and_true_units(page)
    assert "<h2>Figures</h2>" not in page


MANIFEST = {"scene": {**SCENE, "e_n": 0.9},
            "contact_law": {"k_n_N_per_m": 10.0, "mu": 0.5, "mu_wall": 0.5},
            "derived": {"t_c_s": 0.01, "dt_s": 1e-4, "t_end_s": 30.0}}


#: A mixture's section as :func:`granavg.pipeline.reporting._mixture` adds it.
MIXTURE = {"errors": {"band": 0.01, "rest": 0.005, "excess": 0.011}, "c_band": 0.21,
           "c_rest": 0.15, "excess": 0.06, "verdict": "segregates", "s_band_m": 0.006,
           "band_rings": 3, "bands": {"type1": {"s_m": 0.0061, "s_err": 0.0004},
                                      "type2": {"s_m": 0.0058, "s_err": 0.0005}}}
MIXTURE_CLAIM = {"claim": "the shear band segregates", "kind": "measured",
                 "verdict": "segregates", "tolerance": "3 standard errors of the excess",
                 "evidence": "large disks' area share 0.210 +- 0.010 in the band",
                 "reproduced": None, "note": "", "figures": ["mixture"]}


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A report of synthetic profiles (:func:`tests.helpers.profiles`) with a mixture's
    section and every figure drawn as a small blank image: (html, summary)."""
    d = tmp_path_factory.mktemp("synthetic")
    summary = analyze(helper_profiles(20), helper_profiles(60), MANIFEST)
    summary["mixture"] = MIXTURE
    summary["claims"].append(MIXTURE_CLAIM)
    png = d / "blank.png"
    mpimg.imsave(png, np.zeros((4, 4)))
    drawn = {n: png for n in ("fig1", *FIGURES, "mixture")}
    path = write_report(summary, drawn, d / "report.html")
    return path.read_text(encoding="utf-8"), summary


def test_each_figure_follows_its_claims_with_a_caption(synthetic):
    page, summary = synthetic
    check_figures_beside_their_claims(page, summary)
    assert page.count("<figure ") == len(FIGURES) + 2
    pairs = re.findall(r"<figure id='figure-(\d+)'><img alt='[^']*the paper&#x27;s Fig\. "
                       r"(\d)[,)]", page)
    assert [int(a) for a, _ in pairs] == [int(b) for _, b in pairs] == list(range(1, 10))
    mixture = page.split("<h2>The mixture</h2>")[1]
    assert "The band's profiles (see Figure" in mixture and "&plusmn;" in mixture
    row = next(r for r, _ in _claim_rows(page) if "eigen-rotation alternates" in r)
    assert re.search(r"\(see Figures <a[^>]*>\d+</a> and <a[^>]*>\d+</a>\)", row), row


def test_the_report_writes_plus_minus_one_way_and_its_units_truly(synthetic):
    page, _ = synthetic
    check_one_sign_and_true_units(page)
    assert "mm (millimetres)" in page and "deg (degrees)" in page


def test_a_report_without_figures_refers_to_none(tmp_path):
    summary = analyze(helper_profiles(20), helper_profiles(60), MANIFEST)
    page = write_report(summary, {}, tmp_path / "r.html").read_text(encoding="utf-8")
    assert "<figure" not in page and "see Figure" not in page and "No figures" in page
    check_one_sign_and_true_units(page)


def test_the_unit_statement_names_the_units_shown():
    assert "All quantities in SI" in units_note("<td>Pa</td><td>m</td>")
    for body in ("<td>mm</td>", "s = 12.7 mm (statistical)", "angle 3.1 deg,"):
        note = units_note(body)
        assert "All quantities in SI" not in note and "except" in note, body
    assert "mm" not in units_note("<img src='data:image/png;base64,+mm/deg+'>")


def test_every_figure_has_a_caption():
    assert set(FIGURES) | {"fig1", "mixture"} <= set(CAPTIONS)
    for title, text in CAPTIONS.values():
        assert title and len(text) > 80 and "(" in text


@pytest.mark.slow
def test_the_reports_rheology_is_the_apis_and_the_command_lines(report, profiles, tmp_path):
    """The report's per-ring rheology (summary.json) is what granavg.rheology and
    `granavg rheology` give for the same coarse rings (the table to its 10 digits);
    undefined rings are NaN and flagged alike."""
    summary = json.loads((report / "summary.json").read_text())
    rings = summary["numbers"]["rheology"]["per_ring"]
    coarse = Path(profiles[0])                          # the report's coarse rings
    api = granavg.rheology(coarse)
    out = tmp_path / "rh"
    assert run_cli("rheology", coarse, "--out", out, "--no-figures").returncode == 0
    cli = granavg.read(out / coarse.name)
    for name in ("inertial_number", "friction", "nu"):
        got = np.array(rings[name], float)
        assert np.allclose(got, api.values[name], rtol=1e-12, atol=0, equal_nan=True), name
        assert np.allclose(got, cli.values[name], rtol=1e-9, atol=0, equal_nan=True), name
        assert np.allclose(np.array(rings[f"{name}_err"], float), api.sem[name], rtol=1e-12,
                           atol=0, equal_nan=True), name
    assert rings["flags"] == [str(f) for f in api.flags]
