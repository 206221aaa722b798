"""One frame's node sums with a smoothing kernel (:class:`~granavg.engine.smoothing.
smoothed.Smoothed`): the engine's per-particle channels
(:func:`granavg.engine.kernels.particle_channels`) scattered with the kernel's weights,
the contact stress along the branch segments, the walls' forces at their contact
points, and the derivative blocks from the kernel's derivative (the stress divergence
from the particles' net contact forces and the walls' forces) - the same channels and
sums as the exact weights give cells, so that accumulators, errors, sectors and dask
merges are the engine's own.

Every scatter is one compiled loop (:func:`granavg.engine.smoothing._kernels.mixed`)
over (pair, term): where the nodes' basis is the particles' (lattices, planes) a term
per channel with the one weight; where it turns about the axis (circles, the polar
grid) the rotation's terms with the pair's five moments.
"""

from __future__ import annotations

import numpy as np

from granavg.engine.channels import BLOCK, CONTACT_BLOCKS, DERIVATIVE_BLOCKS, Block
from granavg.engine.kernels import BRANCHES, frame_rows, particle_channels, wall_points
from granavg.engine.smoothing._kernels import mixed
from granavg.engine.smoothing.rotation import block_terms

#: Particles per pass (as :data:`granavg.engine.frame_sums.CHUNK`).
CHUNK = 1 << 16
_EMPTY_SECTOR, _EMPTY_SHARE = np.zeros((1, 3), np.int64), np.zeros((1, 3))


class _Terms:
    """The scatter terms of a layout for cells whose basis turns (``turns``) or not:
    (out, in, moment, coefficient) of a block's components."""

    def __init__(self, layout, turns: bool):
        self.layout, self.turns, self.D = layout, turns, layout.dim

    def shaped(self, shape):
        """Component terms of a block of this shape."""
        if self.turns:
            return block_terms(shape, self.layout.axes)
        size = Block("", shape).size(self.D)
        return [(i, i, 0, 1.0) for i in range(size)]

    def channels(self, blocks):
        """Terms of the particles' channels: each block into itself."""
        rows = []
        for b in blocks:
            if b in self.layout.blocks:
                first = self.layout.first(b)
                rows += [(first + o, first + i, m, f)
                         for o, i, m, f in self.shaped(BLOCK[b].shape)]
        return _arrays(rows)

    def into(self, shape, dst, src):
        """Terms of a ``shape`` quantity whose components start at column ``src`` into
        the columns ``dst(o)`` of its components o (None: not wanted)."""
        return _arrays([(dst(o), src + i, m, f) for o, i, m, f in self.shaped(shape)
                        if dst(o) is not None])


def _arrays(rows):
    if not rows:
        return (np.zeros(0, np.int64),) * 3 + (np.zeros(0),)
    o, i, m, f = zip(*rows)
    return (np.asarray(o, np.int64), np.asarray(i, np.int64), np.asarray(m, np.int64),
            np.asarray(f, float))


def _scatter(item, node, W, q, terms, sector, share, sectors, out):
    if len(item) and len(terms[0]):
        mixed(item, node, np.ascontiguousarray(W), np.ascontiguousarray(q), *terms,
              sector, share, sectors, out)


def branch_halves(atoms, contacts, rows, dim, branch):
    """Each contact's halves, one per particle of it (one for a wall contact): the
    owner's row, the branch vector from its centre to the contact point (the middle of
    the overlap, or the surface for ``branch="paper"``), and the force on it."""
    i1, i2 = rows
    shorten = BRANCHES[branch]
    xyz = "xyz"[:dim]
    n = np.column_stack([np.asarray(contacts["n" + x], float) for x in xyz])
    f = np.column_stack([np.asarray(contacts["fn" + x], float) +
                         np.asarray(contacts["ft" + x], float) for x in xyz])
    overlap = np.asarray(contacts["overlap"], float)
    a = np.asarray(atoms["radius"], float)
    pair = i2 >= 0
    l1 = ((a[i1] - shorten * overlap)[:, None]) * n
    l2 = -((a[i2[pair]] - shorten * overlap[pair])[:, None]) * n[pair]
    owner = np.concatenate([i1, i2[pair]])
    return owner, np.concatenate([l1, l2]), np.concatenate([f, -f[pair]])


