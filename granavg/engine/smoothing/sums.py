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

from granavg.engine.channels import BLOCK, Block
from granavg.engine.kernels import frame_rows, particle_channels, wall_points
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

    def each(self, blocks, terms_of):
        """The terms ``terms_of(b)`` of several blocks, concatenated (None: no block)."""
        parts = [terms_of(b) for b in blocks]
        return tuple(np.concatenate(p) for p in zip(*parts)) if parts else None

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


def _scatter(item, node, W, q, terms, sector, share, n_sectors, out):
    if len(item) and len(terms[0]):
        mixed(item, node, np.ascontiguousarray(W), np.ascontiguousarray(q), *terms,
              sector, share, n_sectors, out)


def branch_halves(atoms, contacts, rows, dim, reach):
    """Each contact's halves, one per particle of it (one for a wall contact): the
    owner's row, the branch vector from its centre to the contact point (the middle of
    the overlap, ``reach`` 1/2, or the surface, 0: :data:`~granavg.engine.kernels.BRANCHES`),
    and the force on it."""
    i1, i2 = rows
    shorten = reach
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


def _net_contact_forces(atoms, contacts, rows, dim, reach, n):
    """Each particle's net contact force (walls' included), shape (n, dim), Cartesian."""
    owner, _, f = branch_halves(atoms, contacts, rows, dim, reach)
    net = np.zeros((n, dim))
    np.add.at(net, owner, f)
    return net


#: Two branches meet where their contact points agree within this fraction of the
#: contact's length: far above a dump's rounding (LAMMPS' %g: 1e-5), far below a
#: contact point off the line of centres.
MEET = 1e-4


def branch_segments(atoms, contacts, rows, dim, reach):
    """The segments of the contact stress: :func:`branch_halves`, with the two halves of
    a contact taken as one segment from the first centre to the second (branch l1 - l2,
    force f) where they lie on one line and meet at the contact point (within
    :data:`MEET`; not across a periodic boundary, nor for ``reach`` 0 (``paper``), whose
    branches overlap). The stress is the same (f (x) l1 int + (-f) (x) l2 int is
    f (x) (l1 - l2) int along the whole line), at half the segments."""
    owner, l, f = branch_halves(atoms, contacts, rows, dim, reach)
    i1, i2 = rows
    pair = np.flatnonzero(i2 >= 0)
    if reach != 0.5 or not len(pair):
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


def smoothed_frame_sums(frame, cells, rho_p, blocks, reach, n_sectors, layout):
    """:func:`granavg.engine.frame_sums.frame_sums` with a smoothing kernel: sums at the
    nodes, shape (n_nodes, n_channels) or (n_nodes, n_sectors, n_channels). Each block
    is spread as the channels' registry declares it (:data:`~granavg.engine.channels.
    SPREADS`: :attr:`~granavg.engine.channels.Block.spread` and ``of``)."""
    a, contacts = frame.atoms, frame.contacts
    want = set(blocks) & set(layout.blocks)
    rows = frame_rows(frame) if contacts is not None and \
        any(BLOCK[b].contacts for b in want) else None
    plan = _Spreads(frame, cells, layout, blocks, want, rows, reach)
    radius = np.asarray(a["radius"], float)
    sums = np.zeros((cells.n * max(n_sectors, 1), layout.n))
    buffer = np.empty((min(CHUNK, len(radius)), layout.n))
    for lo in range(0, len(radius), CHUNK):
        part = slice(lo, lo + CHUNK)
        chunk = {k: v[part] for k, v in a.items()}
        pos = tuple(np.asarray(chunk[c], float) for c in cells.position_names)
        r = radius[part]
        E = cells.basis(pos)

        def channels(atoms, out=None):
            return particle_channels(atoms, contacts, layout, cells.particle_volume(r),
                                     cells.def_factor(r), rho_p, plan.particle_blocks,
                                     basis=E, reach=reach, rows=rows, first=lo, out=out)
        q = channels(chunk, buffer)
        sector, share = cells.sector_shares(pos, r, n_sectors) if n_sectors else \
            (_EMPTY_SECTOR, _EMPTY_SHARE)
        images = cells.images(pos, plan.shear) if plan.shear is not None else None
        if images is not None:          # a sheared box: images that move have own rows
            q = images.extend(q, chunk, channels)
            if n_sectors:
                sector, share = images.take(sector), images.take(share)
        plan.chunk(sums, np.ascontiguousarray(q), pos, E, part, (sector, share, n_sectors),
                   images)
    # the contacts taken at their points (the walls', a species' partners' of other
    # species): their own blocks, and less their weights in the divergence (each is the
    # end of a branch that the contact's other half does not reach)
    for which in POINTS:
        if contacts is not None and (which in want or plan.div_terms is not None):
            plan.points(sums, which, which in want, n_sectors)
    if plan.rinv is not None:
        for b in plan.kinds.get("force_divergence", []):
            _partial(sums, layout, b, np.repeat(plan.rinv, max(n_sectors, 1)))
    return sums.reshape(cells.n, n_sectors, -1) if n_sectors else sums


