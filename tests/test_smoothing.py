"""Smoothing kernels (granavg.engine.smoothing): fields at the nodes of any cells, held to
mathematics with references computed here by other means (exact norms; the circle
moments and the branch segments' line integrals against adaptive quadrature between
break points found here; a ring node against the mean of the Cartesian field's polar
components around its circle; mass and momentum conserved; a rigid rotation's rates),
to physics on LAMMPS piles of our own decks (the momentum balance pointwise from the
kernel's own derivative, the weight carried), to the Couette cell (the torque through
every circle), to the exact weights' limit (the top hat across slabs counts centres),
and through the CLI (refusals, dask bit for bit)."""

import math

import numpy as np
import pytest
from scipy import integrate, optimize

from granavg.engine import average
from granavg.cells import Boxes, Grid, PolarGrid, Rings, Shells, Slabs, Slabs3D
from granavg.engine.frame_sums import frame_sums
from granavg.engine.cells.base import layout_of
from granavg.engine.smoothing import get, registry, smooth
from granavg.engine.smoothing._kernels import moments_at, point_pairs
from granavg.engine.smoothing.circles import RingTables
from granavg.engine.smoothing.smoothed import Smoothed
from granavg.io.profiles_io import read_profiles

from .helpers import MAP3, PILE2D_MAP as MAP2, last_rows, run_cli

KERNELS = sorted(registry())


def quad(f, a, b, points=None):
    return integrate.quad(f, a, b, points=points, epsabs=1e-15, epsrel=1e-13, limit=400)[0]


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_every_kernel_integrates_to_one(name, dim):
    k = get(name)
    w = 0.37
    c = k.cutoff(w)
    shell = {1: lambda r: 2.0, 2: lambda r: 2 * math.pi * r, 3: lambda r: 4 * math.pi * r * r}
    total = quad(lambda r: shell[dim](r) * k.value(np.array([r]), w, dim)[0], 0.0, c)
    assert abs(total - 1.0) < 1e-12


# -- circles: the moments, the rings' tables ------------------------------------------------

def circle_moment(k, c, rho, dz, R, order, dim):
    """(1/pi) int_0^pi phi(d) cos(order delta), by adaptive quadrature up to the support's
    end (found here from the law of cosines)."""
    scale = k.norms[dim] / c ** dim
    gap = (c - R + rho) * (c + R - rho) - dz * dz       # c^2 - e^2 (no cancellation)
    if gap <= 0:
        return 0.0
    a0 = math.pi if gap >= 4 * rho * R else 2 * math.asin(math.sqrt(gap / (4 * rho * R)))

    def f(a):
        d = math.sqrt(max((rho - R) ** 2 + dz * dz + 4 * rho * R * math.sin(a / 2) ** 2, 0))
        return scale * k.g(d / c) * math.cos(order * a) if d < c else 0.0
    return quad(f, 0.0, a0, points=[p for p in (1e-6, 1e-4, 1e-2) if p < a0]) / math.pi


CIRCLE_CASES = [(0.3, 0.0, 0.31), (0.3, 0.0, 0.3), (0.3, 1e-7, 0.3), (0.3, 1e-4, 0.3),
                (0.3, 0.002, 0.301), (0.01, 0.0, 0.02), (0.005, 0.001, 0.01),
                (0.02, 0.0, 0.02 + 1e-9), (0.1, 0.0, 0.1 - 0.01), (1e-6, 0.0, 0.02)]


@pytest.mark.parametrize("name", KERNELS)
def test_the_circle_moments_are_exact(name):
    """mu_k (k = 0, 1, 2) of points on, near and far from the circle, inside it and
    swallowing it, against adaptive quadrature: within 1e-13 of the kernel's scale;
    their derivatives against central differences."""
    k = get(name)
    c = 0.02 * k.support
    scale = k.norms[3] / c ** 3
    rho, dz, R = (np.array(v) for v in zip(*CIRCLE_CASES))
    got = moments_at(k.packed, scale, c, rho, dz, R, True)
    for i, case in enumerate(CIRCLE_CASES):
        for order in range(3):
            true = circle_moment(k, c, *case, order, 3)
            assert abs(got[i, order] - true) < 1e-13 * scale, (case, order)
    if not k.smooth_edge:
        return
    h = 1e-7
    for i, (r_, z_, R_) in enumerate(CIRCLE_CASES):
        if min(abs(r_ - R_), r_) < 1e-3:          # the derivatives' own kink
            continue
        up = moments_at(k.packed, scale, c, *(np.array([v]) for v in (r_, z_, R_ + h)), False)
        dn = moments_at(k.packed, scale, c, *(np.array([v]) for v in (r_, z_, R_ - h)), False)
        assert np.allclose(got[i, 3:6], (up - dn)[0, :3] / (2 * h), atol=1e-5 * scale / c)
        up = moments_at(k.packed, scale, c, *(np.array([v]) for v in (r_, z_ - h, R_)), False)
        dn = moments_at(k.packed, scale, c, *(np.array([v]) for v in (r_, z_ + h, R_)), False)
        assert np.allclose(got[i, 6:9], (up - dn)[0, :3] / (2 * h), atol=1e-5 * scale / c)


