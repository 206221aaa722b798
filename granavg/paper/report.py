"""The self-contained report: ``report.html`` (figures embedded) and ``summary.json``."""

from __future__ import annotations

import base64
import html
import json
import logging
import math
import re
from pathlib import Path

from granavg.paper.verdicts import PAPER
from granavg.analysis.figures import CAPTIONS
from granavg.analysis.rounding import plain, pm
from granavg.engine.stationarity import DRIFT_Z

log = logging.getLogger(__name__)

#: The report's one sign for "plus or minus" (HTML).
PM = "&plusmn;"

_NUMBERS = [  # (section, key, label, unit, paper key); lengths of the band in mm
    ("shear_band", "v0_over_omega_Ri", "v0 / (Omega R_i)", "-", "v0_over_omega_Ri"),
    ("shear_band", "s_m", "decay length s", "mm", "s_m"),
    ("shear_band", "s_over_d_mean", "s / mean diameter", "-", None),
    ("shear_band", "decades", "decay before the noise", "decades", None),
    ("density", "nu_inner", "nu, inner ring", "-", None),
    ("density", "nu_bulk", "nu, bulk", "-", None),
    ("density", "nu_outer", "nu, outer ring", "-", None),
    ("density", "dilation_inner", "nu_bulk - nu, 1-3 d from the inner wall", "-", None),
    ("density", "dilation_outer", "nu_bulk - nu, 1-3 d from the outer wall", "-", None),
    ("density", "layering_walls", "rms wiggle of nu 1-3 d from the walls", "-", None),
    ("density", "layering_bulk", "rms wiggle of nu in the bulk", "-", None),
    ("fabric", "anisotropy_max", "largest |dev F| / tr F, |dev F| = (F_1 - F_2)/2", "-", None),
    ("stress_exponents", "sigma_rr", "exponent of sigma_rr", "-", "exp_sigma_rr"),
    ("stress_exponents", "sigma_phiphi", "exponent of sigma_phiphi", "-", "exp_sigma_phiphi"),
    ("stress_exponents", "sigma_rphi", "exponent of sigma_rphi", "-", "exp_sigma_rphi"),
    ("stress_exponents", "sigma_phir", "exponent of sigma_phir", "-", "exp_sigma_phir"),
    ("quasi_static", "dynamic_over_static_max", "largest |dynamic| / |static| stress", "-", None),
    ("stiffness", "bulk_slope_per_m", "d(2 pi E / k_n) / d(tr F)", "1/m", None),
    ("stiffness", "bulk_pearson_r", "bulk modulus vs tr F, Pearson r", "-", None),
    ("stiffness", "identity_deviation", "bulk stiffness / (tr F / 2 pi h) - 1", "-", None),
    ("stiffness", "shear_relative_scatter", "scatter of pi G / k_n (std/mean)", "-", None),
    ("orientation", "band_mean_angle_F_sigma", "mean angle F to sigma, band", "deg", None),
    ("orientation", "band_mean_angle_F_eps", "mean angle F to eps, band", "deg", None),
    ("orientation", "band_mean_angle_sigma_eps", "mean angle sigma to eps, band", "deg", None),
    ("equations_of_motion", "bulk_median_residual", "median EoM residual / stress scale, bulk", "-", None),
    ("equations_of_motion", "wall_residual_max", "largest EoM residual / stress scale, walls", "-", None),
    ("equations_of_motion", "balance_bulk_median_residual", "median balance residual with body and boundary forces, bulk", "-", None),
    ("equations_of_motion", "balance_wall_residual_max", "largest balance residual with body and boundary forces, wall rings", "-", None),
    ("equations_of_motion", "balance_near_wall_residual_max", "largest balance residual, rings next to the wall rings", "-", None),
    ("spin_balance", "max_residual", "largest spins' balance residual / stress scale, any ring", "-", None),
    ("spin_balance", "bulk_median_residual", "median spins' balance residual / stress scale, bulk", "-", None),
    ("spin_balance", "field_max_residual", "largest spins' balance residual with div mu, any ring", "-", None),
    ("spin_balance", "tau_max", "largest moment density of the forces / stress scale", "-", None),
    ("wall_loads", "torque_in_Nm", "torque of the packing on the inner wall", "N m", None),
    ("wall_loads", "torque_out_Nm", "torque of the packing on the outer wall", "N m", None),
    ("eigen_rotation", "layer1_per_s", "omega*, first layer", "1/s", None),
    ("eigen_rotation", "layer2_per_s", "omega*, second layer", "1/s", None),
    ("rheology", "mu_s", "mu(I): mu_s", "-", None),
    ("rheology", "mu_2", "mu(I): mu_2", "-", None),
    ("rheology", "I_0", "mu(I): I_0", "-", None),
    ("rheology", "phi_max", "phi(I): phi_max", "-", None),
    ("rheology", "a", "phi(I): a", "-", None),
]


