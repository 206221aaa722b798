"""The paper's Figs. 2-9 from two ring profiles and their analysis (SI units; the
band's fitted s in mm), and :data:`CAPTIONS`, what each figure shows, for the report.

Each ``figN`` takes the 20- and 60-ring profiles, the :func:`granavg.paper.claims.analyze`
summary and optionally the axes to draw on (``axes=None`` makes a figure), and returns
the axes. Closed symbols: coarse rings; open symbols: fine rings; lines: fits.
Colours are Okabe-Ito (colour-blind safe) and each series also has its own marker.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

from granavg.analysis.continuum import tensor  # noqa: E402
from granavg.engine.quantities import TENSOR  # noqa: E402
from granavg.analysis.continuum import deviator_norm, trace  # noqa: E402

OKABE_ITO = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000"]
MARKERS = ["o", "s", "^", "D", "v", "P"]


def _axes(axes, n, size=(4.2, 3.2)):
    if axes is not None:
        return np.atleast_1d(axes)
    _, ax = plt.subplots(1, n, figsize=(size[0] * n, size[1]), constrained_layout=True)
    return np.atleast_1d(ax)


def _points(ax, x, y, k, label, closed, err=None, n=None, **kw):
    """One series as markers (closed: coarse rings, open: fine) with its error bars."""
    colour = OKABE_ITO[k % len(OKABE_ITO)]
    ax.errorbar(x, y, yerr=err, ls=kw.pop("ls", "none"), marker=MARKERS[k % len(MARKERS)],
                ms=4 if closed else 5, color=colour, mfc=colour if closed else "none",
                elinewidth=0.7, capsize=0, label=f"{label} ({n} rings)" if n else label,
                **kw)


def _both(ax, p20, p60, fn, k, label, err=None):
    """A profile's series for both ring counts; ``err(p)`` its errors (None: none)."""
    for p, closed in ((p20, True), (p60, False)):
        _points(ax, p.cells.centre, fn(p), k, label, closed,
                None if err is None else err(p), n=p.cells.n)


def _sem(name, scale=None):
    """The errors of a profile column (``scale(p)`` divides them as the values)."""
    return lambda p: p.sem[name] / (scale(p) if scale else 1.0)


def _derived(summary, key):
    """The replicates' per-ring errors of a derived profile (None without replicates)."""
    return lambda p: summary["series"].get(f"errors_{p.cells.n}", {}).get(key)


def _below(ax, ncol=2):
    """The legend under the axes, clear of the data."""
    ax.legend(fontsize=6, ncol=ncol, loc="upper center", bbox_to_anchor=(0.5, -0.2),
              frameon=False)


def fig2(p20, p60, summary, axes=None):
    """Density and v_phi / (Omega r) against r, with the exponential fit (Fig. 2)."""
    ax = _axes(axes, 2)
    run = summary["run"]["scene"]
    R_i, Omega = run["R_i"], run["Omega"]
    _both(ax[0], p20, p60, lambda p: p.values["nu"], 0, "nu", _sem("nu"))
    ax[0].set(xlabel="r (m)", ylabel="volume fraction nu (-)", title="density")
    scale = lambda p: Omega * p.cells.centre                                # noqa: E731
    _both(ax[1], p20, p60, lambda p: p.values["v_phi"] / scale(p), 1, "v_phi/(Omega r)",
          _sem("v_phi", scale))
    sb = summary["numbers"]["shear_band"]
    if np.isfinite(sb["s_m"]):
        r = np.linspace(R_i, sb["decay_range_end_m"], 100)
        ax[1].plot(r, sb["v0_over_omega_Ri"] * R_i * np.exp(-(r - R_i) / sb["s_m"]) / r,
                   color="k", ls=":", label=f"fit: v0/(Omega R_i) = "
                   f"{sb['v0_over_omega_Ri']:.3g}, s = {sb['s_m'] * 1e3:.3g} mm")
    ax[1].set(yscale="log", xlabel="r (m)", ylabel="v_phi / (Omega r) (-)", title="velocity")
    for a in ax:
        a.legend(fontsize=7)
    return ax