@pytest.mark.parametrize("name", KERNELS)
@pytest.mark.parametrize("w", [0.002, 0.03, 0.1])
def test_the_rings_tables_hold_the_moments(name, w):
    """The rings' Chebyshev tables against the moments computed point by point, rings
    from 0.05 to 25 support radii: within 2e-11 of the kernel's scale, up to 1e-9 c
    from their breakpoints, and exactly on the circle."""
    k = get(name)
    c = k.cutoff(w)
    scale = k.norms[2] / c ** 2
    radii = np.array([0.005, 0.01, 0.03, 0.1, 0.2])
    tables = RingTables(k, c, radii)
    for j, R in enumerate(radii):
        rho = np.r_[np.linspace(max(R - c, 0) + 1e-9 * c, R + c - 1e-9 * c, 1500), R,
                    R + np.logspace(-9, -1, 20) * c, R - np.logspace(-9, -1, 20) * c]
        rho = rho[rho > 0]
        exact = moments_at(k.packed, scale, c, rho, np.zeros_like(rho), np.full_like(rho, R),
                           True)[:, :6]
        err = np.abs(tables.at(j, rho) - exact) / scale
        err[:, 3:] *= c
        assert err.max() < 2e-11, (R / c, rho[np.argmax(err.max(axis=1))])


# -- branch segments: line integrals ---------------------------------------------------------

def kinks(cells, s, x0, l, k):
    """Where node k's weight along x0 + t l is not smooth, found here: the support's
    ends and the closest approach (points, planes), the crossings of R, R +- c, |R - c|
    (rings), e(t) = c, (rho + R)^2 + dz^2 = c^2 and the closest approach (shells)."""
    c = s.cutoff
    kind, *spec = cells.nodes()
    D = cells.dim
    out = []

    def roots(A, B, C):                     # A t^2 + 2 B t + C = 0
        disc = B * B - A * C
        return [] if A == 0 or disc < 0 else [(-B - math.sqrt(disc)) / A,
                                               (-B + math.sqrt(disc)) / A]
    if kind in ("lattice", "polar"):
        if kind == "lattice":
            idx = np.unravel_index(k, [len(a) for a in spec[0]])
            n = np.array([spec[0][d][idx[d]] for d in range(D)])
        else:
            center, radii, phis = spec
            R, p = radii[k // len(phis)], phis[k % len(phis)]
            n = np.array([center[0] + R * math.cos(p), center[1] + R * math.sin(p)])
        d = x0 - n
        out += roots(l @ l, l @ d, d @ d - c * c) + [-(l @ d) / (l @ l)]
    elif kind == "planes":
        axis, centres, _ = spec
        if l[axis]:
            out += [(centres[k] + e - x0[axis]) / l[axis] for e in (-c, 0.0, c)]
    else:
        center, radii, heights = spec
        R, h = radii[k // len(heights)], heights[k % len(heights)]
        p0, lp = x0[:2] - np.asarray(center), l[:2]
        if D == 2:
            for b in (R, R + c, abs(R - c)):
                out += roots(lp @ lp, lp @ p0, p0 @ p0 - b * b)
        else:
            def at(t):
                return math.hypot(*(p0 + t * lp)), x0[2] + t * l[2] - h
            fs = (lambda t: (at(t)[0] - R) ** 2 + at(t)[1] ** 2 - c * c,
                  lambda t: (at(t)[0] + R) ** 2 + at(t)[1] ** 2 - c * c)
            ts = np.linspace(0, 1, 2001)
            for f in fs:
                v = np.array([f(t) for t in ts])
                out += [optimize.brentq(f, ts[i], ts[i + 1], xtol=1e-15)
                        for i in np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))]
            i = int(np.argmin([fs[0](t) for t in ts]))
            out.append(optimize.minimize_scalar(fs[0], bounds=(ts[max(i - 1, 0)],
                                                               ts[min(i + 1, 2000)]),
                                                method="bounded",
                                                options={"xatol": 1e-14}).x)
    return sorted(t for t in out if 1e-9 < t < 1 - 1e-9)    # (quad fails on slivers)