def write_summary(summary: dict, path) -> Path:
    """``summary.json``: every number under stable keys (no plotting series)."""
    path = Path(path)
    path.write_text(json.dumps({k: v for k, v in summary.items() if k != "series"}, indent=2,
                               default=float) + "\n")
    return path


#: Units shown, and the factor from the summary's SI value.
_SCALE = {"mm": 1e3}


def esc(text) -> str:
    """``text`` escaped for HTML, each ``+-`` written as the report's one sign, ±.

    Parameters
    ----------
    text : object
        Any text (converted with ``str``).

    Returns
    -------
    str
        HTML text.
    """
    return html.escape(str(text)).replace("+-", PM)


def headline_rows(summary):
    """(label, value ± error rounded to the error (HTML), unit, paper value) of every
    headline number, in the unit of its row."""
    rows = []
    for section, key, label, unit, paper in _NUMBERS:
        block = summary["numbers"].get(section) or {}
        if key not in block:
            continue
        f = _SCALE.get(unit, 1.0)
        err, sys = block.get(f"{key}_err"), block.get(f"{key}_sys")
        value = pm(f * block[key], f * err if err is not None else None, sep=f" {PM} ")
        if sys is not None and math.isfinite(sys):
            value += f" (statistical), {PM} {plain(f * sys, 2)} (estimator)"
        rows.append((label, value, unit,
                     "" if paper is None else f"{f * PAPER[paper]:g}"))
    return rows


def error_source(summary) -> str:
    """One sentence saying where the errors come from and where they are lower bounds."""
    err = summary.get("errors") or {}
    if err.get("kind") == "runs":
        text = (f"standard errors between {err['replicates']} independent realisations "
                "(ensemble), for profiles and derived numbers alike")
    elif err.get("kind") == "jackknife":
        text = ("errors from time only: profile errors from a blocking analysis of the "
                "frames' time correlation; derived numbers from a delete-one-block "
                f"jackknife over {err['replicates']} blocks (the packing's frozen structure "
                "is not counted: an ensemble, or rings split into sectors, counts it)")
    elif err.get("kind") == "structure":
        sec, parts = err.get("sectors") or {}, err.get("parts") or {}
        text = (f"errors from time and structure: the spread of the {parts.get('sectors')} "
                f"sectors along {sec.get('axis', 'phi')} of every ring (the packing's frozen "
                "structure and local noise) with the time blocking of the whole ring, less "
                "what both count (a two-way analysis, docs/errors.md); derived numbers from "
                "the same sectors, time blocks and their interaction")
        if sec.get("time_only"):
            text += (f"; {', '.join(sec['time_only'])} from time alone, lower bounds (the "
                     "balance of forces makes them the same in every sector: a packing's "
                     "frozen pressure and torque are global, only realisations sample them)")
        if sec and not sec.get("resolved", True):
            text += ("; neighbouring sectors stay correlated even at "
                     f"{parts.get('sectors')} sectors, so these errors may be too small "
                     "(flag few_replicas)")
    else:
        text = "no replicates: derived numbers carry no error"
    bound = {n: ks for n, ks in (err.get("lower_bound_rings") or {}).items() if ks}
    if bound and err.get("kind") != "runs":
        text += ("; the blocking analysis reached no plateau in some rings (" + ", ".join(
            f"{len(ks)} of the {n}-ring profile" for n, ks in bound.items()) +
            "), where the errors are only lower bounds (flag sem_lower_bound"
            + ("; with sectors: where the time part dominates" if err.get("kind") ==
               "structure" else "") + ")")
    return text + "."


