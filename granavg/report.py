"""The self-contained report: ``report.html`` (figures embedded) and ``summary.json``."""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from .analysis import PAPER

_NUMBERS = [  # (section, key, label, unit, paper key)
    ("shear_band", "v0_over_omega_Ri", "v0 / (Omega R_i)", "-", "v0_over_omega_Ri"),
    ("shear_band", "s_m", "decay length s", "m", "s_m"),
    ("shear_band", "s_over_d_mean", "s / mean diameter", "-", None),
    ("shear_band", "decades", "decay before the noise", "decades", None),
    ("density", "nu_inner", "nu, inner ring", "-", None),
    ("density", "nu_bulk", "nu, bulk", "-", None),
    ("density", "nu_outer", "nu, outer ring", "-", None),
    ("density", "nu_wiggle_walls", "ring-to-ring spread of nu near the walls", "-", None),
    ("density", "nu_wiggle_bulk", "ring-to-ring spread of nu in the bulk", "-", None),
    ("fabric", "anisotropy_max", "largest |dev F| / tr F", "-", None),
    ("stress_exponents", "sigma_rr", "exponent of sigma_rr", "-", "exp_sigma_rr"),
    ("stress_exponents", "sigma_phiphi", "exponent of sigma_phiphi", "-", "exp_sigma_phiphi"),
    ("stress_exponents", "sigma_rphi", "exponent of sigma_rphi", "-", "exp_sigma_rphi"),
    ("stress_exponents", "sigma_phir", "exponent of sigma_phir", "-", "exp_sigma_phir"),
    ("quasi_static", "dynamic_over_static_max", "largest |dynamic| / |static| stress", "-", None),
    ("stiffness", "bulk_slope_per_m", "d(2 pi E / k_n) / d(tr F)", "1/m", None),
    ("stiffness", "bulk_pearson_r", "bulk modulus vs tr F, Pearson r", "-", None),
    ("stiffness", "shear_relative_scatter", "scatter of pi G / k_n (std/mean)", "-", None),
    ("orientation", "max_difference_in_band_deg", "largest angle between major axes, band", "deg", None),
    ("equations_of_motion", "bulk_median_residual", "median EoM residual / stress scale, bulk", "-", None),
    ("equations_of_motion", "wall_residual_max", "largest EoM residual / stress scale, walls", "-", None),
    ("eigen_rotation", "layer1_per_s", "omega*, first layer", "1/s", None),
    ("eigen_rotation", "layer2_per_s", "omega*, second layer", "1/s", None),
]


def write_summary(summary: dict, path) -> Path:
    """``summary.json``: every number under stable keys (no plotting series)."""
    path = Path(path)
    path.write_text(json.dumps({k: v for k, v in summary.items() if k != "series"}, indent=2,
                               default=float) + "\n")
    return path


def headline_rows(summary):
    """(label, value +- error, unit, paper value) of every headline number."""
    rows = []
    for section, key, label, unit, paper in _NUMBERS:
        block = summary["numbers"][section]
        err = block.get(f"{key}_err")
        value = f"{block[key]:.4g}" + (f" &plusmn; {err:.2g}" if err is not None else "")
        rows.append((label, value, unit, "" if paper is None else f"{PAPER[paper]:g}"))
    return rows


def write_report(summary: dict, figures: dict, path, title="granavg report") -> Path:
    """A self-contained ``report.html``: parameters, numbers, claims and Figs. 2-9."""
    run = summary["run"]
    scene, law, derived = run["scene"], run["contact_law"], run["derived"]
    e = html.escape
    params = [("preset", run.get("preset")), ("disks", f"{scene['n_small']} + {scene['n_large']}"),
              ("R_i, R_o (m)", f"{scene['R_i']}, {scene['R_o']}"), ("Omega (rad/s)", scene["Omega"]),
              ("k_n (N/m)", law["k_n_N_per_m"]), ("e_n", scene["e_n"]),
              ("mu, mu_wall", f"{law['mu']}, {law['mu_wall']}"),
              ("t_c, dt (s)", f"{derived['t_c_s']:.4g}, {derived['dt_s']:.4g}"),
              ("sheared (s)", f"{derived['t_end_s']:.4g}"),
              ("frames averaged", (summary.get("frames") or {}).get("n")),
              ("t_min (s)", (summary.get("frames") or {}).get("t_min_s")),
              ("LAMMPS, granavg", f"{run.get('lammps_version')}, {run.get('granavg_version')}")]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}</title>",
             "<style>body{font-family:sans-serif;max-width:70em;margin:auto;padding:1em}"
             "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #999;"
             "padding:.25em .6em;text-align:left}.yes{color:#006400}.no{color:#b00000}"
             "img{max-width:100%}</style></head><body>",
             f"<h1>{e(title)}</h1><p>Luding et al. (2001), 2D Couette cell. All quantities in "
             "SI units.</p><h2>Run</h2><table>"]
    parts += [f"<tr><th>{e(str(k))}</th><td>{e(str(v))}</td></tr>" for k, v in params]
    parts.append("</table><h2>Headline numbers</h2><table><tr><th>quantity</th><th>value</th>"
                 "<th>unit</th><th>paper</th></tr>")
    parts += [f"<tr><td>{e(a)}</td><td>{b}</td><td>{e(c)}</td><td>{e(d)}</td></tr>"
              for a, b, c, d in headline_rows(summary)]
    parts.append("</table><h2>The paper's claims</h2><table><tr><th>claim</th><th>reproduced"
                 "</th><th>decided by</th></tr>")
    for cl in summary["claims"]:
        yes = cl["reproduced"]
        parts.append(f"<tr><td>{e(cl['claim'])}</td><td class='{'yes' if yes else 'no'}'>"
                     f"{'yes' if yes else 'no'}</td><td>{e(cl['evidence'])}</td></tr>")
    parts.append("</table><h2>Figures</h2>")
    for name, png in figures.items():
        data = base64.b64encode(Path(png).read_bytes()).decode()
        parts.append(f"<h3>{e(name.replace('fig', 'Fig. '))}</h3>"
                     f"<img alt='{e(name)}' src='data:image/png;base64,{data}'>")
    parts.append("</body></html>")
    path = Path(path)
    path.write_text("\n".join(parts))
    return path
