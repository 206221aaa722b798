"""The state of the packing frame by frame, and whether the averaging window is steady.

The paper averages a *steady* flow (Eqs. 8-12 assume d/dt = 0). :func:`frame_state`
reduces one frame to scalars that show a transient (SI units): coordination overall and
per radial zone, rattler fraction, bulk static pressure, overlaps, kinetic energy, wall
contacts and the bulk hexatic order (over the contact network: one pass over the
contacts, no triangulation). :func:`stationarity` judges each over the
averaging window: a quantity drifts when the means of the window's two halves, or the
change of a straight line fitted over it, differ from steady by more than
:data:`DRIFT_Z` errors; the errors come from the fluctuations about that line, by
blocking analysis (:mod:`granavg.engine.uncertainty`), so that neither correlation nor the
trend itself is mistaken for noise. :func:`steady_from` finds the earliest start from
which a quantity does not drift. :func:`ensemble_stationarity` judges the window of an
ensemble from its runs' verdicts, with errors from the spread between independent
realisations, which stay honest where one run's fluctuations are as slow as its window.

Zones by disk centre, as fractions of the gap R_o - R_i: ``in`` [0, 0.2), ``bulk``
[0.3, 0.8), ``out`` [0.85, 1]. A rattler has fewer than two contacts.
"""

from __future__ import annotations

import warnings

import numpy as np

from numba import njit

from granavg.engine.kernels import contact_rows, wall_points
from granavg.engine.uncertainty import blocking_errors

ZONES = {"in": (0.0, 0.2), "bulk": (0.3, 0.8), "out": (0.85, 1.0)}
#: Half-window means further apart than this many combined errors flag a drift. With
#: honest errors a steady quantity is flagged in ~0.3% of tests.
DRIFT_Z = 3.0
#: An ensemble verdict needs at least this many independent realisations.
MIN_RUNS = 3
#: The quantities judged for steadiness (when present).
JUDGED = ["C", "C_bulk", "P_bulk_Pa", "rattler_fraction", "nu_bulk", "psi6_bulk"]


def frame_state(atoms, contacts, R_i, R_o, h, rho_p, d_ref) -> dict:
    """Scalars describing one frame (SI units; NaN where the data lack a column).

    Parameters
    ----------
    atoms : dict of ndarray, shape (P,)
        ``x y radius`` and, where present, ``vx vy omegaz id`` of the packing's disks.
    contacts : dict of ndarray or None
        Contact-dump columns (``id1 id2 wall fnx fny ftx fty nx ny overlap``).
    R_i, R_o, h, rho_p : float
        Ring radii (m), disk height (m), material density (kg/m^3).
    d_ref : float
        Reference diameter for the overlaps (m), the small disks' d_s.

    Returns
    -------
    dict
        ``C``, ``C_in``, ``C_bulk``, ``C_out`` (contacts per disk), ``rattler_fraction``,
        ``P_bulk_Pa`` (-tr sigma / 2 of the bulk zone), ``overlap_mean_over_d``,
        ``overlap_max_over_d``, ``ke_J`` (translational + rotational), ``wall_contacts_in``,
        ``wall_contacts_out``, ``torque_in_Nm``, ``torque_out_Nm``
        (:func:`wall_torques`), ``nu_bulk``, ``psi6_bulk`` (mean |psi_6| over the
        contact network's bonds, disks with at least 3 bonds) and ``psi6_bulk_ordered``
        (share with |psi_6| > 0.8).
    """
    x, y, a = atoms["x"], atoms["y"], atoms["radius"]
    r = np.hypot(x, y)
    frac = (r - R_i) / (R_o - R_i)
    zone = {k: (frac >= lo) & ((frac < hi) | (hi == 1.0)) for k, (lo, hi) in ZONES.items()}
    zone_area = {k: np.pi * ((R_i + hi * (R_o - R_i)) ** 2 - (R_i + lo * (R_o - R_i)) ** 2)
                 for k, (lo, hi) in ZONES.items()}
    out = {"nu_bulk": float(np.sum(np.pi * a[zone["bulk"]] ** 2) / zone_area["bulk"])}
    mass = rho_p * h * np.pi * a * a
    if "vx" in atoms:
        ke = 0.5 * mass * (atoms["vx"] ** 2 + atoms["vy"] ** 2)
        if "omegaz" in atoms:
            ke = ke + 0.25 * mass * a * a * atoms["omegaz"] ** 2       # I = m a^2 / 2
        out["ke_J"] = float(np.sum(ke))
    if contacts is None or "id" not in atoms:
        return out
    i1, i2 = contact_rows(atoms, contacts)
    n = len(x)
    fn = ((contacts["fnx"] + contacts["ftx"]) * contacts["nx"] +
          (contacts["fny"] + contacts["fty"]) * contacts["ny"]) if "fnx" in contacts \
        else np.zeros(len(i1))
    count, trace, bonds, re6, im6 = _contact_state(i1, i2, np.asarray(fn, float),
                                                   np.asarray(a, float), x, y, n)
    out.update(_hexatic(bonds, re6, im6, zone["bulk"]))
    out["C"] = float(count.mean()) if n else np.nan
    for k, m in zone.items():
        out[f"C_{k}"] = float(count[m].mean()) if m.any() else np.nan
    out["rattler_fraction"] = float(np.mean(count < 2)) if n else np.nan
    if "fnx" in contacts:
        out["P_bulk_Pa"] = float(-0.5 * trace[zone["bulk"]].sum() / (zone_area["bulk"] * h))
    if "overlap" in contacts:
        ov = contacts["overlap"] / d_ref
        out["overlap_mean_over_d"] = float(ov.mean()) if len(ov) else 0.0
        out["overlap_max_over_d"] = float(ov.max()) if len(ov) else 0.0
    out["wall_contacts_in"] = int(np.sum(contacts["wall"] == 1))
    out["wall_contacts_out"] = int(np.sum(contacts["wall"] == 2))
    if "fnx" in contacts and "overlap" in contacts:
        out.update(wall_torques(atoms, contacts, (i1, i2)))
    return out