def stationarity_table(summary, e, see="") -> list:
    """HTML rows judging the averaging window's steadiness (granavg.engine.stationarity):
    each run's, and an ensemble's from the spread between its realisations; ``see``: the
    reference to the time series' figure (" (see Figure 12)"), or ""."""
    judged = {run: j for run, j in (summary.get("stationarity") or {}).items() if j}
    if not judged:
        return ["<h2>Steady state</h2><p>No time series: steadiness not judged."
                + (f" The packing's state{see}." if see else "") + "</p>"]
    ens = next((j for j in judged.values() for r in j.values() if "n_runs" in r), None)
    out = ["<h2>Steady state</h2><p>Each quantity over the averaging window: means of its "
           "two halves and the change of a fitted line, against errors from its "
           "fluctuations (blocking analysis). <i>drifts</i>: beyond 3 errors; "
           "<i>undetermined</i>: beyond 3 errors that are only lower bounds. "
           "<i>resolution</i>: the smallest change between the halves that the test would "
           "call a drift (3 errors; a lower bound where the errors are)."
           + (f" The time series{see}." if see else "")]
    if ens:
        r = next(iter(ens.values()))
        out.append(f" The <i>ensemble</i> rows judge the mean change over {r['n_runs']} "
                   "independent realisations against its between-run error, which stays "
                   "honest when fluctuations are as slow as one run's window; a steady "
                   f"window is flagged with probability {r['false_alarm']:.1%} (Student's t, "
                   f"{r['n_runs'] - 1} degrees of freedom).")
    out.append("</p><table><tr><th>run</th><th>quantity</th><th>first half</th>"
               "<th>second half</th><th>departure (errors)</th><th>resolution</th>"
               "<th>verdict</th><th>steady from (s)</th></tr>")
    for run, quantities in judged.items():
        for q, r in quantities.items():
            verdict = "drifts" if r["drifts"] else ("undetermined" if r.get("undetermined")
                                                    else "steady")
            cls = {"drifts": "no", "steady": "yes"}.get(verdict, "")
            start = r.get("steady_from_s")
            resolution = r.get("resolution", DRIFT_Z * math.sqrt(2) * r["second_half_err"])
            halves = [pm(r[k], r[f"{k}_err"], sep=f" {PM} ")
                      for k in ("first_half", "second_half")]
            out.append(f"<tr><td>{e(str(run))}</td><td>{e(q)}</td><td>{halves[0]}</td>"
                       f"<td>{halves[1]}</td><td>{r['z']:.1f}</td>"
                       f"<td>{resolution:.2g}</td><td class='{cls}'>{verdict}</td><td>"
                       f"{'-' if 'n_runs' in r else 'none' if start is None else f'{start:.0f}'}"
                       "</td></tr>")
    out.append("</table>")
    return out


#: Longest entry of the run table; longer ones keep their head and go whole to a note.
SHORT = 60


def mixture_table(summary, see="") -> list:
    """The mixture's section (:mod:`granavg.analysis.segregation`), where the summary
    holds one; ``see``: the reference to its figure, or ""."""
    m = summary.get("mixture")
    if not m:
        return []
    err = m["errors"]

    def pm(x, dx, scale=1.0, digits=3):
        return f"{x * scale:.{digits}f} +- {dx * scale:.{digits}f}"     # shown as ±
    rows = [("large disks' area share in the band", pm(m["c_band"], err["band"])),
            ("beyond the band", pm(m["c_rest"], err["rest"])),
            ("excess of the band", pm(m["excess"], err["excess"])),
            ("verdict", m["verdict"])]
    for name, b in m["bands"].items():
        rows.append((f"band width s of the {'small' if name == 'type1' else 'large'} disks "
                     "(mm)", pm(b["s_m"], b.get("s_err", float("nan")), 1e3, 2)))
    out = [f"<h2>The mixture</h2><p>The band: r - R_i below {2 * m['s_band_m'] * 1e3:.1f} mm "
           f"(twice the mixture's s; {m['band_rings']} rings). Errors from the replicates of "
           "the species and of the whole (docs/species.md)."
           + (f" The band's profiles{see}." if see else "") + "</p><table>"]
    out += [f"<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>" for k, v in rows]
    return out + ["</table>"]