def turn(W, delta):
    """Moments of quantities in the basis at phi turned to the basis at phi - delta."""
    z1 = (W[1] + 1j * W[2]) * np.exp(1j * delta)
    z2 = (W[3] + 1j * W[4]) * np.exp(2j * delta)
    return np.array([W[0], z1.real, z1.imag, z2.real, z2.imag])


def line_errors(cells, name, width, starts, branches):
    """The largest error of the segments' weights (every moment) against adaptive
    quadrature of the point weights along them (turned, where the basis turns, from each
    point's azimuth to the start's), over max(|value|, 1e-3 of the largest weight)."""
    s = Smoothed(cells, get(name), width)
    D = cells.dim
    seg, node, W = s.segment_weights(tuple(starts.T), branches)
    centre = getattr(cells, "center", (0.0, 0.0))
    top = np.abs(W[:, 0]).max()
    worst = 0.0
    for i, k, got in zip(seg, node, W):
        x0, l = starts[i], branches[i]
        phi0 = math.atan2(x0[1] - centre[1], x0[0] - centre[0])

        def at(t, m):
            p = x0 + t * l
            _, kn, Wp, _ = s.kernel_weights(tuple(np.array([u]) for u in p), False)
            Wk = Wp[kn == k]
            if not len(Wk):
                return 0.0
            if len(got) == 1:
                return Wk[0, 0]
            return turn(Wk[0], math.atan2(p[1] - centre[1], p[0] - centre[0]) - phi0)[m]
        points = kinks(cells, s, x0, l, k) or None
        for m in range(len(got)):
            true = quad(lambda t: at(t, m), 0.0, 1.0, points=points)
            worst = max(worst, abs(got[m] - true) / max(abs(true), 1e-3 * top))
    assert D == starts.shape[1]
    return worst


CELLS = {"grid": Grid(np.linspace(0, 1, 11), np.linspace(0, 1, 11), 1.0),
         "slabs": Slabs(np.linspace(0, 1, 11), 1.0, "y", 1.0),
         "rings": Rings(np.linspace(0.2, 1.0, 9), 1.0),
         "polar grid": PolarGrid(np.linspace(0.2, 1.0, 9), 12, 1.0),
         "boxes": Boxes(*[np.linspace(0, 1, 6)] * 3),
         "shells": Shells(np.linspace(0.2, 1.0, 9), np.linspace(-0.5, 0.5, 4))}


@pytest.mark.parametrize("cells", CELLS.values(), ids=CELLS.keys())
@pytest.mark.parametrize("name", KERNELS)
def test_a_segments_line_integral_is_the_quadrature_of_its_points(cells, name):
    """The weights of random branch segments in each node, int_0^1 W(x0 + s l) ds:
    within 1e-10 of adaptive quadrature of the nodes' point weights along them."""
    rng = np.random.default_rng(7)
    D = cells.dim
    starts = rng.uniform(0.3, 0.7, (8, D))
    if cells.nodes()[0] in ("circles", "polar"):
        starts[:, 1] = rng.uniform(-0.4, 0.4, 8)
    width = 0.03 if name == "gauss" else 0.09
    assert line_errors(cells, name, width, starts, rng.normal(0, 0.04, (8, D))) < 1e-10


@pytest.mark.parametrize("name", [pytest.param(k, marks=pytest.mark.slow)
                                  if k == "heaviside" else k for k in KERNELS])
@pytest.mark.parametrize("beyond", [0.0, 1e-6, 1e-3, 0.02, 0.1])
def test_a_kink_just_beyond_a_segments_end_costs_no_accuracy(name, beyond):
    """Segments ending a little short of a ring's kinks (the support's edges, the
    circle): the weight goes like a half-integer power there, and Gauss-Legendre on a
    piece ending next to it would lose digits (a square root: 1e-5 of the value); still
    within 1e-10."""
    cells = CELLS["rings"]
    s = Smoothed(cells, get(name), 0.03 if name == "gauss" else 0.09)
    R, c = cells.nodes()[2][4], s.cutoff
    starts, branches = [], []
    for b in (R - c, R, R + c):
        for angle, tilt in ((0.0, 0.3), (0.7, -0.5)):
            u = np.array([math.cos(angle), math.sin(angle)])
            d = 0.05 * np.array([math.cos(angle + tilt), math.sin(angle + tilt)])
            starts += [b * u - (1 + beyond) * d, b * u + (1 + beyond) * d]
            branches += [d, -d]
    assert line_errors(cells, name, s.width, np.array(starts), np.array(branches)) < 1e-10


