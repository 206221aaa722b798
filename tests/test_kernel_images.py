"""Smoothing kernels across periodic faces, and the mass-weighted means, held to sums
computed here with numpy alone from the dumps of LAMMPS piles of our own decks (default
%g dumps, periodic sides).

A node within the kernel's reach of a periodic face sees the particles (and the contact
segments) across it, whether the cells span the box or a range of it; nodes out of reach
of the faces do not change. The velocity is the momentum density over the density, a
mass-weighted mean, in every route: with two material densities it is not the
volume-weighted mean, with one it is."""

import numpy as np
import pytest
from scipy import integrate

from granavg.io.dump_columns import parse_map
from granavg.pipeline.api import average

from .helpers import MAP3, PILE2D_MAP as MAP2, frames, run_pile3d

#: Lucy's normalisation N_D (phi = N_D / c^D (1 + 3q)(1 - q)^3), from its integral.
LUCY = {2: 5.0 / np.pi, 3: 105.0 / (16.0 * np.pi)}
ROUND_OFF = 1e-12
#: Relative rounding of a number printed with LAMMPS' default %g, with margin.
PRINTED = 1e-5


def lucy(r, c, dim):
    q = np.asarray(r, float) / c
    return np.where(q < 1.0, LUCY[dim] / c ** dim * (1 + 3 * q) * (1 - q) ** 3, 0.0)


def last_frame(path, dim):
    """The last frame of a dump read here: its rows by column name and the box."""
    head, cols, rows = frames(path)[-1]
    k = next(i for i, h in enumerate(head) if h.startswith("ITEM: BOX BOUNDS"))
    box = [tuple(map(float, head[k + 1 + a].split()[:2])) for a in range(dim)]
    return {c: rows[:, i] for i, c in enumerate(cols)}, box


def shifts(box, periodic):
    """The image shifts of the periodic axes (0 included), shape (S, D)."""
    axes = [(-1, 0, 1) if p else (0,) for p in periodic]
    L = np.array([hi - lo for lo, hi in box])
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(box), -1).T * L


def node_grid(p):
    """The nodes' positions, shape (n, D), in the cells' order."""
    kind, axes = p.cells.nodes()
    assert kind == "lattice"
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


def particle_sum(nodes, x, weight, c, dim, images):
    """sum_p weight_p phi(|n - x_p - shift|) over the images, shape (n, ...)."""
    weight = np.asarray(weight, float)
    out = np.zeros((len(nodes),) + weight.shape[1:])
    for s in images:
        r = np.linalg.norm(nodes[:, None, :] - x[None, :, :] - s, axis=2)
        out += np.tensordot(lucy(r, c, dim), weight, axes=(1, 0))
    return out


def contact_segments(atoms, contacts, dim):
    """The stress's segments as (start, branch, force): each contact's two halves, from
    each centre to the contact point with the force on that particle, from the
    pair/local columns (d = x_1 - x_2 the minimum image, the normal -d/|d|, the overlap
    r_1 + r_2 - dist, 0 where a pair touches by less than the printed rounding but
    carries a force); where the halves lie on one line and meet (their contact points
    within 1e-4 of the centres' distance, as the dump's rounding leaves them; not
    across a periodic face), one segment from centre to centre with the force on the
    first (the same stress, f (x) l1 + (-f) (x) l2 integrated along one line)."""
    xyz = "xyz"[:dim]
    ids = atoms["id"].astype(int)
    row = {i: k for k, i in enumerate(ids)}
    a = 0.5 * atoms["diameter"]
    x = np.column_stack([atoms[c] for c in xyz])
    i1 = np.array([row[int(i)] for i in contacts["c_pp[1]"]])
    i2 = np.array([row[int(i)] for i in contacts["c_pp[2]"]])
    k = 2
    dist = contacts[f"c_pl[{k - 1}]"]
    d = np.column_stack([contacts[f"c_pl[{k + j}]"] for j in range(dim)])
    force = contacts[f"c_pl[{k + dim}]"]
    ft = np.column_stack([contacts[f"c_pl[{k + dim + 1 + j}]"] for j in range(dim)])
    length = np.linalg.norm(d, axis=1)
    n = -d / length[:, None]
    f = force[:, None] * d / length[:, None] + ft
    overlap = a[i1] + a[i2] - dist
    keep = (overlap > 0) | (force != 0)
    overlap = np.where(overlap > 0, overlap, 0.0)
    l1 = (a[i1] - 0.5 * overlap)[:, None] * n
    l2 = -(a[i2] - 0.5 * overlap)[:, None] * n
    whole = l1 - l2
    meet = np.linalg.norm(x[i1] + l1 - x[i2] - l2, axis=1) <= 1e-4 * np.linalg.norm(
        whole, axis=1)
    one, two = keep & meet, keep & ~meet
    return (np.concatenate([x[i1[one]], x[i1[two]], x[i2[two]]]),
            np.concatenate([whole[one], l1[two], l2[two]]),
            np.concatenate([f[one], f[two], -f[two]]))