def rheology_table(summary, see="") -> list:
    """The rheology's section (:mod:`granavg.analysis.rheology`): each coarse ring's
    inertial_number, friction and packing fraction nu with their errors, and its part in
    the fit mu(I); ``see``: the reference to its figure, or ""."""
    num = (summary.get("numbers") or {}).get("rheology")
    if not num:
        return []
    rings = num["per_ring"]
    nonlocal_ = {round(r, 9) for r in num.get("nonlocal_r_m", [])}

    def status(r, flags):
        said = [f for f in str(flags).split(";") if f in ("no_pressure", "no_shear")]
        if said:
            return "no I (" + ", ".join(said) + ")"
        if round(r, 9) in nonlocal_:
            return "nonlocal: below mu_s, left out of the fit"
        return "band" if r <= num["band_end_m"] else "beyond the band"
    out = [f"<h2>Rheology</h2><p>The coarse rings' local rheology (beyond the paper): "
           f"d = {num['diameter_m'] * 1e3:.2f} mm (the disks' mean), rho_p = "
           f"{num['rho_p_kg_per_m3']:g} kg/m^3; errors from the replicates; the band runs "
           f"to r = {num['band_end_m'] * 1e3:.1f} mm (docs/rheology.md)."
           + (f" The fits{see}." if see else "")
           + "".join(f" No fit: {esc(v)}." for v in num.get("no_fit", {}).values())
           + "</p><table><tr><th>r (mm)</th><th>inertial_number I (-)</th>"
           "<th>friction mu (-)</th><th>packing fraction nu (-)</th><th>ring</th></tr>"]
    for k, r in enumerate(rings["r_m"]):
        cells = [pm(rings[q][k], rings[f"{q}_err"][k], sep=f" {PM} ")
                 if math.isfinite(rings[q][k]) else "-"
                 for q in ("inertial_number", "friction", "nu")]
        out.append(f"<tr><td>{r * 1e3:.1f}</td>" + "".join(f"<td>{c}</td>" for c in cells)
                   + f"<td>{esc(status(r, rings['flags'][k]))}</td></tr>")
    return out + ["</table>"]


def _short(text):
    """(the table's entry, the whole text for a footnote or ""): a long entry cut at its
    first parenthesis or semicolon (or at :data:`SHORT` characters)."""
    if len(text) <= SHORT:
        return html.escape(text), ""
    cut = min((i for i in (text.find(" ("), text.find(";")) if 0 < i <= SHORT),
              default=SHORT)
    return html.escape(text[:cut].rstrip(" ,;:")) + "&hellip;", text


def _seconds(t):
    """A time as a person writes it (4 significant digits), or "-"."""
    return "-" if t is None else f"{t:.4g}"


#: Units a report may show beside SI's coherent ones, and what it measures in them.
NON_SI = {"mm": "mm (millimetres) for the shear band's width and the disks' sizes",
          "deg": "deg (degrees) for angles"}


def units_note(body: str) -> str:
    """The report's sentence on its units, true of ``body`` (the report's HTML): the
    units besides coherent SI ones (:data:`NON_SI`) that it shows, if any.

    Parameters
    ----------
    body : str
        The report's HTML (embedded images are ignored).

    Returns
    -------
    str
        One or two sentences (HTML).
    """
    text = re.sub(r"data:[^'\"]*", "", body)
    used = [what for unit, what in NON_SI.items()
            if re.search(rf"(?<![\w/]){re.escape(unit)}(?![\w/])", text)]
    if not used:
        return "All quantities in SI units (m, s, kg, N, Pa), each with its unit."
    return ("Each value is given with its unit (a table's unit column, a label's "
            "parentheses or beside the number; - marks a ratio without unit): SI units "
            "(m, s, kg, N, Pa), except " + "; ".join(used) + ".")


def figure_order(summary, figures) -> dict:
    """Each drawn figure's number in the report, in the order the report shows them:
    Fig. 1 with the run, then the claims' figures in the claims' order, the time series
    with the steady state, any other last.

    Parameters
    ----------
    summary : dict
        The analysis' summary; its claims name their figures (``figures``).
    figures : dict of str -> path
        The drawn figures, name -> PNG.

    Returns
    -------
    dict of str -> int
    """
    placed = ["fig1", *(n for cl in summary["claims"] for n in cl.get("figures", ())),
              "timeseries"]
    names = dict.fromkeys([n for n in placed if n in figures] + list(figures))
    return {name: k for k, name in enumerate(names, 1)}


