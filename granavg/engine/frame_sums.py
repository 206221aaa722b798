"""One frame's sums over the cells (Eqs. 1-7 before the time average): the particles'
channels taken a chunk at a time on the engine's threads, the contacts' and the walls'
point forces; with a smoothing kernel, :func:`granavg.engine.smoothing.sums.
smoothed_frame_sums`. Pure functions of a frame's arrays."""

from __future__ import annotations

import threading

import numpy as np

from granavg.engine import threads
from granavg.engine.cells.base import layout_of
from granavg.engine.channels import CONTACT_BLOCKS
from granavg.engine.kernels import (cell_sums, frame_rows, particle_channels, sector_sums,
                                    wall_points)

#: Particles per pass of :func:`frame_sums`: the per-particle channels of a chunk (about
#: 50 doubles each in 3D) stay a few tens of MB, whatever the frame's size.
CHUNK = 1 << 16


_local = threading.local()


def _buffer(rows: int, n: int) -> np.ndarray:
    """This thread's buffer of at least (rows, n) channel values, kept from frame to
    frame (its pages are not faulted in anew for each)."""
    buf = getattr(_local, "buffer", None)
    if buf is None or buf.shape[0] < rows or buf.shape[1] != n:
        buf = _local.buffer = np.empty((rows, n))
    return buf


def _chunk_contacts(contacts, rows, lo: int, hi: int):
    """The contacts with a particle among the frame's rows lo .. hi - 1 (a chunk's), and
    their rows, in the frame's order: each particle's contact sums add up in the same
    order as over all contacts, and each contact is read by at most two chunks."""
    i1, i2 = rows
    sel = np.flatnonzero(((i1 >= lo) & (i1 < hi)) | ((i2 >= lo) & (i2 < hi)))
    return {k: np.asarray(v)[sel] for k, v in contacts.items()}, (i1[sel], i2[sel])


def frame_sums(frame, cells, rho_p: float, blocks, reach: float = 0.5,
               n_sectors: int = 0) -> np.ndarray:
    """Cell sums of one frame for any cells (:mod:`granavg.engine.cells`), the particles
    taken :data:`CHUNK` at a time, the chunks on the engine's threads
    (:mod:`granavg.engine.threads`; the result does not depend on their number).

    Returns
    -------
    ndarray, shape (n_cells, n_channels), or (n_cells, n_sectors, n_channels) with
    ``n_sectors`` > 0: the sums of each cell's sectors (the cells' ``sector_shares``),
    which add up to the cell's. ``reach``: the overlap fraction the branch vectors give
    up (:data:`~granavg.engine.kernels.BRANCHES`).
    """
    layout = layout_of(cells.axes, blocks)
    if getattr(cells, "spreads_branches", False):     # a smoothing kernel's nodes
        from granavg.engine.smoothing.sums import smoothed_frame_sums   # (on demand)
        return smoothed_frame_sums(frame, cells, rho_p, blocks, reach, n_sectors, layout)
    a = frame.atoms
    contacts = frame.contacts
    shear = getattr(frame, "shear", None)
    radius = a["radius"]
    rows = frame_rows(frame) if contacts is not None and (
        {*CONTACT_BLOCKS, "wall", "inter", "ninter", "fabinter"} & set(blocks)) else None
    n = cells.n * max(n_sectors, 1)
    rows_needed = min(CHUNK, len(radius))

    starts = range(0, len(radius), CHUNK)

    def chunk_sums(lo):
        part = slice(lo, lo + CHUNK)
        chunk = {k: v[part] for k, v in a.items()}
        pos = tuple(chunk[c] for c in cells.position_names)
        r = chunk["radius"]
        mine, mine_rows = contacts, rows
        if rows is not None and len(starts) > 1:
            mine, mine_rows = _chunk_contacts(contacts, rows, lo, lo + CHUNK)
        basis = cells.basis(pos)

        def channels(atoms, out=None):
            return particle_channels(atoms, mine, layout, cells.particle_volume(r),
                                     cells.def_factor(r), rho_p, blocks, basis=basis,
                                     reach=reach, rows=mine_rows, first=lo, out=out)
        q = channels(chunk, _buffer(rows_needed, layout.n))
        images = cells.images(pos, r, shear) if shear is not None and \
            hasattr(cells, "images") else None
        if images is None:
            particle, cell, w = cells.weights(pos, r)
        else:                           # a sheared box: images that move have own rows
            q = images.extend(q, chunk, channels)
            particle, cell, w = cells.weights(pos, r, images)
        if n_sectors:
            sector, share = cells.sector_shares(pos, r, n_sectors)
            if images is not None:
                sector, share = images.take(sector), images.take(share)
            return sector_sums(particle, cell, w, sector, share, n_sectors, q, cells.n)
        return cell_sums(particle, cell, w, q, n)

    # the chunks' sums added in chunk order: the same result on any number of threads
    sums = np.zeros((n, layout.n))
    for part in threads.map_ordered(chunk_sums, starts):
        sums += part
    for block in ("wall", "inter"):
        if block in blocks and frame.contacts is not None:
            _point_forces(sums, layout, block, frame, cells, reach, rows, n_sectors, n)
    return sums.reshape(cells.n, n_sectors, -1) if n_sectors else sums


def _point_forces(sums, layout, block, frame, cells, reach, rows, n_sectors, n):
    """Add the forces of the contacts a block takes at their contact points
    (:func:`~granavg.engine.kernels.wall_points`) to the cell of each point, in the basis
    there. A wall's point just beyond the edge cell goes to it (it lies on the wall,
    beyond the packing's cells); a point between two particles of different species
    (``inter``) only to the cell holding it: a cell's sum must not depend on which
    other cells are averaged (``--range``)."""
    a = frame.atoms
    points, forces = wall_points(a, frame.contacts, cells.dim, reach, rows, which=block)
    at = tuple(points.T)
    slack = float(np.max(a["radius"], initial=0.0)) if block == "wall" else 0.0
    where = cells.cell_of(at, slack=slack)
    E = cells.basis(at)
    inside = where >= 0
    if n_sectors:
        where = where * n_sectors + cells.sector_shares(      # radius 0: its centre's
            at, np.zeros(len(points)), n_sectors)[0][:, 0]
    first = layout.first(block)
    for i in range(cells.dim):
        along = np.einsum("pj,pj->p", forces, E[:, i, :]) if cells.dim == 3 else \
            forces[:, 0] * E[:, i, 0] + forces[:, 1] * E[:, i, 1]
        sums[:, first + i] += np.bincount(where[inside], along[inside], minlength=n)