def fig3(p20, p60, summary, axes=None):
    """tr F and the anisotropy |dev F| / tr F against r (Fig. 3)."""
    ax = _axes(axes, 2)
    _both(ax[0], p20, p60, lambda p: trace(tensor(p, "F")), 0, "tr F",
          _derived(summary, "trF"))
    ax[0].set(xlabel="r (m)", ylabel="tr F (-)", title="isotropic fabric")
    _both(ax[1], p20, p60, lambda p: deviator_norm(tensor(p, "F")) / trace(tensor(p, "F")), 2,
          "|dev F| / tr F", _derived(summary, "anisotropy"))
    ax[1].set(xlabel="r (m)", ylabel="|dev F| / tr F (-)", title="anisotropy")
    for a in ax:
        a.legend(fontsize=7)
    return ax


def fig4(p20, p60, summary, axes=None):
    """Static stress, dynamic stress and the fluctuation part against r (Fig. 4)."""
    ax = _axes(axes, 3, size=(4.4, 4.0))
    ex = summary["numbers"]["stress_exponents"]
    for k, comp in enumerate(TENSOR):
        _both(ax[0], p20, p60, lambda p, c=comp: p.values[f"sigma_{c}"], k, f"sigma_{comp}",
              _sem(f"sigma_{comp}"))
        r = p20.cells.centre
        y0 = p20.values[f"sigma_{comp}"]
        mid = len(r) // 2
        ax[0].plot(r, y0[mid] * (r / r[mid]) ** ex[f"sigma_{comp}"], color=OKABE_ITO[k], lw=1)
        _both(ax[1], p20, p60, lambda p, c=comp: p.values[f"dsigma_{c}"], k, f"dsigma_{comp}",
              _sem(f"dsigma_{comp}"))
        _both(ax[2], p20, p60, lambda p, c=comp: p.values[f"dsigma_fluct_{c}"], k,
              f"fluct_{comp}", _sem(f"dsigma_fluct_{comp}"))
    ax[0].set(xlabel="r (m)", ylabel="static stress (Pa)", title="static (lines: r^n fits)")
    ax[1].set(xlabel="r (m)", ylabel="dynamic stress (Pa)", title="dynamic")
    ax[2].set(xlabel="r (m)", ylabel="fluctuation stress (Pa)", title="velocity fluctuations")
    for a in ax:
        _below(a)
    return ax


def fig5(p20, p60, summary, axes=None):
    """2 pi E / k_n and pi G / k_n against tr F, with the linear bulk fit (Fig. 5); with
    a density series, the bulk rings of every run on the same axes."""
    ax = _axes(axes, 2)
    for k, p in enumerate((p20, p60)):
        trF, B, G = summary["series"][f"stiffness_{p.cells.n}"]
        for a, y, key in ((ax[0], B, "B"), (ax[1], G, "G")):
            _points(a, trF, y, k, f"{p.cells.n} rings", k == 0, _derived(summary, key)(p))
    for k, (label, trF, B, G) in enumerate(summary["series"].get("density_series", [])):
        for a, y in ((ax[0], B), (ax[1], G)):
            _points(a, trF, y, k + 2, f"{label} (bulk)", True)
    slope, intercept = summary["series"]["bulk_fit"]
    x = np.linspace(*ax[0].get_xlim(), 50)
    ax[0].plot(x, slope * x + intercept, color="k", ls=":", label=f"bulk fit: {slope:.3g} tr F "
               f"{intercept:+.3g}")
    ax[0].set(xlabel="tr F (-)", ylabel="2 pi E / k_n = tr sigma / tr eps / k_n (1/m)",
              title="bulk stiffness")
    ax[1].set(xlabel="tr F (-)", ylabel="pi G / k_n = |dev sigma| / |dev eps| / k_n (1/m)",
              title="shear stiffness")
    for a in ax:
        a.legend(fontsize=7)
    return ax


def fig6(p20, p60, summary, axes=None):
    """Orientation of the major axes of F, sigma and eps to e_r against r (Fig. 6), with
    the replicates' errors."""
    ax = _axes(axes, 1, size=(5.4, 4.2))
    for p in (p20, p60):
        closed = p is p20
        for k, (name, deg) in enumerate(summary["series"][f"orientation_{p.cells.n}"].items()):
            _points(ax[0], p.cells.centre, deg, k, f"phi_{name}", closed,
                    _derived(summary, f"orientation_{name}")(p), n=p.cells.n,
                    ls="-" if closed else "none", lw=0.8)
    ax[0].set(xlabel="r (m)", ylabel="orientation of the major axis to e_r (deg)",
              title="tensor orientations")
    _below(ax[0], ncol=3)
    return ax