# -- a ring node is the circle mean of the field's polar components --------------------------

def synthetic_frame(rng, n=60, contacts=30, touching=10):
    """Disks in an annulus with random velocities and random contacts (forces and normals
    need not balance: the sums are linear in them); the first ``touching`` contacts join
    disks 2i+1 and 2i+2 placed in contact along their normal (branches on one line,
    meeting at the contact point: one segment of the stress, the others two)."""
    r, p = rng.uniform(0.25, 0.45, n), rng.uniform(0, 2 * np.pi, n)
    atoms = {"id": np.arange(1, n + 1), "x": r * np.cos(p), "y": r * np.sin(p),
             "radius": rng.uniform(0.008, 0.012, n), "vx": rng.normal(size=n),
             "vy": rng.normal(size=n), "omegaz": rng.normal(size=n)}
    i1 = rng.integers(1, n + 1, contacts)
    i2 = np.where(rng.random(contacts) < 0.8, rng.integers(1, n + 1, contacts), 0)
    i2 = np.where(i2 == i1, 0, i2)
    a = rng.uniform(0, 2 * np.pi, contacts)
    cols = {"id1": i1, "id2": i2, "wall": (i2 == 0).astype(int), "nx": np.cos(a),
            "ny": np.sin(a), "fnx": rng.normal(size=contacts),
            "fny": rng.normal(size=contacts),
            "ftx": rng.normal(size=contacts), "fty": rng.normal(size=contacts),
            "overlap": rng.uniform(0, 1e-3, contacts)}
    for k in range(touching):
        i, j = 2 * k, 2 * k + 1
        cols["id1"][k], cols["id2"][k], cols["wall"][k] = i + 1, j + 1, 0
        gap = atoms["radius"][i] + atoms["radius"][j] - cols["overlap"][k]
        atoms["x"][j] = atoms["x"][i] + gap * cols["nx"][k]
        atoms["y"][j] = atoms["y"][i] + gap * cols["ny"][k]
    return type("F", (), {"timestep": 0, "time": 0.0, "atoms": atoms, "contacts": cols})()


#: Points around each circle for the reference (the trapezoid on Lucy's C^2 edge:
#: 4096 points leave 1e-8, 16384 4e-11).
ALPHA = 16384


