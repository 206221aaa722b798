"""The averaging engine in 3D on configurations whose answer is known exactly: a
compressed simple cubic crystal of spheres, rigid rotation in cylindrical shells, and
the stress sum rule over boxes."""

import numpy as np
import pytest

from granavg.engine import average
from granavg.cells import Boxes, Shells, Slabs3D
from granavg.engine.sphere_weights import box_weights
from granavg.io.frames import Frame

from .helpers import CUBIC_RHO_P as RHO_P, cubic_crystal


def test_a_compressed_cubic_crystal_gives_fabric_stress_and_strain_exactly():
    a, delta, k = 0.002, 5e-5, 100.0
    frame = cubic_crystal(a, delta, k)
    inner = np.linspace(-0.008, 0.008, 5)                   # away from the crystal's faces
    p = average([frame, Frame(1, 1.0, frame.atoms, frame.contacts)],
                Boxes(inner, inner, inner), density=RHO_P, sectors=None)
    nu = p.values["nu"]
    assert np.all(nu > 0.5)
    length = a - delta / 2                                # to the contact point
    for i in "xyz":
        for j in "xyz":
            same = i == j
            # six normals along +-x, +-y, +-z: F = 2 nu I, tr F = nu C
            assert np.allclose(p.values[f"F_{i}{j}"], 2 * nu if same else 0, atol=1e-12)
            # sigma = -2 k delta l nu / (4/3 pi a^3) I (tension positive)
            expected = -2 * k * delta * length * nu / (4 / 3 * np.pi * a**3) if same else 0
            assert np.allclose(p.values[f"sigma_{i}{j}"], expected, rtol=1e-12,
                               atol=1e-12 * k * delta / a**2)
            # eps = -(delta l / a^2) I, as in 2D: the overlap shortens every branch vector
            assert np.allclose(p.values[f"eps_{i}{j}"], -delta * length / a**2 if same else 0,
                               rtol=1e-12, atol=1e-15)
    assert np.allclose(p.values["coordination"], 6, rtol=1e-12)


def test_the_summed_stress_is_the_sum_of_the_contacts_force_times_branch():
    """sum_k V_k sigma_k = sum over contacts f (x) r_12 for cells covering the packing
    (an exact sum rule of the weights), with random forces and positions."""
    frame = cubic_crystal()
    rng = np.random.default_rng(3)
    c = frame.contacts
    for comp in ("fnx", "fny", "fnz", "ftx", "fty", "ftz"):
        c[comp] = c[comp] + rng.normal(0, 1e-3, len(c[comp]))
    lo, hi = -0.03, 0.03
    cells = Boxes(np.linspace(lo, hi, 4), np.linspace(lo, hi, 5), np.linspace(lo, hi, 3))
    p = average([frame, Frame(1, 1.0, frame.atoms, c)], cells, density=RHO_P, sectors=None)
    pos = np.column_stack([frame.atoms[x] for x in "xyz"])
    row = {int(i): k for k, i in enumerate(frame.atoms["id"])}
    i1 = np.array([row[int(i)] for i in c["id1"]])
    i2 = np.array([row[int(i)] for i in c["id2"]])
    f = np.column_stack([c[f"fn{x}"] + c[f"ft{x}"] for x in "xyz"])
    # f (x) l_1 + (-f) (x) l_2 = f (x) r_12: the contact branch ends mid-overlap,
    # l_1 - l_2 = 2 (a - delta/2) n = x_2 - x_1
    r12 = pos[i2] - pos[i1]
    for a_, i in enumerate("xyz"):
        for b_, j in enumerate("xyz"):
            direct = np.sum(f[:, a_] * r12[:, b_])
            summed = np.sum(cells.volume * p.values[f"sigma_{i}{j}"])
            assert summed == pytest.approx(direct, rel=1e-10, abs=1e-12 * abs(direct) + 1e-18)