def fig7(p20, p60, summary, axes=None):
    """Residuals of the equations of motion (Eqs. 11-12), r div T, for the static stress
    alone and for the total T = sigma - dsigma whose divergence vanishes in steady flow
    (Fig. 7)."""
    ax = _axes(axes, 2, size=(4.4, 3.8))
    for k, p in enumerate((p20, p60)):
        st, tot, scale = summary["series"][f"eom_{p.cells.n}"]
        for j, (comp, title) in enumerate((("r", "radial, Eq. 11"),
                                           ("phi", "tangential, Eq. 12"))):
            r = p.cells.centre
            _points(ax[j], r, st[j] / scale, 0, "static", k == 0,
                    _derived(summary, f"eom_static_{comp}")(p), n=p.cells.n)
            _points(ax[j], r, tot[j] / scale, 1, "total, sigma - dsigma", k == 0,
                    _derived(summary, f"eom_total_{comp}")(p), n=p.cells.n)
            ax[j].set(xlabel="r (m)", ylabel=f"residual / {scale:.3g} Pa (-)", title=title)
    for a in ax:
        a.axhline(0, color="k", lw=0.5)
        _below(a)
    return ax


def fig8(p20, p60, summary, axes=None):
    """-D_rphi and -W_rphi against r, with the fit's Eq. 15 and the particles' -omega."""
    ax = _axes(axes, 2, size=(4.4, 3.8))
    for k, p in enumerate((p20, p60)):
        D, W, Df, Wf, omega, _ = summary["series"][f"rates_{p.cells.n}"]
        r = p.cells.centre
        _points(ax[0], r, -D, 0, "-D", k == 0, _derived(summary, "D")(p), n=p.cells.n)
        _points(ax[1], r, -W, 1, "-W", k == 0, _derived(summary, "W")(p), n=p.cells.n)
        if k == 1:
            ax[0].plot(r, -Df, color="k", ls=":", label="-D of the fit (Eq. 15)")
            ax[1].plot(r, -Wf, color="k", ls=":", label="-W of the fit")
            ax[1].plot(r, -omega, color=OKABE_ITO[2], lw=1.2, label="-omega of the particles")
    ax[0].set(xlabel="r (m)", ylabel="-D_rphi (1/s)", title="deformation rate")
    ax[1].set(xlabel="r (m)", ylabel="-W_rphi, -omega (1/s)", title="spin")
    for a in ax:
        a.set_yscale("symlog", linthresh=1e-3)
        _below(a)
    return ax


def fig9(p20, p60, summary, axes=None):
    """-omega* = -(omega - W_rphi) near the inner wall (Fig. 9)."""
    ax = _axes(axes, 1, size=(5.0, 3.4))
    R_i = summary["run"]["scene"]["R_i"]
    sb = summary["numbers"]["shear_band"]
    for k, p in enumerate((p20, p60)):
        ws = summary["series"][f"rates_{p.cells.n}"][5]
        near = p.cells.centre <= max(sb["decay_range_end_m"], R_i + 0.03)
        err = _derived(summary, "omega_star")(p)
        _points(ax[0], p.cells.centre[near], -ws[near], k, "-omega*", k == 0,
                None if err is None else err[near], n=p.cells.n, ls="-", lw=0.8)
    ax[0].axhline(0, color="k", lw=0.5)
    ax[0].set(xlabel="r (m)", ylabel="-omega* = -(omega - W_rphi) (1/s)",
              title="eigen-rotation near the inner wall")
    ax[0].legend(fontsize=7)
    return ax


