"""The mass flux of the displacements between two consecutive frames, at a smoothing
kernel's nodes: what makes the continuity equation hold at any dump interval.

Between frames at t_f and t_f+1 = t_f + dt, particle p moves by dx_p (its two
positions paired by id, unwrapped across periodic faces). Its mass flux along the
straight segment between them,

    j_f(x) = sum_p m_p (dx_p / dt) int_0^1 W(x - x_p(t_f) - s dx_p) ds,

has the divergence sum_p m_p (W(x - x_p(t_f)) - W(x - x_p(t_f+1))) / dt, so that
rho_f+1 - rho_f = -dt div j_f exactly, whatever collisions the particle went through
in between (the density is a function of the positions alone). The time axis weighs
the intervals so that the smoothed fields keep d rho/dt + div j = 0 by summation by
parts (:meth:`~granavg.engine.timing.axes.Smoothed.flux_hits`). The segment is not the
particle's path: j is the flux that the frames fix, equal to the momentum density
rho v where the frames resolve the motion (the dumped velocities keep their own
meaning in the momentum balance and the kinetic stress).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from granavg.engine.body_forces import masses
from granavg.engine.channels import BLOCK, FLUX_BLOCKS
from granavg.engine.cells.base import layout_of
from granavg.engine.smoothing.sums import _EMPTY_SECTOR, _EMPTY_SHARE, _scatter, _Terms
from granavg.errors import UserError


@dataclass
class Kept:
    """What the flux keeps of a frame for the next: its step, time, atoms' columns (ids,
    positions, radii, masses) and box."""

    timestep: int
    time: float
    atoms: dict
    box: object | None = None
    #: the frame's mass sums at the nodes, shape (n_nodes,), where made
    mass_sums: np.ndarray | None = None


def paired(before, after, dim: int, periods=None):
    """The particles of both frames, paired by id: their rows in each and their
    displacements (minimum image along the periodic axes ``periods``: per axis its
    length or None), and how many appear or vanish between them."""
    for frame in (before, after):
        if "id" not in frame.atoms:
            raise UserError(f"time step {frame.timestep}: the atoms have no id column; the "
                            "displacements' mass flux pairs each particle's positions "
                            "across frames by id: dump the ids, or ask continuity_v (the "
                            "dumped velocities' residual) instead")
    ids0 = np.asarray(before.atoms["id"])
    ids1 = np.asarray(after.atoms["id"])
    common, r0, r1 = np.intersect1d(ids0, ids1, assume_unique=True, return_indices=True)
    xyz = "xyz"[:dim]
    dx = np.column_stack([np.asarray(after.atoms[c], float)[r1] -
                          np.asarray(before.atoms[c], float)[r0] for c in xyz])
    for k, length in enumerate(periods or ()):
        if length:
            dx[:, k] -= length * np.round(dx[:, k] / length)
    return r0, r1, dx, (len(ids0) - len(common), len(ids1) - len(common))


def box_periods(frame, cells, dim: int):
    """The periodic lengths along each axis (None where not periodic): the frame's box's,
    else (frames without one: VTK, tables, frames in memory) the cells' periods."""
    box = getattr(frame, "box", None)
    if box is not None:
        return [float(box.hi[k] - box.lo[k]) if box.periodic[k] else None
                for k in range(dim)]
    periods = getattr(getattr(cells, "cells", cells), "periods", None) or ()
    return [None if p is None else float(p[1] - p[0]) for p in periods]


def _mass_divergence(before, after, r0, r1, cells, rho_p, dt, out):
    """div j_f into ``out``: sum_p m_p (W(x - x_p(t_f)) - W(x - x_p(t_f+1))) / dt over
    the paired particles: the two frames' mass sums' difference (the averager keeps
    them for every frame whose intervals reach a time), less the unpaired particles'
    own, so that the identity holds to round-off."""
    out += (before.mass_sums - after.mass_sums) / dt
    for frame, rows, sign in ((before, r0, -1.0), (after, r1, 1.0)):
        alone = np.ones(len(frame.atoms["id"]), bool)
        alone[rows] = False
        if alone.any():                 # vanished (before) or appeared (after): no flux
            a = frame.atoms
            m = np.asarray(masses(a, cells.particle_volume, rho_p), float)[alone]
            pos = tuple(np.asarray(a[c], float)[alone] for c in cells.position_names)
            item, node, W, _ = cells.kernel_weights(pos, False)
            np.add.at(out, node, (sign / dt) * m[item] * W[:, 0])