class FigureShelf:
    """The report's figures: numbered by :func:`figure_order`, each one embedded once,
    beside the first section that asks for it.

    Parameters
    ----------
    summary : dict
        The analysis' summary.
    figures : dict of str -> path
        The drawn figures, name -> PNG.
    """

    def __init__(self, summary, figures):
        self.paths = dict(figures)
        self.number = figure_order(summary, figures)
        self.shown = set()

    def see(self, names) -> str:
        """The reference to the drawn figures among ``names``, as HTML links:
        ``" (see Figure 3)"``, ``" (see Figures 8 and 9)"``; "" where none is drawn."""
        refs = [f"<a href='#figure-{self.number[n]}'>{self.number[n]}</a>"
                for n in names if n in self.number]
        if not refs:
            return ""
        many = len(refs) > 1
        return (f" (see Figure{'s' if many else ''} "
                f"{', '.join(refs[:-1]) + ' and ' if many else ''}{refs[-1]})")

    def place(self, names) -> list:
        """The HTML of the figures among ``names`` not shown yet, each as a numbered
        ``<figure>`` with its caption."""
        out = []
        for name in names:
            if name in self.paths and name not in self.shown:
                self.shown.add(name)
                out.append(figure_html(name, self.number[name], self.paths[name]))
        return out

    def rest(self) -> list:
        """The HTML of the figures no section showed (under their own heading)."""
        left = [n for n in self.number if n not in self.shown]
        return ["<h2>Other figures</h2>", *self.place(left)] if left else []


def figure_html(name, number, png) -> str:
    """One embedded figure with its caption (:data:`~granavg.analysis.figures.CAPTIONS`:
    what is plotted, against what, in which units, what to look at).

    Parameters
    ----------
    name : str
        The figure's key (``fig2``, ``spins``, ...).
    number : int
        Its number in the report.
    png : path
        The PNG, embedded as base64.

    Returns
    -------
    str
        A ``<figure>`` element.
    """
    title, text = CAPTIONS.get(name, (None, None))
    if title is None:
        log.warning("figure %s has no caption; it is shown under its name", name)
        title, text = f"The figure {name}", "See the figure's axes for its quantities."
    data = base64.b64encode(Path(png).read_bytes()).decode()
    return (f"<figure id='figure-{number}'><img alt='Figure {number}: {esc(title)}' "
            f"src='data:image/png;base64,{data}'><figcaption><b>Figure {number}. "
            f"{esc(title)}.</b> {esc(text)}</figcaption></figure>")


def _claim_row(cl, shelf) -> str:
    """One claim's row of the claims' table, with the reference to its figures."""
    cls = {"reproduced": "yes", "holds": "yes", "not reproduced": "no",
           "violated": "no"}.get(cl["verdict"], "")
    note = f"<br><small>{esc(cl['note'])}</small>" if cl.get("note") else ""
    return (f"<tr><td>{esc(cl['claim'])}{shelf.see(cl.get('figures', ()))}</td>"
            f"<td>{esc(cl['kind'])}</td><td class='{cls}'>{esc(cl['verdict'])}{note}</td>"
            f"<td>{esc(cl.get('tolerance', ''))}</td><td>{esc(cl['evidence'])}</td></tr>")


def _claim_groups(claims) -> list:
    """Consecutive claims that show the same figures, as (figures, claims) pairs."""
    groups = []
    for cl in claims:
        shows = tuple(cl.get("figures", ()))
        if groups and groups[-1][0] == shows:
            groups[-1][1].append(cl)
        else:
            groups.append((shows, [cl]))
    return groups


_CLAIMS_INTRO = (
    "<h2>The paper's claims</h2><p>A verdict is <i>reproduced</i> when the data show the "
    "claim beyond twice its error and within its tolerance, <i>not reproduced</i> when "
    "they show the opposite beyond twice its error, <i>inconclusive</i> otherwise. A "
    "claim that holds only by its tolerance, its number many errors from the paper's, "
    "says so beside its verdict. Identity checks test the averaging, not the paper's "
    "physics. Each figure follows the claims it shows.</p>")
_CLAIMS_HEAD = ("<table><tr><th>claim</th><th>kind</th><th>verdict</th><th>tolerance</th>"
                "<th>the numbers</th></tr>")


def claims_section(summary, shelf) -> list:
    """The claims' tables, one per run of claims that show the same figures, each
    followed by those figures."""
    out = [_CLAIMS_INTRO]
    for shows, claims in _claim_groups(summary["claims"]):
        out += [_CLAIMS_HEAD, *(_claim_row(cl, shelf) for cl in claims), "</table>"]
        out += shelf.place(shows)
    return out