def fig_spins(p20, p60, summary, axes=None):
    """Figs. 8-9 in micropolar terms: the couple stress (mu_r: the couple through a
    circle; mu_phi: through a radial cut), the eigen-rotation omega* beside the couples
    the contacts pass (per volume, over the stress scale), and the spins' balance
    residual per ring with the forces' moment density for scale."""
    ax = _axes(axes, 3, size=(4.2, 3.2))
    if "spins_20" not in summary["series"] and f"spins_{p20.cells.n}" not in summary["series"]:
        ax[0].text(0.5, 0.5, "no couple stress in these profiles", ha="center",
                   transform=ax[0].transAxes)
        return ax
    for k, p in enumerate((p20, p60)):
        r = p.cells.centre
        for j, comp in enumerate(("r", "phi")):
            ax[0].plot(r, p.values[f"mu_{comp}"], marker=MARKERS[k], ls="none",
                       color=OKABE_ITO[j], mfc=OKABE_ITO[j] if k == 0 else "none",
                       label=f"mu_{comp} ({p.cells.n} rings)")
        cells, err, field, tau = summary["series"][f"spins_{p.cells.n}"]
        ax[2].errorbar(r, cells, yerr=err, marker=MARKERS[k], ls="none", color=OKABE_ITO[0],
                       mfc=OKABE_ITO[0] if k == 0 else "none", ms=4,
                       label=f"residual, couples passed ({p.cells.n} rings)")
        ax[2].plot(r, field, marker=MARKERS[k + 2], ls="none", color=OKABE_ITO[1],
                   mfc=OKABE_ITO[1] if k == 0 else "none", ms=4,
                   label=f"residual, div mu ({p.cells.n} rings)")
        ax[2].plot(r, tau, color=OKABE_ITO[2], lw=0.8 if k else 1.4,
                   label=f"forces' moments alone ({p.cells.n} rings)")
    fine = p60
    ws = summary["series"][f"rates_{fine.cells.n}"][5]
    ax[1].plot(fine.cells.centre, -ws, color=OKABE_ITO[0], marker="o", ms=3,
               label=f"-omega* ({fine.cells.n} rings)")
    scale = summary["numbers"]["spin_balance"]["tau_max"] if "spin_balance" in \
        summary["numbers"] else None
    twin = ax[1].twinx()
    twin.plot(fine.cells.centre, fine.values["couple_density"], color=OKABE_ITO[1], lw=1.0,
              label="couples passed per volume")
    twin.set_ylabel("couples passed (N m / m^3)", color=OKABE_ITO[1])
    ax[0].axhline(0, color="k", lw=0.5)
    ax[0].set(xlabel="r (m)", ylabel="couple stress (N m / m^2)", title="couple stress")
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].set(xlabel="r (m)", ylabel="-omega* (1/s)", title="eigen-rotation and couples")
    ax[2].axhspan(-0.1, 0.1, color="0.9", zorder=0)
    ax[2].axhline(0, color="k", lw=0.5)
    ax[2].set(xlabel="r (m)", ylabel="moment density / stress scale (-)",
              title="balance of the spins" + (f" (tau up to {scale:.2g})" if scale else ""))
    for a in (ax[0], ax[2]):
        a.legend(fontsize=6)
    ax[1].legend(fontsize=6, loc="upper right")
    return ax


#: Panels of the time-series figure: ((column, legend label) ..., y label, log scale
#: where the values span more than a decade).
_SERIES_PANELS = [
    ((("C", "all disks"), ("C_bulk", "bulk")), "coordination C (contacts per disk)", False),
    ((("P_bulk_Pa", "bulk"),), "static pressure -tr(sigma)/2 (Pa)", True),
    ((("rattler_fraction", "all disks"),), "rattlers: share with < 2 contacts (-)", False),
    ((("overlap_mean_over_d", "mean"), ("overlap_max_over_d", "largest")),
     "overlap / d_s (-)", True),
    ((("ke_J", "all disks"),), "kinetic energy (J)", True),
    ((("psi6_bulk", "mean |psi_6|, bulk"), ("psi6_bulk_ordered", "share |psi_6| > 0.8, bulk")),
     "hexatic order (-)", False),
]


def fig_timeseries(p20, p60, summary, axes=None):
    """The packing's state against time, the averaging window shaded (t >= t_min);
    one line per realisation for an ensemble."""
    ts = p20.timeseries if p20.timeseries is not None else p60.timeseries
    if axes is None:
        _, axes = plt.subplots(2, 3, figsize=(12.6, 6.0), constrained_layout=True)
    ax = np.atleast_1d(axes).ravel()
    if ts is None:
        ax[0].text(0.5, 0.5, "no time series (profiles from an older granavg)",
                   ha="center", transform=ax[0].transAxes)
        return ax
    t_min = (p20.meta.get("frames") or {}).get("t_min_s", 0.0)
    runs = list(ts.groupby("run")) if "run" in ts else [(None, ts)]
    for a, (cols, label, log) in zip(ax, _SERIES_PANELS):
        shown = [(col, name) for col, name in cols if col in ts]
        for k, (col, name) in enumerate(shown):
            for j, (run, part) in enumerate(runs):
                a.plot(part.t_s, part[col], color=OKABE_ITO[k], lw=0.8, alpha=1 if j == 0 else 0.5,
                       label=name if j == 0 else None)
        a.axvspan(t_min, ts.t_s.max(), color="0.9", zorder=0, label="averaged")
        values = np.concatenate([np.asarray(ts[c], float) for c, _ in shown]) if shown else []
        positive = values[np.isfinite(values) & (values > 0)] if len(values) else values
        wide = len(positive) and positive.max() > 10 * positive.min()
        a.set(xlabel="t (s)", ylabel=label, yscale="log" if log and wide else "linear")
        if log and wide:                     # ticks as plain numbers: 0.02, 0.1, not 2x10^-2
            for axis in (a.yaxis.set_major_formatter, a.yaxis.set_minor_formatter):
                axis(FuncFormatter(lambda y, _: f"{y:g}"))
        a.legend(fontsize=6)
    return ax