def flux_size(blocks, dim: int) -> int:
    """Columns of the flux blocks ``blocks`` (:data:`~granavg.engine.channels.FLUX_BLOCKS`
    order) in ``dim`` dimensions."""
    return sum(BLOCK[b].size(dim) for b in FLUX_BLOCKS if b in blocks)


def displacement_sums(before, after, cells, rho_p, blocks=("jmass", "djmass")):
    """The displacements' fluxes between two consecutive frames at the nodes, shape
    (n_nodes, :func:`flux_size`): the flux blocks ``blocks`` in channel order, vectors
    and tensors in the nodes' basis (the basis at each segment's start, or at the point):

    - ``jmass``, ``djmass``: the mass flux j_f and its divergence (module docstring);
    - ``djmom``: the divergence of the displacements' momentum flux, m v (x) dx / dt
      along the segment (v at the start): m v (W(start) - W(end)) / dt;
    - ``impulse``: the forces dumped at the end frame (``fx fy fz``; LAMMPS' fix
      ave/atom over the interval: its mean force), at the end.

    Then P_f+1 - P_f = dt (sum m dv/dt W(end) - div j_p) exactly (P the momentum sums),
    and the momentum balance between frames closes with the impulse where the dumped
    forces are the interval's means. Also returns how many particles vanish and appear
    between the frames (their mass and momentum leave or enter without a flux).

    Parameters
    ----------
    before, after : Frame
        Consecutive frames (``id`` among their atoms' columns).
    cells : Smoothed
        A smoothing kernel's nodes.
    rho_p : float or None
        The material density, for masses where the frames have no mass column.
    blocks : sequence of str
        The flux blocks wanted.
    """
    D = cells.dim
    dt = after.time - before.time
    r0, r1, dx, lost = paired(before, after, D, box_periods(after, cells, D))
    out = np.zeros((cells.n, flux_size(blocks, D)))
    if not len(r0):
        return out, lost
    a0, a1 = before.atoms, after.atoms
    m = np.asarray(masses(a0, cells.particle_volume, rho_p), float)[r0]
    start = tuple(np.asarray(a0[c], float)[r0] for c in cells.position_names)
    end = tuple(np.asarray(a1[c], float)[r1] for c in cells.position_names)
    terms = _Terms(layout_of(cells.axes, ()), cells.moments > 1)
    none = (_EMPTY_SECTOR, _EMPTY_SHARE, 0)
    xyz = "xyz"[:D]
    first, col = 0, {}
    for b in FLUX_BLOCKS:
        if b in blocks:
            col[b] = first
            first += BLOCK[b].size(D)

    def into(shape, b):
        return terms.into(shape, lambda o: col[b] + o, 0)

    def at_points(pos, values, shape, b):
        item, node, W, _ = cells.kernel_weights(pos, False)
        _scatter(item, node, W, np.ascontiguousarray(values), into(shape, b), *none, out)

    if "jmass" in col:
        flux = np.einsum("pij,pj->pi", cells.basis(start), m[:, None] * dx / dt)
        _scatter(*cells.segment_weights(start, dx), np.ascontiguousarray(flux),
                 into("vector", "jmass"), *none, out)
    if "djmass" in col:
        _mass_divergence(before, after, r0, r1, cells, rho_p, dt, out[:, col["djmass"]])
    if "djmom" in col:
        p = m[:, None] * np.column_stack([np.asarray(a0["v" + c], float)[r0] for c in xyz])
        for pos, sign in ((start, 1.0), (end, -1.0)):
            E = cells.basis(pos)
            at_points(pos, np.einsum("pij,pj->pi", E, (sign / dt) * p), "vector", "djmom")
    if "impulse" in col:
        F = np.column_stack([np.asarray(a1["f" + c], float)[r1] for c in xyz])
        at_points(end, np.einsum("pij,pj->pi", cells.basis(end), F), "vector", "impulse")
    return out, lost
