"""The self-contained report: ``report.html`` (figures embedded) and ``summary.json``."""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

from granavg.analysis.claims import PAPER
from granavg.analysis.rounding import plain, pm
from granavg.engine.stationarity import DRIFT_Z

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
]


def write_summary(summary: dict, path) -> Path:
    """``summary.json``: every number under stable keys (no plotting series)."""
    path = Path(path)
    path.write_text(json.dumps({k: v for k, v in summary.items() if k != "series"}, indent=2,
                               default=float) + "\n")
    return path


#: Units shown, and the factor from the summary's SI value.
_SCALE = {"mm": 1e3}


def headline_rows(summary):
    """(label, value +- error rounded to the error, unit, paper value) of every headline
    number, in the unit of its row."""
    rows = []
    for section, key, label, unit, paper in _NUMBERS:
        block = summary["numbers"].get(section) or {}
        if key not in block:
            continue
        f = _SCALE.get(unit, 1.0)
        err, sys = block.get(f"{key}_err"), block.get(f"{key}_sys")
        value = pm(f * block[key], f * err if err is not None else None)
        if sys is not None and math.isfinite(sys):
            value += f" (statistical), +- {plain(f * sys, 2)} (estimator)"
        rows.append((label, value.replace(" +- ", " &plusmn; "), unit,
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


def stationarity_table(summary, e) -> list:
    """HTML rows judging the averaging window's steadiness (granavg.engine.stationarity):
    each run's, and an ensemble's from the spread between its realisations."""
    judged = {run: j for run, j in (summary.get("stationarity") or {}).items() if j}
    if not judged:
        return ["<h2>Steady state</h2><p>No time series: steadiness not judged.</p>"]
    ens = next((j for j in judged.values() for r in j.values() if "n_runs" in r), None)
    out = ["<h2>Steady state</h2><p>Each quantity over the averaging window: means of its "
           "two halves and the change of a fitted line, against errors from its "
           "fluctuations (blocking analysis). <i>drifts</i>: beyond 3 errors; "
           "<i>undetermined</i>: beyond 3 errors that are only lower bounds. "
           "<i>resolution</i>: the smallest change between the halves that the test would "
           "call a drift (3 errors; a lower bound where the errors are)."]
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
            halves = [pm(r[k], r[f"{k}_err"]).replace(" +- ", " &plusmn; ")
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


def mixture_table(summary, e) -> list:
    """The mixture's section (:mod:`granavg.analysis.segregation`), where the summary
    holds one."""
    m = summary.get("mixture")
    if not m:
        return []
    err = m["errors"]

    def pm(x, dx, scale=1.0, digits=3):
        return f"{x * scale:.{digits}f} +- {dx * scale:.{digits}f}"
    rows = [("large disks' area share in the band", pm(m["c_band"], err["band"])),
            ("beyond the band", pm(m["c_rest"], err["rest"])),
            ("excess of the band", pm(m["excess"], err["excess"])),
            ("verdict", m["verdict"])]
    for name, b in m["bands"].items():
        rows.append((f"band width s of the {'small' if name == 'type1' else 'large'} disks "
                     "(mm)", pm(b["s_m"], b.get("s_err", float("nan")), 1e3, 2)))
    out = [f"<h2>The mixture</h2><p>The band: r - R_i below {2 * m['s_band_m'] * 1e3:.1f} mm "
           f"(twice the mixture's s; {m['band_rings']} rings). Errors from the replicates of "
           "the species and of the whole (docs/species.md).</p><table>"]
    out += [f"<tr><th>{e(k)}</th><td>{e(v)}</td></tr>" for k, v in rows]
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


def write_report(summary: dict, figures: dict, path, title="granavg report") -> Path:
    """A self-contained ``report.html``: parameters, numbers, claims and Figs. 2-9."""
    run = summary["run"]
    scene, law, derived = run["scene"], run["contact_law"], run["derived"]
    e = html.escape
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
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}</title>",
             "<style>body{font-family:sans-serif;max-width:70em;margin:auto;padding:1em}"
             "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #999;"
             "padding:.25em .6em;text-align:left}.yes{color:#006400}.no{color:#b00000}"
             "img{max-width:100%}</style></head><body>",
             f"<h1>{e(title)}</h1><p>Luding et al. (2001), 2D Couette cell. All quantities in "
             "SI units.</p><h2>Run</h2><table>"]
    notes = []
    for k, v in params:
        short, full = _short(str(v))
        if full:
            notes.append(full)
            short += f" <sup>[{len(notes)}]</sup>"
        parts.append(f"<tr><th>{e(str(k))}</th><td>{short}</td></tr>")
    parts.append("</table>")
    parts += [f"<p class='note'>[{k}] {e(n)}</p>" for k, n in enumerate(notes, 1)]
    parts.append("<h2>Headline numbers</h2><table><tr><th>quantity</th><th>value</th>"
                 "<th>unit</th><th>paper</th></tr>")
    parts += [f"<tr><td>{e(a)}</td><td>{b}</td><td>{e(c)}</td><td>{e(d)}</td></tr>"
              for a, b, c, d in headline_rows(summary)]
    parts.append(f"</table><p>Errors: {e(error_source(summary))}</p>")
    parts.append("<h2>The paper's claims</h2><p>A verdict is <i>reproduced</i> when the "
                 "data show the claim beyond twice its error and within its tolerance, "
                 "<i>not reproduced</i> when they show the opposite beyond twice its "
                 "error, <i>inconclusive</i> otherwise. A claim that holds only by its "
                 "tolerance, its number many errors from the paper's, says so beside "
                 "its verdict. Identity checks test the averaging, not the paper's "
                 "physics.</p><table><tr><th>claim</th><th>kind</th><th>verdict</th>"
                 "<th>tolerance</th><th>the numbers</th></tr>")
    for cl in summary["claims"]:
        cls = {"reproduced": "yes", "holds": "yes", "not reproduced": "no",
               "violated": "no"}.get(cl["verdict"], "")
        note = f"<br><small>{e(cl['note'])}</small>" if cl.get("note") else ""
        parts.append(f"<tr><td>{e(cl['claim'])}</td><td>{e(cl['kind'])}</td>"
                     f"<td class='{cls}'>{e(cl['verdict'])}{note}</td>"
                     f"<td>{e(cl.get('tolerance', ''))}</td><td>{e(cl['evidence'])}</td></tr>")
    parts.append("</table>")
    parts += stationarity_table(summary, e)
    parts += mixture_table(summary, e)
    parts.append("<h2>Figures</h2>" if figures else
                 "<p>No figures: the analysis was asked for its numbers alone.</p>")
    for name, png in figures.items():
        data = base64.b64encode(Path(png).read_bytes()).decode()
        title = {"spins": "Figs. 8-9 in micropolar terms",
                 "mixture": "The mixture: large disks' concentration, each species' v_phi"
                 }.get(name, name.replace("fig", "Fig. "))
        parts.append(f"<h3>{e(title)}</h3>"
                     f"<img alt='{e(name)}' src='data:image/png;base64,{data}'>")
    parts.append("</body></html>")
    path = Path(path)
    path.write_text("\n".join(parts))
    return path