#: Each figure's caption for the report: (title, what is plotted against what, in which
#: units, and what to look at). Closed symbols are the coarser rings, open ones the
#: finer; error bars are one standard error.
CAPTIONS = {
    "fig1": (
        "The packing and its contact forces (the paper's Fig. 1)",
        "The disks at the time in the title, drawn to scale against x and y (m). Left: each "
        "disk coloured by the horizontal stripe its centre lay in at the first dumped frame; "
        "the stripes bend where the packing shears, near the inner wall. Right: the "
        "contact network, each disk-disk contact a segment coloured by its normal force "
        "in thirds (blue small, green medium, red large); look for the force chains."),
    "timeseries": (
        "The packing's state against time",
        "Against time t (s), the averaging window shaded grey: the coordination number C "
        "(contacts per disk), the bulk's static pressure -tr(sigma)/2 (Pa), the share of "
        "rattlers (disks with fewer than 2 contacts, -), the mean and largest overlap over "
        "the small diameter d_s (-), the kinetic energy (J) and the bulk's hexatic order "
        "|psi_6| (-); one line per realisation of an ensemble. A steady window shows "
        "fluctuations about a level, no trend."),
    "fig2": (
        "Density and velocity across the cell (the paper's Fig. 2)",
        "Against the radius r (m). Left: the volume (in 2D: area) fraction nu (-); look "
        "for the lower density (dilation) 1-3 diameters from each wall and the layering "
        "oscillations next to the walls. Right: v_phi / (Omega r) (-) on a log scale, "
        "the dotted line the exponential fit v0 exp(-(r - R_i)/s) / (Omega r) with "
        "v0/(Omega R_i) and the decay length s (mm) in the legend; a straight stretch is "
        "the exponential decay of the shear band, its length in decades the decay before "
        "the noise."),
    "fig3": (
        "Fabric across the cell (the paper's Fig. 3)",
        "Against the radius r (m). Left: the trace of the fabric tensor tr F (-), the "
        "contacts' density. Right: its anisotropy |dev F| / tr F (-), |dev F| = "
        "(F_1 - F_2)/2; the claim holds where every ring stays below 0.2."),
    "fig4": (
        "Stress across the cell (the paper's Fig. 4)",
        "Stress components rr, rphi, phir and phiphi (Pa) against the radius r (m). Left: "
        "the static (contact) stress, the lines the bulk's power laws r^n (Eq. 10: n = 0 "
        "for sigma_rr and sigma_phiphi, -2 for the shear components). Middle: the dynamic "
        "(kinetic) stress; right: its part from velocity fluctuations. Look at the scale: "
        "the dynamic stress lies far below the static one in a quasi-static flow."),
    "fig5": (
        "Stiffness against fabric (the paper's Fig. 5)",
        "Each bulk ring's stiffness over the normal spring k_n (1/m) against its tr F "
        "(-). Left: the bulk stiffness 2 pi E / k_n = tr sigma / tr eps / k_n with the "
        "straight bulk fit (dotted; its slope is 1/(2 pi h) for linear springs). Right: "
        "the shear stiffness pi G / k_n = |dev sigma| / |dev eps| / k_n. With a density "
        "series, every run's bulk rings: they should fall on one line."),
    "fig6": (
        "Orientation of fabric, stress and strain (the paper's Fig. 6)",
        "The angle (deg) of the major axis of the fabric F, the stress sigma and the "
        "strain eps to the radial direction e_r against the radius r (m); lines join the "
        "coarser rings. Where the three angles differ (in the shear band, near the inner "
        "wall) the tensors are not co-linear."),
    "fig7": (
        "The equations of motion (the paper's Fig. 7, Eqs. 11-12)",
        "The residual r div T of each ring over the stress scale (the bulk's mean "
        "|sigma_rr|, in Pa in the axis label; -) against the radius r (m). Left: radial "
        "(Eq. 11); right: tangential (Eq. 12); for the static stress alone and for the "
        "total T = sigma - dsigma. The total's residual should lie near 0 in the bulk; "
        "the wall rings, where the walls' forces act, stand apart."),
    "fig8": (
        "Deformation rate and spin (the paper's Fig. 8)",
        "Against the radius r (m), on a symmetric log scale (linear within 10^-3 1/s). "
        "Left: the deformation rate -D_rphi (1/s), the dotted line that of the velocity "
        "fit (Eq. 15). Right: the continuum spin -W_rphi (1/s) of the data and of the fit, "
        "with the particles' mean rotation -omega (green line); where -omega departs from "
        "-W_rphi the disks rotate against the flow's spin."),
    "fig9": (
        "Eigen-rotation near the inner wall (the paper's Fig. 9)",
        "The eigen-rotation -omega* = -(omega - W_rphi) (1/s) of the rings near the inner "
        "wall against the radius r (m). Look at its sign in the first two layers of disks: "
        "the paper finds it alternates."),
    "spins": (
        "The paper's Figs. 8-9 in micropolar terms",
        "Against the radius r (m). Left: the couple stress mu_r and mu_phi (N m / m^2). "
        "Middle: -omega* (1/s, left axis) beside the couples the contacts pass per volume "
        "(N m / m^3, right axis). Right: the spins' balance residual over the stress "
        "scale (-), with the couples passed and with div mu, beside the forces' moments "
        "alone; the grey band marks 0.1 either side of 0, the claim's limit."),
    "mixture": (
        "The mixture: segregation in the shear band",
        "Against the distance from the inner wall r - R_i (mm). Left: the large disks' "
        "share of the area fraction, c = nu_large / nu (-), the band shaded and the "
        "dotted line its mean beyond the band; more large disks in the band is "
        "segregation. Right: each species' v_phi (m/s, log scale)."),
    "rheology": (
        "The local rheology of the coarse rings: mu(I) and phi(I)",
        "Each ring with a defined inertial number I = gamma_dot d / sqrt(P / rho_p) (-, log "
        "scale), its error bars from the replicates in both directions. Left: the friction "
        "mu = tau / P (-) with the fit mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) (line) "
        "and mu_s (dotted); open red markers are rings left out of the fit, below mu_s and "
        "the fit by more than 3 errors while they flow (creep, where the local law has no "
        "flow). Right: the packing fraction (-) with the fit phi(I) = phi_max - a I. A ring "
        "whose pressure or shear rate lies within 2 errors of 0 has no I and is not "
        "shown (docs/rheology.md)."),
}

