"""The Couette cell's state frame by frame: the observer the scene supplies to the
averaging (the engine knows no R_i, R_o or wall codes).

The paper averages a *steady* flow (Eqs. 8-12 assume d/dt = 0). :func:`frame_state`
reduces one frame to scalars that show a transient (SI units): coordination overall and
per radial zone, rattler fraction, bulk static pressure, overlaps, kinetic energy, wall
contacts, the torques on the two walls and the bulk hexatic order (over the contact
network: one pass over the contacts, no triangulation). :class:`CouetteState` records
them per frame for the averaging (:class:`~granavg.engine.cell_average.CellAverage`'s
``series``) and names the ones whose steadiness is judged
(:func:`~granavg.engine.stationarity.stationarity`).

Zones by disk centre, as fractions of the gap R_o - R_i: ``in`` [0, 0.2), ``bulk``
[0.3, 0.8), ``out`` [0.85, 1]. A rattler has fewer than two contacts. Wall codes of
granavg's contact format (:mod:`granavg.io.contacts`): 1 the inner (turning) wall, 2 the
outer.
"""

from __future__ import annotations

import numpy as np

from granavg.engine.kernels import BRANCHES, contact_rows, wall_points
from granavg.sim._contact_state import contact_state, disk_state

ZONES = {"in": (0.0, 0.2), "bulk": (0.3, 0.8), "out": (0.85, 1.0)}
#: The quantities whose steadiness is judged (when present).
JUDGED = ("C", "C_bulk", "P_bulk_Pa", "rattler_fraction", "nu_bulk", "psi6_bulk")
#: The wall codes of the inner and the outer wall.
INNER, OUTER = 1, 2


def frame_state(atoms, contacts, R_i, R_o, h, rho_p, d_ref, rows=None) -> dict:
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
    rows : tuple of ndarray, optional
        The contacts' rows among the atoms (:attr:`granavg.io.frames.Frame.rows`), if
        the reader looked them up; else looked up here.

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
    f = np.ascontiguousarray
    x, y, a = f(atoms["x"], float), f(atoms["y"], float), f(atoms["radius"], float)
    n = len(x)
    gap = R_o - R_i
    zone_area = {k: np.pi * ((R_i + hi * gap) ** 2 - (R_i + lo * gap) ** 2)
                 for k, (lo, hi) in ZONES.items()}
    out = {}
    mass = rho_p * h * np.pi * a * a
    if "vx" in atoms:
        ke = 0.5 * mass * (atoms["vx"] ** 2 + atoms["vy"] ** 2)
        if "omegaz" in atoms:
            ke = ke + 0.25 * mass * a * a * atoms["omegaz"] ** 2       # I = m a^2 / 2
        out["ke_J"] = float(np.sum(ke))
    with_contacts = contacts is not None and "id" in atoms
    if with_contacts:
        i1, i2 = rows if rows is not None else contact_rows(atoms, contacts)
        fn = ((contacts["fnx"] + contacts["ftx"]) * contacts["nx"] +
              (contacts["fny"] + contacts["fty"]) * contacts["ny"]) if "fnx" in contacts \
            else np.zeros(len(i1))
        per_disk = contact_state(f(i1, np.int64), f(i2, np.int64), f(fn, float), a, x, y, n)
    else:
        per_disk = (np.zeros(0),) * 5
    names = list(ZONES)
    sums = disk_state(x, y, a, *per_disk, R_i, R_o, np.array(list(ZONES.values()), float),
                      names.index("bulk"))
    zone = {k: sums[4 * i:4 * i + 4] for i, k in enumerate(names)}   # n, contacts, area, trace
    kept, psi, ordered, contacts_all, rattlers = sums[4 * len(names):]
    out = {"nu_bulk": float(zone["bulk"][2] / zone_area["bulk"]), **out}
    if not with_contacts:
        return out
    if kept >= 3:
        out.update(psi6_bulk=float(psi / kept), psi6_bulk_ordered=float(ordered / kept))
    out["C"] = float(contacts_all / n) if n else np.nan
    for k, (m, c, _, _) in zone.items():
        out[f"C_{k}"] = float(c / m) if m else np.nan
    out["rattler_fraction"] = float(rattlers / n) if n else np.nan
    if "fnx" in contacts:
        out["P_bulk_Pa"] = float(-0.5 * zone["bulk"][3] / (zone_area["bulk"] * h))
    if "overlap" in contacts:
        ov = contacts["overlap"] / d_ref
        out["overlap_mean_over_d"] = float(ov.mean()) if len(ov) else 0.0
        out["overlap_max_over_d"] = float(ov.max()) if len(ov) else 0.0
    out["wall_contacts_in"] = int(np.sum(contacts["wall"] == INNER))
    out["wall_contacts_out"] = int(np.sum(contacts["wall"] == OUTER))
    if "fnx" in contacts and "overlap" in contacts:
        out.update(wall_torques(atoms, contacts, (i1, i2)))
    return out


def wall_torques(atoms, contacts, rows) -> dict:
    """Torque about the centre (N m) that the packing exerts on each wall: minus the
    wall contacts' forces on the disks, at their contact points x + (a - delta/2) n
    (:func:`~granavg.engine.kernels.wall_points`), and minus their contact couples
    (``mz``: rolling resistance). The shear cell's torque, which the experiments measure
    (``torque_in_Nm`` on the turning inner ring, ``torque_out_Nm`` on the outer)."""
    points, forces = wall_points(atoms, contacts, 2, BRANCHES["contact"], rows)
    code = np.asarray(contacts["wall"])
    walls = code != 0
    code = code[walls]
    torque = -(points[:, 0] * forces[:, 1] - points[:, 1] * forces[:, 0])
    if "mz" in contacts:
        torque = torque - np.asarray(contacts["mz"], float)[walls]
    return {name: float(np.sum(torque[code == c]))
            for name, c in (("torque_in_Nm", INNER), ("torque_out_Nm", OUTER))}


class CouetteState:
    """Rows of :func:`frame_state`, one per frame, with its time step and time (s): a
    frame observer of the averaging (``add``, ``rows``, ``columns``, ``judged``).

    Parameters
    ----------
    R_i, R_o, h, rho_p, d_ref : float
        The cell's ring radii, the disks' height, their material density and the
        reference diameter of the overlaps (SI units).
    """

    judged = JUDGED

    def __init__(self, R_i, R_o, h, rho_p, d_ref):
        self.geometry = (R_i, R_o, h, rho_p, d_ref)
        self.rows = []

    def add(self, frame) -> None:
        self.rows.append({"step": frame.timestep, "t_s": frame.time,
                          **frame_state(frame.atoms, frame.contacts, *self.geometry,
                                        rows=frame.rows)})

    def columns(self) -> dict:
        """The rows as columns, name -> ndarray (NaN where a frame lacks a quantity)."""
        names = list(dict.fromkeys(k for row in self.rows for k in row))
        return {k: np.array([row.get(k, np.nan) for row in self.rows]) for k in names}