@pytest.mark.slow
def test_a_ring_node_is_the_circle_mean_of_the_polar_components():
    """The sums of ring nodes (velocity, kinetic tensor, contact stress, wall forces)
    against the Cartesian coarse-grained fields computed here with point nodes on
    :data:`ALPHA` points of each circle, projected on the local polar basis and averaged: the
    particles' own basis turned to the node's, not applied as is."""
    rng = np.random.default_rng(3)
    frame = synthetic_frame(rng)
    rings = Rings(np.linspace(0.2, 0.5, 7), 0.01)
    s = Smoothed(rings, get("lucy"), 0.05)
    blocks = ["vol", "mass", "mom", "kin", "sig", "wall"]
    S = frame_sums(frame, s, 1.0, blocks, n_sectors=0)
    layout = layout_of(("r", "phi"), blocks)
    k = get("lucy")
    c = s.cutoff
    scale = k.norms[2] / c ** 2
    at = frame.atoms
    x = np.column_stack([at["x"], at["y"]])
    m = np.pi * at["radius"] ** 2 * 0.01
    v = np.column_stack([at["vx"], at["vy"]])
    # the contact stress's segments and the walls' contact points, Cartesian
    from granavg.engine.kernels import contact_rows, wall_points
    from granavg.engine.smoothing.sums import branch_halves, branch_segments
    rows = contact_rows(at, frame.contacts)
    owner, l, f = branch_halves(at, frame.contacts, rows, 2, 0.5)
    # the sums took the touching contacts as one segment each, the reference two halves
    assert len(branch_segments(at, frame.contacts, rows, 2, 0.5)[0]) == len(owner) - 10
    wp, wf = wall_points(at, frame.contacts, 2, 0.5, rows)
    alpha = np.linspace(0, 2 * np.pi, ALPHA, endpoint=False)
    for j, R in enumerate(rings.centre):
        P = R * np.column_stack([np.cos(alpha), np.sin(alpha)])
        er, ephi = P / R, np.column_stack([-P[:, 1], P[:, 0]]) / R
        basis = np.stack([er, ephi], axis=1)

        def field(points_at, values):
            """sum_p values_p phi(|P - x_p|) at the circle's points (point nodes)."""
            item = np.repeat(np.arange(len(points_at)), len(P))
            node = np.tile(np.arange(len(P)), len(points_at))
            w, dw = np.zeros(len(item)), np.zeros((len(item), 2))
            point_pairs(np.ascontiguousarray(points_at), P, basis, item, node, k.packed,
                        scale, c, False, w, dw)
            return np.einsum("ak,ak...->k...", w.reshape(len(points_at), len(P)),
                             np.broadcast_to(values[:, None], (len(points_at), len(P))
                                             + values.shape[1:]))
        mom = field(x, m[:, None] * v)
        kin = field(x, m[:, None, None] * v[:, :, None] * v[:, None, :])
        wall = field(wp, wf)
        # the stress along the segments: their points, 64 per segment (Gauss-Legendre)
        gx, gw = np.polynomial.legendre.leggauss(64)
        t = 0.5 * (gx + 1)
        pts = (x[owner][:, None, :] + t[None, :, None] * l[:, None, :]).reshape(-1, 2)
        fl = (f[:, :, None] * l[:, None, :])[:, None] * (0.5 * gw)[None, :, None, None]
        sig = field(pts, fl.reshape(-1, 2, 2))
        V = rings.volume[j] / rings.h

        def polar_vector(F):
            return np.array([np.mean(np.einsum("ki,ki->k", F, er)),
                             np.mean(np.einsum("ki,ki->k", F, ephi))])

        def polar_tensor(T):
            return np.array([[np.mean(np.einsum("ki,kij,kj->k", a, T, b)) for b in (er, ephi)]
                             for a in (er, ephi)]).ravel()
        for block, true in (("mom", polar_vector(mom)), ("kin", polar_tensor(kin)),
                            ("sig", polar_tensor(sig)), ("wall", polar_vector(wall))):
            got = layout.block(S, block)[j]
            assert np.allclose(got, V * true, rtol=0, atol=1e-9 * np.abs(V * true).max()), \
                (block, R, got, V * true)


def test_mass_and_momentum_are_conserved_across_planes_and_circles():
    """The coarse-grained density integrated over space is the particles' mass, its
    momentum their momentum (adaptive quadrature over the node's position)."""
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0.3, 0.6, 5), rng.uniform(-0.2, 0.2, 5)
    a = np.full(5, 0.01)
    vol = math.pi * a ** 2                      # disks of height 1
    vx = rng.normal(size=5)
    for name in KERNELS:
        k = get(name)
        w = 0.05

        def plane_density(u, velocity=False):
            s = Smoothed(Slabs(np.array([u - 1e-3, u + 1e-3]), 1.0, "x", 1.0), k, w)
            p, _, ww = s.weights((x, y), a)
            return float(np.sum(ww * vol[p] * (vx[p] if velocity else 1.0))) / s.volume[0]
        breaks = np.sort(np.r_[x - k.cutoff(w), x + k.cutoff(w)])
        assert abs(quad(plane_density, 0.0, 1.0, points=breaks) - vol.sum()) < \
            1e-10 * vol.sum(), name
        mom = quad(lambda u: plane_density(u, True), 0.0, 1.0, points=breaks)
        assert abs(mom - np.sum(vol * vx)) < 1e-10 * np.sum(np.abs(vol * vx)), name

        # around circles: each particle's circle means over all R, 2 pi R mu_0(rho; R),
        # integrate to one (the rings' tables hold mu_0: test_the_rings_tables_...)
        c = k.cutoff(w)
        for rho in np.hypot(x, y):
            def ring(R):
                return 2 * math.pi * R * moments_at(k.packed, k.norms[2] / c ** 2, c,
                                                    np.array([rho]), np.zeros(1),
                                                    np.array([R]), False)[0, 0]
            total = quad(ring, max(rho - c, 0.0), rho + c, points=[rho])
            assert abs(total - 1.0) < 1e-10, name