def segment_integral(node, x0, l, c, dim):
    """int_0^1 phi(|node - x0 - s l|) ds by adaptive quadrature between the support's
    ends and the point of closest approach."""
    A = l @ l
    B = l @ (x0 - node)
    C = (x0 - node) @ (x0 - node)
    s0 = -B / A
    m2 = max(C - B * B / A, 0.0)
    if m2 >= c * c:
        return 0.0
    h = np.sqrt((c * c - m2) / A)
    lo, hi = max(0.0, s0 - h), min(1.0, s0 + h)
    if hi <= lo:
        return 0.0

    def phi(s):
        return float(lucy(np.linalg.norm(x0 + s * l - node), c, dim))
    points = [s0] if lo < s0 < hi else None
    return integrate.quad(phi, lo, hi, points=points, epsabs=0.0, epsrel=1e-13,
                          limit=200)[0]


def stress_at(node, halves, c, dim, images, depth):
    """sum over the halves of f (x) l int phi along l, with images (tension-positive,
    first index the force's), shape (dim, dim)."""
    x, l, f = halves
    out = np.zeros((dim, dim))
    for s in images:
        reach = np.linalg.norm(x + 0.5 * l + s - node, axis=1) < c + 0.5 * np.linalg.norm(
            l, axis=1)
        for k in np.flatnonzero(reach):
            out += np.outer(f[k], l[k]) * segment_integral(node, x[k] + s, l[k], c, dim)
    return out / depth


def tensor_at(p, name, k, dim):
    xyz = "xyz"[:dim]
    return np.array([[p.values[f"{name}_{i}{j}"][k] for j in xyz] for i in xyz])


@pytest.fixture(scope="module")
def pile3d(pile3d_soft):
    return pile3d_soft


def last_time(path):
    """The time of a dump's last frame (its ITEM: TIME)."""
    return float(path.read_text().rsplit("ITEM: TIME\n", 1)[1].split()[0])