def _net_contact_forces(atoms, contacts, rows, dim, branch, n):
    """Each particle's net contact force (walls' included), shape (n, dim), Cartesian."""
    owner, _, f = branch_halves(atoms, contacts, rows, dim, branch)
    net = np.zeros((n, dim))
    np.add.at(net, owner, f)
    return net


#: Two branches meet where their contact points agree within this fraction of the
#: contact's length: far above a dump's rounding (LAMMPS' %g: 1e-5), far below a
#: contact point off the line of centres.
MEET = 1e-4


def branch_segments(atoms, contacts, rows, dim, branch):
    """The segments of the contact stress: :func:`branch_halves`, with the two halves of
    a contact taken as one segment from the first centre to the second (branch l1 - l2,
    force f) where they lie on one line and meet at the contact point (within
    :data:`MEET`; not across a periodic boundary, nor for ``branch="paper"``, whose
    branches overlap). The stress is the same (f (x) l1 int + (-f) (x) l2 int is
    f (x) (l1 - l2) int along the whole line), at half the segments."""
    owner, l, f = branch_halves(atoms, contacts, rows, dim, branch)
    i1, i2 = rows
    pair = np.flatnonzero(i2 >= 0)
    if BRANCHES[branch] != 0.5 or not len(pair):
        return owner, l, f
    x = np.column_stack([np.asarray(atoms[c], float) for c in "xyz"[:dim]])
    first, second = pair, len(i1) + np.arange(len(pair))        # rows of the two halves
    whole = l[first] - l[second]
    miss = np.linalg.norm(x[i1[pair]] + l[first] - x[i2[pair]] - l[second], axis=1)
    meet = miss <= MEET * np.linalg.norm(whole, axis=1)
    keep = np.ones(len(owner), bool)
    keep[second[meet]] = False
    l = l.copy()
    l[first[meet]] = whole[meet]
    return owner[keep], l[keep], f[keep]