def rigid_rotation(cells, step, omega, width=0.03):
    """Disks on a square lattice of spacing ``step`` moving as v = Omega x r, averaged
    with Lucy."""
    g = np.arange(-0.3, 0.3001, step)
    X, Y = (u.ravel() for u in np.meshgrid(g, g))
    atoms = {"x": X, "y": Y, "radius": np.full(X.size, 0.4 * step), "vx": -omega * Y,
             "vy": omega * X, "omegaz": np.full(X.size, omega)}
    frames = [type("F", (), {"timestep": k, "time": 0.1 * k, "atoms": atoms,
                             "contacts": None})() for k in range(3)]
    return average(frames, Smoothed(cells, get("lucy"), width), density=1.0,
                   quantities=["nu", "v", "gradv", "D", "W"], sectors=None)


@pytest.mark.parametrize("cells", [Grid(np.linspace(-0.15, 0.15, 7),
                                        np.linspace(-0.15, 0.15, 7), 1.0),
                                   Rings(np.linspace(0.05, 0.2, 7), 1.0)],
                         ids=["grid", "rings"])
def test_a_rigid_rotation_has_no_deformation_and_its_rotation_rate(cells):
    """v = Omega x r: at every interior node v_phi = Omega r (rings), W_xy or W_rphi =
    Omega and D = 0 from the kernel's derivative, up to the lattice's discreteness (the
    kernel's moments over a lattice three spacings wide: 6e-3 on the grid, 1.5e-4 at
    rings), which falls off as the lattice is refined: the fields are the continuum's
    (at rings: the polar components turned from each particle's basis, not taken as
    they are)."""
    omega = 0.7
    polar = isinstance(cells, Rings)
    inner = slice(1, -1) if polar else slice(None)
    spin, rates = ("W_rphi", ("rr", "rphi", "phiphi")) if polar else ("W_xy", ("xx", "xy",
                                                                            "yy"))
    errors = []
    for step in (0.01, 0.005, 0.0025):
        p = rigid_rotation(cells, step, omega)
        errors.append(max(np.max(np.abs(p.values["v_phi"] / (omega * cells.centre) - 1))
                          if polar else 0.0,
                          np.max(np.abs(p.values[spin][inner] / omega - 1)),
                          *(np.max(np.abs(p.values[f"D_{c}"][inner])) / omega for c in rates)))
    assert errors[0] < 1e-2 and errors[1] < errors[0] / 2 and errors[2] < errors[1] / 2 \
        and errors[2] < 2e-4, errors


# -- LAMMPS piles of our own decks ---------------------------------------------------------

@pytest.fixture(scope="module")
def pile2d(pile2d_on_disks):
    """tests/decks/pile_2d_lj.lmp on its floor of wall disks (a session's run)."""
    return pile2d_on_disks


@pytest.fixture(scope="module")
def pile3d(pile3d_soft):
    """tests/decks/pile_3d_si.lmp with k_n = 20 N/m (a session's run)."""
    return pile3d_soft


def survival(kernel, w, u):
    """The share of a particle's smoothed mass beyond u across the planes (1D)."""
    c = kernel.cutoff(w)
    if u >= c:
        return 0.0
    if u <= -c:
        return 1.0
    return quad(lambda t: kernel.value(np.array([abs(t)]), w, 1)[0], u, c)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["2d", "3d"])
def test_a_pile_balances_at_every_node_and_carries_its_weight(case, pile2d, pile3d, tmp_path):
    """A pile at rest, default dump format, Lucy of width one diameter across slabs:
    div(sigma) + b + t = 0 at every bulk node to 0.5% of rho g (from the kernel's own
    derivative, no differences between nodes), and the slabs carry the weight above,
    -sigma_zz(z) A = g sum_p m_p S(z - z_p) with S the kernel's survival function, to
    0.5%."""
    if case == "2d":
        d, up, g, width = pile2d, "y", 1.0, 1.0
        args = ("--contact-columns", MAP2, "--thickness", 1.0, "--wall-types", 2,
                "--gravity", 0, -g, "--slabs", "y", "--range", 1.5, 11.5, "--bins", 20)
        section = 20.0
    else:
        d, up, g, width = pile3d, "z", 9.81, 0.002
        args = ("--contact-columns", MAP3, "--gravity", 0, 0, -g, "--slabs", "z",
                "--range", 0.002, 0.02, "--bins", 18)
        section = 0.016 * 0.016
    out = tmp_path / f"k{case}.csv"
    proc = run_cli("average", "--atoms", d / "atoms.dump", "--contacts", d / "contacts.dump",
                   *args, "--kernel", "lucy", "--width", width, "--out", out, "--no-progress",
                   "--quantities", "nu,rho,sigma,divsigma,body,boundary,dsigma,divdsigma")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(out)
    rho = p.values["rho"]
    res = (p.values[f"divsigma_{up}"] - p.values[f"divdsigma_{up}"] + p.values[f"body_{up}"]
           + p.values[f"boundary_{up}"])
    u = p.cells.coordinates()[up]
    bulk = (u > u.min() + width) & (rho > 0.5 * np.nanmax(rho)) & (u < u.max() - width)
    scale = np.nanmean(rho[bulk]) * g
    assert bulk.sum() >= 6 and np.max(np.abs(res[bulk])) < 0.005 * scale, res[bulk] / scale
    rows, cols = last_rows(d / "atoms.dump")
    z, m = rows[:, cols.index(up)], rows[:, cols.index("mass")]
    keep = rows[:, cols.index("type")] != 2
    k = get("lucy")
    carried = np.array([g * np.sum(m[keep] * np.array([survival(k, width, zk - zp)
                                                       for zp in z[keep]])) for zk in u])
    ratio = -p.values[f"sigma_{up}{up}"][bulk] * section / carried[bulk]
    assert np.all(np.abs(ratio - 1) < 0.005), ratio