class _Spreads:
    """The scatter terms of one frame's blocks, each kind of spread its own
    (:data:`~granavg.engine.channels.SPREADS`), and what they need of the frame: the
    kernel's derivative, the nodes' 1/r, the branch segments, the net contact forces."""

    def __init__(self, frame, cells, layout, blocks, want, rows, reach):
        a, contacts, D = frame.atoms, frame.contacts, cells.dim
        self.cells, self.frame, self.rows, self.reach = cells, frame, rows, reach
        self.shear = getattr(frame, "shear", None)
        self.kinds = {}
        for b in layout.blocks:                   # the blocks of each spread, in order
            if b in want:
                self.kinds.setdefault(BLOCK[b].spread, []).append(b)
        terms = self.terms = _Terms(layout, cells.moments > 1)
        col = self.col = layout.first
        self.particle_blocks = [b for b in blocks if BLOCK[b].spread == "particle"]
        self.plain = terms.channels(self.particle_blocks)
        self.deriv = bool({"gradient", "divergence", "force_divergence"} & set(self.kinds))
        derived = [b for b in layout.blocks
                   if b in want and BLOCK[b].spread in ("gradient", "divergence")]
        # the derivatives along each basis direction j (their W: dW[:, :, j])
        self.along = [terms.each(derived, lambda b, j=j: _derivative(terms, b, j, D, col))
                      for j in range(D if self.deriv else 0)]
        scaled = self.kinds.get("inverse_radius", [])
        self.rinv = cells.inverse_radius() if scaled else None
        self.rinv_terms = terms.each(scaled, lambda b: terms.into(
            BLOCK[BLOCK[b].of].shape, lambda o: col(b) + o, col(BLOCK[b].of)))
        along_segments = self.kinds.get("segment", [])
        self.segments = branch_segments(a, contacts, rows, D, reach) \
            if rows is not None and along_segments else None
        self.seg_terms = terms.each(along_segments, self._own)
        # div of f (x) l int_0^1 phi(x - x_p - s l) ds is f (phi(x - x_p) - phi(x - x_p -
        # l)): summed over a contact's two halves (the forces opposite, the ends at the
        # contact point alike), each particle's net contact force at its centre, less
        # each contact point's force (no integral, no segment)
        self.div_terms = terms.each(self.kinds.get("force_divergence", []), self._own) \
            if rows is not None else None
        self.net = _net_contact_forces(a, contacts, rows, D, reach, len(a["radius"])) \
            if self.div_terms is not None else None

    def _own(self, b):
        """Terms of a quantity of block ``b``'s shape, from column 0, into ``b``."""
        return self.terms.into(BLOCK[b].shape, lambda o: self.col(b) + o, 0)

    def chunk(self, sums, q, pos, E, part, shares, images=None):
        """Scatter a chunk of the particles (rows ``part``; ``q`` their channels, ``E``
        their basis, ``shares`` (sector, share, n_sectors) their shares; with
        ``images`` of a sheared box, ``q`` and the shares have their rows too)."""
        cells, D = self.cells, self.cells.dim
        particle, node, W, dW = cells.kernel_weights(pos, self.deriv, images)
        _scatter(particle, node, W, q, self.plain, *shares, sums)
        for j, t in enumerate(self.along):
            if t is not None:
                _scatter(particle, node, dW[:, :, j], q, t, *shares, sums)
        if self.rinv is not None:
            _scatter(particle, node, W * self.rinv[node][:, None], q, self.rinv_terms,
                     *shares, sums)
        if self.net is not None:
            fb = np.einsum("pij,pj->pi", E, self.net[part])
            if images is not None:
                fb = images.take(fb)
            _scatter(particle, node, W, fb, self.div_terms, *shares, sums)
        if self.segments is None:
            return
        owner, l, f = self.segments
        lo = part.start
        mine = (owner >= lo) & (owner < lo + len(pos[0]))
        if mine.any():
            own = owner[mine] - lo
            Eo = E[own]
            fb = np.einsum("hij,hj->hi", Eo, f[mine])
            lb = np.einsum("hij,hj->hi", Eo, l[mine])
            Q = (fb[:, :, None] * lb[:, None, :]).reshape(-1, D * D)
            sector, share, n_sectors = shares
            ss, sh = (sector[own], share[own]) if n_sectors else (sector, share)
            seg, snode, sW = cells.segment_weights(tuple(u[own] for u in pos), l[mine],
                                                   self.shear)
            _scatter(seg, snode, sW, Q, self.seg_terms, ss, sh, n_sectors, sums)

    def points(self, sums, which, wanted, n_sectors):
        """Scatter the forces of the contacts block ``which`` takes at their points: into
        it (``wanted``), and less their weights in the force divergence."""
        points, forces = wall_points(self.frame.atoms, self.frame.contacts, self.cells.dim,
                                     self.reach, self.rows, which=which)
        if not len(points):
            return
        cells, at = self.cells, tuple(points.T)
        Fw = np.einsum("pij,pj->pi", cells.basis(at), forces)
        k, node, W, _ = cells.kernel_weights(at, False, shear=self.shear)
        sector, share = cells.sector_shares(at, np.zeros(len(points)), n_sectors) \
            if n_sectors else (_EMPTY_SECTOR, _EMPTY_SHARE)
        if wanted:
            _scatter(k, node, W, Fw, self._own(which), sector, share, n_sectors, sums)
        if self.div_terms is not None:
            _scatter(k, node, -W, Fw, self.div_terms, sector, share, n_sectors, sums)