@njit(cache=True, nogil=True)
def _contact_state(i1, i2, fn, a, x, y, n):
    """One pass over the contacts: each disk's contact count, its sum a f.n (the trace of
    its stress sum) and the sums cos 6 theta, sin 6 theta over its disk-disk bonds
    (theta the bond's angle; the reverse bond has the same)."""
    count, trace, bonds = np.zeros(n), np.zeros(n), np.zeros(n)
    re6, im6 = np.zeros(n), np.zeros(n)
    for c in range(i1.shape[0]):
        p, q = i1[c], i2[c]
        count[p] += 1.0
        trace[p] += a[p] * fn[c]
        if q < 0:
            continue
        count[q] += 1.0
        trace[q] += a[q] * fn[c]
        dx, dy = x[q] - x[p], y[q] - y[p]
        r2 = dx * dx + dy * dy
        if r2 > 0.0:
            u, v = dx * dx / r2, dy * dy / r2            # cos^2, sin^2
            cs = dx * dy / r2                              # cos sin
            c6 = u * u * u - 15.0 * u * u * v + 15.0 * u * v * v - v * v * v
            s6 = cs * (6.0 * u * u - 20.0 * u * v + 6.0 * v * v)
            bonds[p] += 1.0
            bonds[q] += 1.0
            re6[p] += c6
            im6[p] += s6
            re6[q] += c6
            im6[q] += s6
    return count, trace, bonds, re6, im6


def wall_torques(atoms, contacts, rows) -> dict:
    """Torque about the centre (N m) that the packing exerts on each wall: minus the
    wall contacts' forces on the disks, at their contact points x + (a - delta/2) n
    (:func:`~granavg.engine.kernels.wall_points`). The shear cell's torque, which the
    experiments measure (``torque_in_Nm`` on the turning inner ring, ``torque_out_Nm``
    on the outer)."""
    points, forces = wall_points(atoms, contacts, 2, "contact", rows)
    code = np.asarray(contacts["wall"])
    code = code[code != 0]
    torque = -(points[:, 0] * forces[:, 1] - points[:, 1] * forces[:, 0])
    return {name: float(np.sum(torque[code == c]))
            for name, c in (("torque_in_Nm", 1), ("torque_out_Nm", 2))}


def _hexatic(bonds, re6, im6, bulk):
    """Mean |psi_6| of the bulk disks with at least 3 bonds and the share above 0.8, over
    the bonds of the contact network: psi_6 = <exp(6 i theta)> over a disk's disk-disk
    contacts (the sums from :func:`_contact_state`). Disks with fewer bonds are left out:
    one bond alone gives |psi_6| = 1, two often more than 0.8."""
    keep = bulk & (bonds >= 3)
    if keep.sum() < 3:
        return {}
    psi = np.hypot(re6[keep], im6[keep]) / bonds[keep]
    return {"psi6_bulk": float(psi.mean()), "psi6_bulk_ordered": float(np.mean(psi > 0.8))}


class TimeSeries:
    """Rows of :func:`frame_state`, one per frame, with its time step and time (s)."""

    def __init__(self, R_i, R_o, h, rho_p, d_ref):
        self.geometry = (R_i, R_o, h, rho_p, d_ref)
        self.rows = []

    def add(self, frame) -> None:
        self.rows.append({"step": frame.timestep, "t_s": frame.time,
                          **frame_state(frame.atoms, frame.contacts, *self.geometry)})

    def columns(self) -> dict:
        """The rows as columns, name -> ndarray (NaN where a frame lacks a quantity)."""
        names = list(dict.fromkeys(k for row in self.rows for k in row))
        return {k: np.array([row.get(k, np.nan) for row in self.rows]) for k in names}