@pytest.mark.slow
def test_the_stress_divergence_is_the_derivative_of_the_segments_stress(pile3d, tmp_path):
    """divsigma comes from the particles' net contact forces and the walls' forces at
    their points, sigma from the line integrals along the segments: on planes 50 um
    apart (Lucy, w = 2 mm) the central differences of sigma_zz are divsigma_z to 3e-4 of
    rho g (their own error is O(h^2)), where divsigma reaches rho g."""
    out = tmp_path / "fd.csv"
    proc = run_cli("average", "--atoms", pile3d / "atoms.dump", "--contacts",
                   pile3d / "contacts.dump", "--contact-columns", MAP3, "--slabs", "z",
                   "--range", 0.004, 0.016, "--bins", 240, "--kernel", "lucy", "--width",
                   0.002, "--quantities", "nu,rho,sigma,divsigma", "--out", out,
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(out)
    z = p.cells.coordinates()["z"]
    scale = np.nanmean(p.values["rho"]) * 9.81
    fd = np.gradient(p.values["sigma_zz"], z)[2:-2]
    div = p.values["divsigma_z"][2:-2]
    assert np.max(np.abs(div)) > 0.5 * scale
    assert np.max(np.abs(fd - div)) < 3e-4 * scale, np.max(np.abs(fd - div)) / scale


def test_the_top_hat_across_slabs_counts_the_centres_where_exact_weights_split(pile3d,
                                                                              tmp_path):
    """The definitions' difference, stated: a top hat of radius w (its w is its
    support radius, as MercuryCG's) at half a slab's width spans the slab, and each
    slab holds the particles whose centres lie in it, whole (binned here without
    granavg); the exact weights split each straddling particle by its volume in each
    slab. Across curved cells there is no such limit: a circle's mean of the top hat is
    no annulus."""
    edges = np.linspace(0.004, 0.016, 7)
    rows, cols = last_rows(pile3d / "atoms.dump")
    last = float(open(pile3d / "atoms.dump").read().split("ITEM: TIME\n")[-1].split()[0])
    args = ("average", "--atoms", pile3d / "atoms.dump", "--slabs", "z", "--edges", *edges,
            "--quantities", "nu", "--t-min", last, "--no-progress")
    proc = run_cli(*args, "--kernel", "heaviside", "--width", (edges[1] - edges[0]) / 2,
                   "--out", tmp_path / "h.csv")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(*args, "--out", tmp_path / "e.csv")
    assert proc.returncode == 0, proc.stderr
    h, e = read_profiles(tmp_path / "h.csv"), read_profiles(tmp_path / "e.csv")
    z, a = rows[:, cols.index("z")], 0.5 * rows[:, cols.index("diameter")]
    V = 4 / 3 * np.pi * a ** 3
    slab = np.diff(edges) * 0.016 * 0.016
    assert np.allclose(h.values["nu"], np.histogram(z, edges, weights=V)[0] / slab,
                       rtol=1e-10, atol=0)
    assert not np.allclose(h.values["nu"], e.values["nu"], rtol=1e-3)


@pytest.mark.slow
def test_the_couette_torque_passes_through_every_circle(tmp_path):
    """Rings with Lucy of width one small diameter on a run of the demo scene: the
    torque through each circle, 2 pi r^2 h (sigma_phir - dsigma_phir), is the inner
    wall's less the plate's between the wall and the circle, within two errors, at every
    node farther than the kernel's reach from the walls."""
    run = tmp_path / "run"
    proc = run_cli("simulate", "--preset", "demo", "--out", run, "--set", "t_end=2",
                   "--set", "dump_dt=0.25", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "k.csv"
    proc = run_cli("average", run, "--bins", 20, "--kernel", "lucy", "--width", 0.0075,
                   "--t-min", 0.5, "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(out)
    scene = p.meta["run_manifest"]["scene"]
    h, Ri, Ro = scene["h"], scene["R_i"], scene["R_o"]
    ts = p.timeseries
    t_in = ts["torque_in_Nm"][ts["t_s"] >= 0.5].mean()
    r = p.cells.centre
    T = 2 * np.pi * r ** 2 * h * (p.values["sigma_phir"] - p.values["dsigma_phir"])
    err = 2 * np.pi * r ** 2 * h * p.sem["sigma_phir"]
    f = np.r_[0.0, 2 * np.pi * r ** 2 * h * p.values["body_phi"]]
    plate = np.array([np.trapezoid(f[:k + 2], np.r_[Ri, r][:k + 2]) for k in range(len(r))])
    far = (r > Ri + 0.0075 + 0.0045) & (r < Ro - 0.0075 - 0.0045)
    assert far.sum() >= 15
    assert np.all(np.abs(T[far] - (t_in - plate[far])) < 2 * err[far]), \
        (T[far], t_in - plate[far], err[far])


# -- the command line ------------------------------------------------------------------------

@pytest.mark.parametrize("extra, needle", [
    (("--width", 0.01), "--width is the width of a smoothing kernel"),
    (("--kernel", "lucy"), "--kernel lucy needs --width W"),
    (("--kernel", "cubic", "--width", 1), "--kernel 'cubic': choose exact or gauss, "
                                          "heaviside or lucy"),
    (("--kernel", "lucy", "--width", 0.1), "--width 0.1: below half the smallest particle "
                                           "radius"),
    (("--quantities", "nu,gradv"), "gradv is a derivative of the coarse-grained fields"),
    (("--kernel", "heaviside", "--width", 1, "--quantities", "divsigma"),
     "divsigma is a derivative"),
])
def test_refusals_in_one_line(pile2d, tmp_path, extra, needle):
    proc = run_cli("average", "--atoms", pile2d / "atoms.dump", "--thickness", 1.0,
                   "--slabs", "y", "--out", tmp_path / "p.csv", *extra)
    errors = [ln for ln in proc.stderr.splitlines() if "error:" in ln]
    assert proc.returncode == 2 and len(errors) == 1 and needle in errors[0], proc.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_kernel_averages_on_dask_are_the_serial_ones_bit_for_bit(pile3d, tmp_path):
    pytest.importorskip("distributed")
    args = ("average", "--atoms", pile3d / "atoms.dump", "--contacts",
            pile3d / "contacts.dump", "--contact-columns", MAP3, "--grid", 2, 2, 6,
            "--z-range", 0, 0.024, "--kernel", "lucy", "--width", 0.002, "--no-progress")
    assert run_cli(*args, "--out", tmp_path / "s.csv").returncode == 0
    proc = run_cli(*args, "--workers", 2, "--out", tmp_path / "d.csv")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "s.csv").read_bytes() == (tmp_path / "d.csv").read_bytes()


def test_smooth_wraps_only_with_a_kernel():
    rings = Rings(np.linspace(0.1, 0.2, 5), 0.006)
    assert smooth(rings, None, None) is rings and smooth(rings, "exact", None) is rings
    s = smooth(rings, "gauss", 0.01)
    assert isinstance(s, Smoothed) and s.describe()["kernel"] == "gauss" and s.n == 4
    assert Slabs3D(np.linspace(0, 1, 3), "z", 1.0).nodes()[0] == "planes"


def test_the_kernel_sums_spread_each_block_as_the_registry_declares_it():
    """Every block says how a kernel spreads it (granavg.engine.channels.SPREADS), those
    spread from another block name it, and the kernel's sums name no block: what they do
    with one follows from its declaration alone."""
    import ast
    from pathlib import Path

    from granavg.engine.channels import BLOCK, SPREADS
    from granavg.engine.smoothing import sums

    for name, block in BLOCK.items():
        assert block.spread in SPREADS, name
        derived = block.spread in ("gradient", "divergence", "force_divergence",
                                   "inverse_radius")
        assert (block.of in BLOCK) if derived else block.of == "", name
    literals = {n.value for n in ast.walk(ast.parse(Path(sums.__file__).read_text()))
                if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert not literals & set(BLOCK), literals & set(BLOCK)