#: The blocks taken at the contacts' points, in the channels' order (the walls', then a
#: species' partners'): :func:`~granavg.engine.kernels.wall_points` of each.
POINTS = tuple(b.name for b in BLOCK.values() if b.spread == "point")


def _derivative(terms, b, j, D, col):
    """The terms of block ``b``'s derivative along basis direction j from its block
    ``of``: the gradient's component (o, j), or the divergence's o // D where o % D is j."""
    of = BLOCK[b].of
    if BLOCK[b].spread == "gradient":
        return terms.into(BLOCK[of].shape, lambda o: col(b) + o * D + j, col(of))
    return terms.into(BLOCK[of].shape, lambda o: col(b) + o // D if o % D == j else None,
                      col(of))


def _partial(sums, layout, block, rinv):
    """The stress divergence of the ends' weights is the whole divergence; ``block``
    (the divergence of its block ``of``, the stress) holds the partial derivatives
    sum_j d_j S_ij: less, in a polar basis, the curvature terms the quantities add back
    from the values (granavg.engine.quantities._divergence): (S_rr - S_phiphi) / r,
    (S_rphi + S_phir) / r, S_zr / r."""
    D = layout.dim
    S = layout.block(sums, BLOCK[block].of).reshape(-1, D, D)
    first = layout.first(block)
    sums[:, first] -= (S[:, 0, 0] - S[:, 1, 1]) * rinv
    sums[:, first + 1] -= (S[:, 0, 1] + S[:, 1, 0]) * rinv
    if D == 3:
        sums[:, first + 2] -= S[:, 2, 0] * rinv