def window_mean(series, column: str, t_min: float) -> dict:
    """Mean of a per-frame quantity over t >= t_min with its standard error: between
    realisations for an ensemble's series (a ``run`` column), else by blocking analysis
    of the frames (``lower_bound`` where no plateau was reached); None if absent.
    ``series``: a table (DataFrame, or a mapping of columns)."""
    if series is None or column not in series:
        return None
    inside = np.asarray(series["t_s"], float) >= t_min
    x = np.asarray(series[column], float)[inside]
    if "run" in series:
        runs = np.asarray(series["run"])[inside]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)      # a run with no value: NaN
            means = np.array([np.nanmean(x[runs == r]) for r in np.unique(runs)])
        err = float(np.std(means, ddof=1) / np.sqrt(len(means))) if len(means) > 1 else np.nan
        return {"mean": float(np.mean(means)), "err": err, "n_runs": int(len(means)),
                "error": "between realisations"}
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return {"mean": float(np.mean(x)) if len(x) else np.nan, "err": np.nan}
    sem, lower = blocking_errors(np.ones(len(x)), x[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
    return {"mean": float(np.mean(x)), "err": float(sem["x"][0]),
            "lower_bound": bool(lower["x"][0]), "error": "blocking over frames"}


def _fluctuation_error(t, x):
    """Standard error of the mean of x from its fluctuations about a straight line
    (blocking analysis of the residuals: a trend is not read as correlation)."""
    resid = x - np.polyval(np.polyfit(t, x, 1), t)
    sem, lower = blocking_errors(np.ones(len(x)), resid[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
    return float(sem["x"][0]), bool(lower["x"][0])


def stationarity(series, t_min: float, t_max: float | None = None) -> dict:
    """Judge each quantity of :data:`JUDGED` over the window t_min <= t <= t_max of a
    table (DataFrame, or a mapping of columns with ``t_s``).

    Returns
    -------
    dict of quantity -> dict
        ``first_half``, ``second_half`` (means), their errors, ``trend_change`` (of the
        fitted line over the window), ``z`` (the larger departure from steady, in
        errors), ``drifts`` (z > DRIFT_Z with a reliable error), ``undetermined`` (z >
        DRIFT_Z, but the later half's error is only a lower bound: too few independent
        samples to tell a drift from slow fluctuations), ``error_lower_bound``,
        ``steady_from_s`` (earliest start that would be steady).
    """
    t = np.asarray(series["t_s"], float)
    upto = t <= (t_max if t_max is not None else np.inf)
    window = (t >= t_min) & upto
    out = {}
    for q in JUDGED:
        if q not in series:
            continue
        x = np.asarray(series[q], float)
        if np.sum(~np.isnan(x[window])) < 8:
            continue
        res = _judge(t[window], x[window])
        if res is None:
            continue
        res["steady_from_s"] = steady_from({"t_s": t[upto], q: x[upto]}, q, t_min)
        out[q] = res
    return out


def _judge(t, x):
    """Half means and a linear trend over the window, against the fluctuation error of
    the steadier half (under steadiness both halves fluctuate alike, so a transient
    cannot hide in its own inflated error); drifts if either departs from steady by
    more than DRIFT_Z errors."""
    ok = np.isfinite(x)
    t, x = t[ok], x[ok]
    if len(x) < 8:
        return None
    half = len(x) // 2
    (e1, l1), (e2, l2) = (_fluctuation_error(t[s], x[s]) for s in (slice(None, half),
                                                                     slice(half, None)))
    m1, m2 = float(x[:half].mean()), float(x[half:].mean())
    e_half = e2                  # the later half: the steady reference if a transient ends
    change = np.polyfit(t, x, 1)[0] * (t[-1] - t[0])   # the trend's change over the window
    z_halves = _ratio(abs(m2 - m1), np.sqrt(2) * e_half)
    z_trend = _ratio(abs(change), np.sqrt(12) * e_half / np.sqrt(2))
    z = float(max(z_halves, z_trend))
    return {"first_half": m1, "first_half_err": e1, "second_half": m2, "second_half_err": e2,
            "trend_change": float(change), "z": z, "drifts": bool(z > DRIFT_Z and not l2),
            "undetermined": bool(z > DRIFT_Z and l2), "error_lower_bound": l1 or l2}


def _ratio(a, b):
    return a / b if b > 0 else (0.0 if a == 0 else np.inf)


def steady_from(series, q: str, t_min: float, min_frames: int = 16):
    """Earliest start (s, t >= t_min) of a steady stretch of ``q``: the start that
    maximises the effective number of independent frames n / g, g the statistical
    inefficiency from blocking (Chodera, J. Chem. Theory Comput. 12, 1799, 2016), if
    the stretch from there does not drift; None otherwise (or with < min_frames)."""
    t = np.asarray(series["t_s"], float)
    x = np.asarray(series[q], float)
    keep = (t >= t_min) & np.isfinite(x)
    t, x = t[keep], x[keep]
    if len(x) < min_frames:
        return None
    best, best_neff = None, -1.0
    for start in np.linspace(t[0], t[-min_frames], 20):
        part = x[t >= start]
        naive = np.std(part, ddof=1) / np.sqrt(len(part))
        sem, _ = blocking_errors(np.ones(len(part)), part[:, None, None],
                                 lambda m: {"x": m[:, :, 0]})
        g = max((sem["x"][0] / naive) ** 2, 1.0) if naive > 0 else 1.0
        if len(part) / g > best_neff:
            best, best_neff = float(start), len(part) / g
    res = _judge(t[t >= best], x[t >= best])
    return best if res is not None and not (res["drifts"] or res["undetermined"]) else None


def ensemble_stationarity(judged: list) -> dict:
    """Judge an ensemble's averaging window from its runs' :func:`stationarity` results.

    Each run k gives the change between the means of its window's halves, d_k, and the
    change c_k of a line fitted over the window. Independent realisations of a steady
    window give changes that scatter about zero; a drift shared by the runs moves their
    mean. The error of the mean change is the between-run standard error
    std(d_k)/sqrt(n), never below the error from the runs' own errors (as in
    :func:`granavg.engine.combine.combine_runs`): unlike a single run's blocking error, it
    stays honest when fluctuations are as slow as the window. A quantity drifts when the
    mean change of either kind exceeds :data:`DRIFT_Z` errors; with n runs the error has
    n - 1 degrees of freedom, so one such test flags a steady window with probability
    ``false_alarm`` (Student's t; 5.8% for 4 runs, 2.0% for 8; both tests together,
    measured on synthetic ensembles of 44 frames with fluctuations as slow as the window:
    7-8% and 3%; docs/profiles.md).

    Parameters
    ----------
    judged : list of dict
        One :func:`stationarity` result per realisation (``None`` for a run without a
        time series), all over the same window.

    Returns
    -------
    dict of quantity -> dict
        For each quantity judged in at least :data:`MIN_RUNS` runs: ``n_runs``, the
        ensemble means ``first_half`` and ``second_half``, ``change`` (mean d_k) and
        ``change_err``, ``trend_change`` and ``trend_change_err`` (mean c_k), ``z`` (the
        larger departure, in errors), ``drifts``, ``undetermined`` (always False: the
        errors are not lower bounds), ``resolution`` (the smallest half-to-half change
        the test would call a drift, DRIFT_Z errors) and ``false_alarm``. Empty with
        fewer runs.
    """
    runs = [j for j in judged if j]
    out = {}
    for q in JUDGED:
        rows = [j[q] for j in runs if q in j]
        if len(rows) < MIN_RUNS:
            continue
        n = len(rows)
        m1, m2 = (np.array([r[k] for r in rows]) for k in ("first_half", "second_half"))
        own = np.array([np.sqrt(2) * r["second_half_err"] for r in rows])
        d = m2 - m1
        c = np.array([r["trend_change"] for r in rows])
        floor = np.sqrt(np.sum(own**2)) / n
        e_d = max(np.std(d, ddof=1) / np.sqrt(n), floor)
        e_c = max(np.std(c, ddof=1) / np.sqrt(n), np.sqrt(6) * floor)   # as in _judge
        z = float(max(_ratio(abs(d.mean()), e_d), _ratio(abs(c.mean()), e_c)))
        out[q] = {"n_runs": n, "first_half": float(m1.mean()), "second_half": float(m2.mean()),
                  "first_half_err": float(np.std(m1, ddof=1) / np.sqrt(n)),
                  "second_half_err": float(np.std(m2, ddof=1) / np.sqrt(n)),
                  "change": float(d.mean()), "change_err": float(e_d),
                  "trend_change": float(c.mean()), "trend_change_err": float(e_c),
                  "z": z, "drifts": bool(z > DRIFT_Z), "undetermined": False,
                  "error_lower_bound": False, "resolution": float(DRIFT_Z * e_d),
                  "false_alarm": float(2 * _t_tail(DRIFT_Z, n - 1)),
                  "steady_from_s": None}
    return out


def _t_tail(z, dof):
    """P(T > z) for Student's t (scipy.stats, imported only for an ensemble's verdict)."""
    from scipy import stats
    return stats.t.sf(z, dof)