@pytest.mark.parametrize("dim", [pytest.param(3, marks=pytest.mark.slow), 2])
def test_nodes_near_periodic_faces_see_the_particles_across_them(dim, pile3d, pile2d):
    """Lucy at the nodes of a grid over the periodic box given as a range, as a user
    matching another code's nodes gives it: rho at every node, and the stress at the
    nodes nearest the faces, equal the sums over the particles' and the segments'
    images to round-off; the layers at the faces get what the images bring (a node
    there would miss much of its density without them), the nodes out of the kernel's
    reach of the faces nothing; the same grid from the box's own bounds is the same."""
    if dim == 3:
        d, width, shape, H = pile3d, 0.002, (16, 16, 22), 1.0
        ranges = {"x_range": (0.0, 0.016), "y_range": (0.0, 0.016), "z_range": (0.0, 0.022)}
        cmap, periodic = MAP3, (True, True, False)
    else:
        d, width, shape, H = pile2d, 1.0, (20, 14), 1.0
        ranges = {"x_range": (0.0, 20.0), "y_range": (0.0, 14.0)}
        cmap, periodic = MAP2, (True, False)
    atoms, box = last_frame(d / "atoms.dump", dim)
    contacts, _ = last_frame(d / "contacts.dump", dim)
    extra = {"thickness": H} if dim == 2 else {}
    opts = dict(kernel="lucy", width=width, quantities=["nu", "rho", "sigma"],
                t_min=last_time(d / "atoms.dump"), sectors=None,
                contact_map=parse_map(cmap), progress=False)
    p = average(d / "atoms.dump", contacts=d / "contacts.dump",
                cells={"grid": shape, **ranges, **extra}, **opts)
    own = {k: v for k, v in ranges.items() if not periodic["xyz".index(k[0])]}
    whole = average(d / "atoms.dump", contacts=d / "contacts.dump",
                    cells={"grid": shape, **own, **extra}, **opts)
    assert p.n_frames == 1                          # the last frame alone
    nodes = node_grid(p)
    xyz = "xyz"[:dim]
    x = np.column_stack([atoms[c] for c in xyz])
    c = width                                       # lucy: w is the support radius
    images = shifts(box, periodic)
    rho = particle_sum(nodes, x, atoms["mass"], c, dim, images) / H
    alone = particle_sum(nodes, x, atoms["mass"], c, dim, np.zeros((1, dim))) / H
    scale = np.max(rho)
    assert np.max(np.abs(p.values["rho"] - rho)) <= ROUND_OFF * scale
    assert np.array_equal(p.values["rho"], whole.values["rho"])
    assert np.array_equal(p.values["sigma_xx"], whole.values["sigma_xx"])
    face = np.zeros(len(nodes), bool)
    for k, per in enumerate(periodic):
        if per:
            lo, hi = box[k]
            face |= (nodes[:, k] - lo < c) | (hi - nodes[:, k] < c)
    assert np.max(np.abs(rho - alone)[face]) > 0.1 * scale         # what images bring
    assert np.max(np.abs(rho - alone)[~face]) <= ROUND_OFF * scale  # out of reach: nothing
    halves = contact_segments(atoms, contacts, dim)
    near = np.flatnonzero(face & (p.values["nu"] > 0.3))
    near = near[np.argsort(np.min([np.minimum(nodes[near, k] - box[k][0],
                                              box[k][1] - nodes[near, k])
                                   for k in range(dim) if periodic[k]], axis=0))][:8]
    sig = np.array([stress_at(nodes[k], halves, c, dim, images, H) for k in near])
    ours = np.array([tensor_at(p, "sigma", k, dim) for k in near])
    size = np.max(np.abs(sig))
    assert size > 0 and np.max(np.abs(ours - sig)) <= ROUND_OFF * size, \
        np.max(np.abs(ours - sig)) / size
    without = np.array([stress_at(nodes[k], halves, c, dim, np.zeros((1, dim)), H)
                        for k in near])
    assert np.max(np.abs(without - sig)) > 0.02 * size             # the images matter


@pytest.fixture(scope="module")
def heavy3d(tmp_path_factory):
    """The pile with the odd ids of a material three times as dense."""
    out = tmp_path_factory.mktemp("heavy3d")
    run_pile3d(out, kn=20.0, heavy=3.0)
    return out


def below(z, z0, a):
    """The share of each sphere's volume below the plane z (spherical caps)."""
    u = np.clip((z - z0) / a, -1.0, 1.0)
    return 1.0 - (1.0 - u) ** 2 * (2.0 + u) / 4.0