def _run_rows(summary) -> list:
    """(label, value) of the run's table."""
    run = summary["run"]
    scene, law, derived = run["scene"], run["contact_law"], run["derived"]
    params = [("preset", run.get("preset")), ("disks", f"{scene['n_small']} + {scene['n_large']}"),
              ("R_i, R_o (m)", f"{scene['R_i']}, {scene['R_o']}"), ("Omega (rad/s)", scene["Omega"]),
              ("k_n (N/m)", law["k_n_N_per_m"]), ("e_n", scene["e_n"]),
              ("contact law", law.get("pair_style", "pair gran/hooke/history")),
              ("mu, mu_wall, mu_roll", f"{law['mu']}, {law['mu_wall']}, {law.get('mu_roll', 0.0)}"),
              ("base-plate friction mu_base, v_base (m/s)",
               f"{scene.get('mu_base', 0.0)}, {scene.get('v_base', 0.001)}"
               if scene.get("mu_base") else "none"),
              ("packing", run.get("preparation") or "not recorded"),
              ("t_c, dt (s)", f"{derived['t_c_s']:.4g}, {derived['dt_s']:.4g}"),
              ("sheared (s)", f"{derived['t_end_s']:.4g}"),
              ("frames averaged", (summary.get("frames") or {}).get("n")),
              ("averaged from t (s)", _seconds((summary.get("frames") or {}).get("t_min_s"))),
              ("LAMMPS, granavg", f"{run.get('lammps_version')}, {run.get('granavg_version')}")]
    forecast = run.get("forecast") or {}
    if "accuracy_class" in forecast:      # what the speed/accuracy study expects (docs/sweep)
        params.append(("accuracy class of the settings (docs/sweep)",
                       f"{forecast['accuracy_class']}: {forecast['accuracy_reason']}"))
    return params


def run_section(summary, shelf) -> list:
    """The run's table (long entries cut, whole in numbered notes) and Fig. 1."""
    parts, notes = ["<h2>Run</h2><table>"], []
    for k, v in _run_rows(summary):
        short, full = _short(str(v))
        if full:
            notes.append(full)
            short += f" <sup>[{len(notes)}]</sup>"
        parts.append(f"<tr><th>{esc(k)}</th><td>{short.replace('+-', PM)}</td></tr>")
    parts.append("</table>")
    parts += [f"<p class='note'>[{k}] {esc(n)}</p>" for k, n in enumerate(notes, 1)]
    see = shelf.see(["fig1"])
    if see:
        parts.append(f"<p>The packing after shearing and its contact forces{see}.</p>")
    return parts + shelf.place(["fig1"])


def headline_section(summary) -> list:
    """The headline numbers' table and where their errors come from."""
    parts = ["<h2>Headline numbers</h2><table><tr><th>quantity</th><th>value</th>"
             "<th>unit</th><th>paper</th></tr>"]
    parts += [f"<tr><td>{esc(a)}</td><td>{b}</td><td>{esc(c)}</td><td>{esc(d)}</td></tr>"
              for a, b, c, d in headline_rows(summary)]
    return parts + [f"</table><p>Errors: {esc(error_source(summary))}</p>"]


_STYLE = ("<style>body{font-family:sans-serif;max-width:70em;margin:auto;padding:1em}"
          "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #999;"
          "padding:.25em .6em;text-align:left}.yes{color:#006400}.no{color:#b00000}"
          "img{max-width:100%}figure{margin:1em 0 2em}figcaption{font-size:90%;"
          "max-width:60em}</style>")


def write_report(summary: dict, figures: dict, path, title="granavg report") -> Path:
    """A self-contained ``report.html``: the run, the headline numbers, the claims with
    the figures that show them, the steady state and the mixture.

    Parameters
    ----------
    summary : dict
        The analysis' summary (:func:`granavg.paper.claims.analyze`).
    figures : dict of str -> path
        The drawn figures, name -> PNG (empty: a report of numbers alone).
    path : path
        The HTML file to write.
    title : str
        The report's title.

    Returns
    -------
    Path
        ``path``.
    """
    shelf = FigureShelf(summary, figures)
    body = [*run_section(summary, shelf), *headline_section(summary),
            *claims_section(summary, shelf),
            *stationarity_table(summary, html.escape, shelf.see(["timeseries"])),
            *shelf.place(["timeseries"]),
            *mixture_table(summary, shelf.see(["mixture"])),
            *rheology_table(summary, shelf.see(["rheology"])), *shelf.rest()]
    if not figures:
        body.append("<p>No figures: the analysis was asked for its numbers alone.</p>")
    head = [f"<!doctype html><html><head><meta charset='utf-8'><title>{esc(title)}</title>",
            f"{_STYLE}</head><body>", f"<h1>{esc(title)}</h1><p>Luding et al. (2001), 2D "
            f"Couette cell. {units_note(chr(10).join(body))}</p>"]
    path = Path(path)
    path.write_text("\n".join([*head, *body, "</body></html>"]), encoding="utf-8")
    return path