def smoothed_frame_sums(frame, cells, rho_p, blocks, branch, sectors, layout):
    """:func:`granavg.engine.frame_sums.frame_sums` with a smoothing kernel: sums at the
    nodes, shape (n_nodes, n_channels) or (n_nodes, sectors, n_channels)."""
    a = frame.atoms
    contacts = frame.contacts
    D = cells.dim
    radius = np.asarray(a["radius"], float)
    want = set(blocks) & set(layout.blocks)
    rows = frame_rows(frame) if contacts is not None and \
        {*CONTACT_BLOCKS, "wall", "inter", "ninter", "fabinter", "dsig"} & want else None
    n = cells.n * max(sectors, 1)
    sums = np.zeros((n, layout.n))
    terms = _Terms(layout, cells.moments > 1)
    particle_blocks = [b for b in blocks if b not in ("sig", "wall", "inter",
                                                      *DERIVATIVE_BLOCKS)]
    plain = terms.channels(particle_blocks)
    deriv = bool({"dmass", "dmom", "dkin", "dsig"} & want)
    col = layout.first
    # the derivative blocks, along each basis direction j: (terms, which W to use)
    along = []
    for j in range(D if deriv else 0):
        parts = []
        if "dmass" in want:
            parts.append(terms.into("scalar", lambda o, j=j: col("dmass") + j, col("mass")))
        if "dmom" in want:
            parts.append(terms.into("vector", lambda o, j=j: col("dmom") + o * D + j,
                                    col("mom")))
        if "dkin" in want:
            parts.append(terms.into("tensor", lambda o, j=j: col("dkin") + o // D
                                    if o % D == j else None, col("kin")))
        along.append(tuple(np.concatenate(p) for p in zip(*parts)) if parts else None)
    rinv = cells.inverse_radius() if "rinv" in want else None
    rinv_terms = terms.into("scalar", lambda o: col("rinv"), col("vol")) \
        if rinv is not None else None
    segments = branch_segments(a, contacts, rows, D, branch) if rows is not None and \
        "sig" in want else None
    seg_terms = terms.into("tensor", lambda o: col("sig") + o, 0) \
        if "sig" in want else None
    # div of f (x) l int_0^1 phi(x - x_p - s l) ds is f (phi(x - x_p) - phi(x - x_p - l)):
    # summed over a contact's two halves (the forces opposite, the ends at the contact
    # point alike), each particle's net contact force at its centre, less each wall
    # contact's force at its contact point (no integral, no segment)
    div_terms = terms.into("vector", lambda o: col("dsig") + o, 0) \
        if "dsig" in want and rows is not None else None
    net = _net_contact_forces(a, contacts, rows, D, branch, len(radius)) \
        if div_terms is not None else None
    buffer = np.empty((min(CHUNK, len(radius)), layout.n))
    for lo in range(0, len(radius), CHUNK):
        part = slice(lo, lo + CHUNK)
        chunk = {k: v[part] for k, v in a.items()}
        pos = tuple(np.asarray(chunk[c], float) for c in cells.position_names)
        r = radius[part]
        E = cells.basis(pos)
        q = np.ascontiguousarray(particle_channels(
            chunk, contacts, layout, cells.particle_volume(r), cells.def_factor(r), rho_p,
            particle_blocks, basis=E, branch=branch, rows=rows, first=lo, out=buffer))
        particle, node, W, dW = cells.kernel_weights(pos, deriv)
        sector, share = cells.sector_shares(pos, r, sectors) if sectors else \
            (_EMPTY_SECTOR, _EMPTY_SHARE)
        _scatter(particle, node, W, q, plain, sector, share, sectors, sums)
        for j, t in enumerate(along):
            if t is not None:
                _scatter(particle, node, dW[:, :, j], q, t, sector, share, sectors, sums)
        if rinv is not None:
            _scatter(particle, node, W * rinv[node][:, None], q, rinv_terms, sector, share,
                     sectors, sums)
        if net is not None:
            fb = np.einsum("pij,pj->pi", E, net[part])
            _scatter(particle, node, W, fb, div_terms, sector, share, sectors, sums)
        if segments is not None:
            owner, l, f = segments
            mine = (owner >= lo) & (owner < lo + len(r))
            if mine.any():
                own = owner[mine] - lo
                Eo = E[own]
                fb = np.einsum("hij,hj->hi", Eo, f[mine])
                lb = np.einsum("hij,hj->hi", Eo, l[mine])
                Q = (fb[:, :, None] * lb[:, None, :]).reshape(-1, D * D)
                start = tuple(u[own] for u in pos)
                ss, sh = (sector[own], share[own]) if sectors else (sector, share)
                seg, snode, sW = cells.segment_weights(start, l[mine])
                _scatter(seg, snode, sW, Q, seg_terms, ss, sh, sectors, sums)
    # the walls' forces, and a species' partners' of other species, at their contact
    # points: their own blocks, and less their weights in the divergence (each is the
    # end of a branch that the contact's other half does not reach)
    for which in ("wall", "inter"):
        if contacts is None or (which not in want and div_terms is None):
            continue
        points, forces = wall_points(a, contacts, D, branch, rows, which=which)
        if not len(points):
            continue
        at = tuple(points.T)
        Fw = np.einsum("pij,pj->pi", cells.basis(at), forces)
        k, node, W, _ = cells.kernel_weights(at, False)
        sector, share = cells.sector_shares(at, np.zeros(len(points)), sectors) if sectors \
            else (_EMPTY_SECTOR, _EMPTY_SHARE)
        if which in want:
            _scatter(k, node, W, Fw, terms.into("vector", lambda o, b=which: col(b) + o, 0),
                     sector, share, sectors, sums)
        if div_terms is not None:
            _scatter(k, node, -W, Fw, div_terms, sector, share, sectors, sums)
    if "dsig" in want and rinv is not None:
        _partial(sums, layout, np.repeat(rinv, max(sectors, 1)))
    return sums.reshape(cells.n, sectors, -1) if sectors else sums


def _partial(sums, layout, rinv):
    """The stress divergence of the ends' weights is the whole divergence; the ``dsig``
    block holds the partial derivatives sum_j d_j S_ij: less, in a polar basis, the
    curvature terms the quantities add back from the values (granavg.engine.
    quantities._divergence): (S_rr - S_phiphi) / r, (S_rphi + S_phir) / r, S_zr / r."""
    D = layout.dim
    S = layout.block(sums, "sig").reshape(-1, D, D)
    first = layout.first("dsig")
    sums[:, first] -= (S[:, 0, 0] - S[:, 1, 1]) * rinv
    sums[:, first + 1] -= (S[:, 0, 1] + S[:, 1, 0]) * rinv
    if D == 3:
        sums[:, first + 2] -= S[:, 2, 0] * rinv