@pytest.mark.slow
@pytest.mark.parametrize("heavy", [False, True], ids=["one material", "two materials"])
def test_the_mean_velocity_and_spin_are_mass_weighted(heavy, pile3d, heavy3d):
    """v = sum m v phi / sum m phi (Lucy, a grid over the periodic box, images included)
    and, with the exact weights, v = sum w m v / sum w m over slabs (w each sphere's
    volume share, spherical caps): both to round-off of max |v|, the spin alike, and the
    temperature and the kinetic stress about the mean flow with the same v. With two
    materials that is not the volume-weighted mean (by more than 1% of max |v|); with
    one it is, to the dumped masses' rounding (%g: 6 digits)."""
    d = heavy3d if heavy else pile3d
    atoms, box = last_frame(d / "atoms.dump", 3)
    masses = atoms["mass"]
    odd = atoms["id"].astype(int) % 2 == 1
    ratio = np.median(masses[odd] / atoms["diameter"][odd] ** 3) / np.median(
        masses[~odd] / atoms["diameter"][~odd] ** 3)
    assert ratio == pytest.approx(3.0 if heavy else 1.0, rel=1e-4)     # the deck's materials
    opts = dict(quantities=["nu", "rho", "v", "omega", "temperature", "dsigma_fluct"],
                t_min=last_time(d / "atoms.dump"), sectors=None, progress=False)
    x = np.column_stack([atoms[c] for c in "xyz"])
    vel = np.column_stack([atoms[f"v{c}"] for c in "xyz"])
    spin = np.column_stack([atoms[f"omega{c}"] for c in "xyz"])
    vol = np.pi / 6 * atoms["diameter"] ** 3
    # the kernel's nodes
    p = average(d / "atoms.dump", cells={"grid": (8, 8, 11), "z_range": (0.0, 0.022)},
                kernel="lucy", width=0.002, **opts)
    images = shifts(box, (True, True, False))
    nodes = node_grid(p)
    M = particle_sum(nodes, x, masses, 0.002, 3, images)
    P = particle_sum(nodes, x, masses[:, None] * vel, 0.002, 3, images)
    S = particle_sum(nodes, x, masses[:, None] * spin, 0.002, 3, images)
    K = particle_sum(nodes, x, masses[:, None, None] * vel[:, :, None] * vel[:, None, :],
                     0.002, 3, images)
    byvol = particle_sum(nodes, x, vol[:, None] * vel, 0.002, 3, images) / \
        particle_sum(nodes, x, vol, 0.002, 3, images)[:, None]
    # the exact weights over slabs across z
    edges = np.linspace(0.0, 0.022, 12)
    q = average(d / "atoms.dump", cells={"slabs": "z", "edges": list(edges)}, **opts)
    share = np.diff(below(edges[:, None], atoms["z"][None, :], 0.5 * atoms["diameter"]),
                    axis=0)                                             # (slabs, spheres)
    cases = [(p, M, P, S, K, byvol, np.ones(p.cells.n)),       # sums of phi: densities
             (q, share @ masses, share @ (masses[:, None] * vel),
              share @ (masses[:, None] * spin),
              np.einsum("kp,pij->kij", share, masses[:, None, None] * vel[:, :, None] *
                        vel[:, None, :]),
              (share @ (vol[:, None] * vel)) / (share @ vol)[:, None], q.cells.volume)]
    for prof, M, P, S, K, byvol, V in cases:
        ok = M > 1e-3 * M.max()
        v = P[ok] / M[ok, None]
        ours = np.column_stack([prof.values[f"v_{c}"] for c in "xyz"])[ok]
        top = np.max(np.abs(v))
        assert top > 0 and np.max(np.abs(ours - v)) <= ROUND_OFF * top
        w = S[ok] / M[ok, None]
        spin_ours = np.column_stack([prof.values[f"omega_{c}"] for c in "xyz"])[ok]
        assert np.max(np.abs(spin_ours - w)) <= ROUND_OFF * np.max(np.abs(w))
        fluct = K[ok] - P[ok, :, None] * P[ok, None, :] / M[ok, None, None]
        temp = np.trace(fluct, axis1=1, axis2=2) / (3 * M[ok])
        kinetic = np.trace(K[ok], axis1=1, axis2=2) / (3 * M[ok])
        assert np.max(np.abs(prof.values["temperature"][ok] - temp)) <= \
            ROUND_OFF * np.max(kinetic)
        ours_fl = np.array([[prof.values[f"dsigma_fluct_{i}{j}"][ok] for j in "xyz"]
                            for i in "xyz"]).transpose(2, 0, 1)
        assert np.max(np.abs(ours_fl - fluct / V[ok, None, None])) <= \
            ROUND_OFF * np.max(np.abs(K[ok] / V[ok, None, None]))
        gap = np.max(np.abs(byvol[ok] - v))
        assert gap > 0.01 * top if heavy else gap <= PRINTED * top