FIGURES = {"timeseries": fig_timeseries, "fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5, "fig6": fig6,
           "fig7": fig7, "fig8": fig8, "fig9": fig9, "spins": fig_spins}


def save_all(p20, p60, summary, out_dir) -> dict:
    """Draw every figure and save it as PNG and PDF in ``out_dir``; returns name -> PNG path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, fn in FIGURES.items():
        ax = fn(p20, p60, summary)
        fig = ax[0].figure
        for ext in ("png", "pdf"):
            fig.savefig(out / f"{name}.{ext}", dpi=130)
        plt.close(fig)
        paths[name] = out / f"{name}.png"
    return paths


def fig1(first, later, contacts, R_i, R_o, *, stripes=10, axes=None):
    """The packing after shearing, disks coloured by the horizontal stripe their centre
    was in at the first frame (the shear zone shows as bent stripes), and the contact
    network with forces in thirds: large red, medium green, small blue (Fig. 1). Drawn
    to scale (m).

    Parameters
    ----------
    first, later : dict of ndarray
        Atom columns ``id x y radius`` of the first frame and of the frame to draw.
    contacts : dict of ndarray
        Contact columns ``id1 id2 wall fnx fny`` of the frame to draw.
    R_i, R_o : float
        Ring radii (m), drawn as circles.
    """
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle

    ax = _axes(axes, 2, size=(5.2, 5.2))
    order = np.argsort(first["id"])
    pos = np.searchsorted(first["id"][order], later["id"])
    y0 = first["y"][order][np.clip(pos, 0, len(order) - 1)]
    band = np.floor((y0 + R_o) / (2 * R_o) * stripes).astype(int) % 2
    colours = np.where(band == 0, OKABE_ITO[0], OKABE_ITO[4])
    disks = PatchCollection([Circle((x, y), a) for x, y, a in
                             zip(later["x"], later["y"], later["radius"])],
                            facecolors=colours, edgecolors="none")
    ax[0].add_collection(disks)
    rows = {int(i): k for k, i in enumerate(later["id"])}
    pair = np.asarray(contacts["wall"]) == 0
    i1 = np.array([rows[int(i)] for i in np.asarray(contacts["id1"])[pair]], dtype=int)
    i2 = np.array([rows[int(i)] for i in np.asarray(contacts["id2"])[pair]], dtype=int)
    f = np.hypot(np.asarray(contacts["fnx"])[pair], np.asarray(contacts["fny"])[pair])
    cuts = np.quantile(f, [1 / 3, 2 / 3]) if len(f) else (0, 0)
    third = np.digitize(f, cuts)                      # 0 small, 1 medium, 2 large
    colour_of = np.array(["#0072B2", "#009E73", "#D55E00"])          # blue, green, red
    segments = np.stack([np.column_stack([later["x"][i1], later["y"][i1]]),
                         np.column_stack([later["x"][i2], later["y"][i2]])], axis=1)
    for k in (0, 1, 2):                                # large forces drawn on top
        sel = third == k
        ax[1].add_collection(LineCollection(segments[sel], colors=colour_of[k],
                                            linewidths=0.4 + 0.6 * k,
                                            label=("small", "medium", "large")[k] +
                                            " normal forces"))
    for a, title in zip(ax, ("disks by initial stripe", "contact forces in thirds")):
        for R in (R_i, R_o):
            a.add_patch(Circle((0, 0), R, fill=False, color="k", lw=0.8))
        a.set(xlim=(-1.02 * R_o, 1.02 * R_o), ylim=(-1.02 * R_o, 1.02 * R_o), aspect="equal",
              xlabel="x (m)", ylabel="y (m)", title=title)
    ax[1].legend(fontsize=6, loc="upper right")
    return ax


def fig_scales(widths_d, diameter, profiles, exact, names, plateaus, *, unit="", units=None,
               axes=None):
    """A scale study: each field against position at each kernel width (light to dark
    with the width; the standard errors as bands) and the exact weights' profile (black
    points), one panel per field; each panel's title gives the plateau's widths in
    diameters (:mod:`granavg.analysis.scales`).

    Parameters
    ----------
    widths_d : sequence of float, shape (K,)
        The widths in mean diameters.
    diameter : float
        The mean diameter, in the length unit.
    profiles : sequence of Fields, shape (K,)
    exact : Fields or None
        The exact weights' profile of the same cells and frames.
    names : sequence of str
        Value columns to draw, one panel each.
    plateaus : dict of name -> (w_from, w_to) or None
        In the length unit (shown in diameters).
    unit : str
        The length unit's label.
    units : dict of name -> str, optional
        Each field's unit, for its axis label.
    """
    ax = _axes(axes, len(names), size=(4.0, 3.2))
    line = profiles[0].cells.position()
    colours = plt.get_cmap("viridis")(np.linspace(0.85, 0.1, len(profiles)))
    for a, name in zip(ax, names):
        for k, (wd, p) in enumerate(zip(widths_d, profiles)):
            x = line[1] if line else np.arange(p.cells.n)
            y, e = p.values[name], p.sem[name]
            a.plot(x, y, color=colours[k], lw=1.2, label=f"w = {wd:g} d")
            a.fill_between(x, y - e, y + e, color=colours[k], alpha=0.25, lw=0)
        if exact is not None and name in exact.values:
            xe = exact.cells.position()[1] if line else np.arange(exact.cells.n)
            a.errorbar(xe, exact.values[name], exact.sem[name], ls="none", marker="o",
                       ms=3, color="k", lw=0.8, label="exact weights")
        span = plateaus.get(name)
        where = f"plateau w = {span[0] / diameter:.3g}-{span[1] / diameter:.3g} d" \
            if span else "no plateau"
        a.set(xlabel=f"{line[0]} ({unit})" if line else "cell",
              ylabel=f"{name} ({(units or {}).get(name) or '-'})",
              title=f"{name}: {where}")
        a.legend(fontsize=6)
    return ax