def test_rigid_rotation_in_shells():
    """Spheres turning as a rigid body about the z axis: v_phi = Omega <r> of the
    shell's sphere volume, v_r = v_z = 0, omega_z = Omega, no fluctuation but the
    spread of Omega r across a shell."""
    rng = np.random.default_rng(4)
    Om, n = 0.3, 4000
    r = rng.uniform(0.02, 0.1, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(-0.02, 0.02, n)
    a = rng.choice([0.002, 0.003], n)
    x, y = r * np.cos(phi), r * np.sin(phi)
    atoms = {"id": np.arange(1, n + 1.0), "x": x, "y": y, "z": z, "radius": a,
             "vx": -Om * y, "vy": Om * x, "vz": np.zeros(n), "omegax": np.zeros(n),
             "omegay": np.zeros(n), "omegaz": np.full(n, Om)}
    cells = Shells(np.linspace(0.025, 0.095, 8), np.linspace(-0.015, 0.015, 4))
    frames = [Frame(k, float(k), atoms, None) for k in range(3)]
    p = average(frames, cells, density=RHO_P, sectors=None)
    assert np.allclose(p.values["v_r"], 0, atol=1e-15)
    assert np.allclose(p.values["v_z"], 0, atol=1e-15)
    assert np.allclose(p.values["omega_z"], Om, rtol=1e-13)
    assert np.allclose(p.values["omega_r"], 0, atol=1e-15)
    r_mean = np.zeros(cells.n)
    vol = np.zeros(cells.n)
    part, cell, w = cells.weights((x, y, z), a)
    v = w * 4 / 3 * np.pi * a[part] ** 3
    np.add.at(r_mean, cell, v * r[part])
    np.add.at(vol, cell, v)
    assert np.allclose(p.values["v_phi"], Om * r_mean / vol, rtol=1e-12)
    assert np.allclose(p.values["dsigma_fluct_rr"], 0, atol=1e-15)
    assert np.allclose(p.values["dsigma_fluct_zz"], 0, atol=1e-15)
    assert np.all(p.values["dsigma_fluct_phiphi"] > 0)


def test_slabs_of_a_uniform_packing_have_its_density():
    """Spheres in a box: nu in slabs across z is the packing's volume over the slab's
    (exact weights, no centre-in-cell rule), and the weights sum over the slabs."""
    rng = np.random.default_rng(5)
    n, side = 3000, 0.05
    a = rng.uniform(0.001, 0.002, n)
    x, y = rng.uniform(0, side, n), rng.uniform(0, side, n)
    z = rng.uniform(0.004, 0.046, n)
    atoms = {"x": x, "y": y, "z": z, "radius": a}
    cells = Slabs3D(np.linspace(0.0, 0.05, 11), "z", side * side)
    p = average([Frame(0, 0.0, atoms, None), Frame(1, 1.0, atoms, None)], cells,
                quantities=["nu"], sectors=None)
    assert np.sum(p.values["nu"] * cells.volume) == pytest.approx(np.sum(4 / 3 * np.pi * a**3),
                                                                  rel=1e-12)
    part, cell, w = box_weights(x, y, z, a, [-1, 1], [-1, 1], cells.edges)
    nu = np.bincount(cell, w * 4 / 3 * np.pi * a[part] ** 3, cells.n) / cells.volume
    assert np.allclose(p.values["nu"], nu, rtol=1e-12)


def test_shell_sectors_split_each_sphere_by_its_volume_beyond_the_planes():
    """A sphere straddling a sector boundary (a plane through the axis) goes to the two
    sectors by the exact cap volumes (against Monte Carlo), and a frame's sector sums
    add up to its shells' sums."""
    from granavg.engine.frame_sums import frame_sums
    from granavg.engine.channels import BLOCKS

    cells = Shells(np.linspace(0.02, 0.1, 5), np.linspace(-0.02, 0.02, 3))
    k, a = 8, 0.004
    phi_b = 2 * np.pi / k                                 # the first boundary plane
    c = (0.06 * np.cos(phi_b - 0.03), 0.06 * np.sin(phi_b - 0.03), 0.001)
    sector, share = cells.sector_shares(tuple(np.array([v]) for v in c),
                                           np.array([a]), k)
    got = np.zeros(k)
    np.add.at(got, sector[0], share[0])
    rng = np.random.default_rng(7)
    n = 1_000_000
    u = rng.normal(size=(n, 3))
    u *= (a * rng.random(n) ** (1 / 3) / np.linalg.norm(u, axis=1))[:, None]
    ang = np.arctan2(u[:, 1] + c[1], u[:, 0] + c[0]) % (2 * np.pi)
    mc = np.bincount((ang // phi_b).astype(int), minlength=k) / n
    assert np.count_nonzero(got) == 2 and got.sum() == pytest.approx(1, abs=1e-14)
    assert np.abs(got - mc).max() < 4 * np.sqrt(0.25 / n)
    frame = cubic_crystal(a=0.002, n=30)
    blocks = [b for b in BLOCKS if b not in ("wall", "body", "bpow")]
    whole = frame_sums(frame, cells, RHO_P, blocks)
    split = frame_sums(frame, cells, RHO_P, blocks, n_sectors=24)
    assert np.allclose(split.sum(axis=1), whole, rtol=1e-12, atol=1e-15)


def test_shells_get_errors_from_time_and_structure():
    """Over cylindrical shells the sectors along phi count the frozen structure, as for
    rings; the components the balance fixes keep time errors."""
    rng = np.random.default_rng(8)
    frames = []
    base = cubic_crystal(a=0.002, n=30)
    for t in range(12):
        atoms = dict(base.atoms)
        atoms["vx"] = rng.normal(0, 1e-3, len(atoms["x"]))
        frames.append(Frame(t, float(t), atoms, base.contacts))
    cells = Shells(np.linspace(0.0, 0.05, 4), np.linspace(-0.02, 0.02, 3))
    p = average(frames, cells, density=RHO_P)
    err = p.meta["errors"]
    assert err["kind"] == "time+structure" and err["sectors"]["axis"] == "phi"
    assert "sigma_rz" in err["sectors"]["time_only"] and "sigma_zz" not in \
        err["sectors"]["time_only"]
    assert p.replicates.kind == "structure"
