"""The ring-averaging engine on configurations whose answer is known exactly."""

import numpy as np
import pytest

from granavg.engine.accumulate import CellAccumulator
from granavg.engine.frame_sums import frame_sums
from granavg.engine.cells.base import layout_of
from granavg.engine.cells.rings import Rings
from granavg.io.frames import Frame
from granavg.engine.weights import ring_weights

from .helpers import HEX_H as H, HEX_RHO_P as RHO_P, hex_crystal, ring_average as average


@pytest.mark.parametrize("branch, reach", [("contact", 0.5), ("paper", 0.0)])
def test_compressed_hex_crystal_gives_fabric_stress_and_strain_exactly(branch, reach):
    """Branch vectors of length l = a - reach delta: to the contact point (the middle of
    the overlap) or, as Eq. 5 is printed, to the disk's surface."""
    a, delta, k = 0.004, 1e-4, 10.0
    frame = hex_crystal(a, delta, k)
    rings = Rings.count(8, 0.03, 0.09, H)          # away from the crystal's edge (0.12 m)
    p = average([frame], rings, branch=branch)
    length = a - reach * delta
    nu = p.values["nu"]
    assert np.all(nu > 0.85)
    # six contacts a disk: tr F = nu C, F = 3 nu I (six normals 60 degrees apart)
    assert np.allclose(p.values["F_rr"] + p.values["F_phiphi"], 6 * nu, rtol=1e-12)
    assert np.allclose(p.values["F_rr"], 3 * nu, rtol=1e-12)
    assert np.allclose(p.values["F_rphi"], 0, atol=1e-12)
    assert np.allclose(p.values["coordination"], 6, rtol=1e-12)
    # sigma = (1/V) sum_p w sum_c f (x) l = -3 k delta l nu / (pi a^2 h) I (tension > 0)
    expected = -3 * k * delta * length * nu / (np.pi * a * a * H)
    assert np.allclose(p.values["sigma_rr"], expected, rtol=1e-12)
    assert np.allclose(p.values["sigma_phiphi"], expected, rtol=1e-12)
    assert np.allclose(p.values["sigma_rphi"], 0, atol=1e-12 * abs(expected).max())
    # eps = -(delta l / a^2) I (-delta / a with Eq. 5's l = a): the overlap shortens
    # every branch vector by delta
    assert np.allclose(p.values["eps_rr"], -delta * length / a ** 2, rtol=1e-12)
    assert np.allclose(p.values["eps_phiphi"], -delta * length / a ** 2, rtol=1e-12)
    assert np.allclose(p.values["eps_phir"], 0, atol=1e-12)


def rotating_frame(omega, rng, n=3000, t=0.0):
    r = rng.uniform(0.1032 + 0.0045, 0.2524 - 0.0045, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    x, y = r * np.cos(phi), r * np.sin(phi)
    a = rng.choice([0.00371, 0.004495], n)
    atoms = {"id": np.arange(1, n + 1.0), "x": x, "y": y, "radius": a,
             "vx": -omega * y, "vy": omega * x, "omegaz": np.full(n, omega)}
    return Frame(int(t * 1000), t, atoms, None)


def test_rigid_rotation():
    omega, rng = 0.1, np.random.default_rng(3)
    rings = Rings.count(20, 0.1032, 0.2524, H)
    frames = [rotating_frame(omega, rng, t=t) for t in (0.0, 1.0, 2.0)]
    groups = ["nu", "v", "omega", "dsigma", "dsigma_fluct"]
    p = average(frames, rings, groups)
    assert np.allclose(p.values["v_r"], 0, atol=1e-15)
    assert np.allclose(p.values["omega"], omega, rtol=1e-13)
    # v_phi = Omega <r>, the volume-weighted mean radius of the ring's disk area
    r_mean = np.zeros(rings.n)
    vol = np.zeros(rings.n)
    for f in frames:
        r = np.hypot(f.atoms["x"], f.atoms["y"])
        part, ring, w = ring_weights(r, f.atoms["radius"], rings.edges)
        v = w * np.pi * H * f.atoms["radius"][part] ** 2
        r_mean += np.bincount(ring, v * r[part], rings.n)
        vol += np.bincount(ring, v, rings.n)
    assert np.allclose(p.values["v_phi"], omega * r_mean / vol, rtol=1e-12)
    # and close to Omega r at the ring centre where the ring is full of disks
    assert np.allclose(p.values["v_phi"][1:-1], omega * rings.centre[1:-1], rtol=2e-3)
    # no fluctuation but the spread of Omega r across a ring: rr and rphi vanish, and
    # phiphi is the variance term rho_p nu Omega^2 var(r) <= rho Omega^2 (dr + 2a)^2 / 12
    assert np.allclose(p.values["dsigma_fluct_rr"], 0, atol=1e-18)
    assert np.allclose(p.values["dsigma_fluct_rphi"], 0, atol=1e-18)
    width = np.diff(rings.edges) + 2 * 0.004495
    bound = RHO_P * p.values["nu"] * omega**2 * width**2 / 12
    assert np.all(p.values["dsigma_fluct_phiphi"] >= 0)
    assert np.all(p.values["dsigma_fluct_phiphi"] <= bound)
    assert np.all(p.values["dsigma_fluct_phiphi"] < 1e-3 * p.values["dsigma_phiphi"])


def test_chunks_merge_into_the_one_pass_result():
    rng = np.random.default_rng(5)
    rings = Rings.count(10, 0.1032, 0.2524, H)
    frames = [rotating_frame(0.1 * (1 + 0.1 * k), rng, n=500, t=0.5 * k) for k in range(24)]
    channels = ["vol", "mom", "spin", "kin"]

    def accumulate(chunk):
        acc = CellAccumulator((rings.n, layout_of(rings.axes, channels).n), start=0.0,
                              block_time=2.0)
        for f in chunk:
            acc.add(f.timestep, f.time, frame_sums(f, rings, RHO_P, channels))
        return acc

    one = accumulate(frames)
    aligned = accumulate(frames[:8]).merge(accumulate(frames[8:16])).merge(
        accumulate(frames[16:]))                       # chunks of whole 2 s blocks
    assert np.array_equal(aligned.mean(), one.mean())
    for got, want in zip(aligned.block_sums(), one.block_sums()):
        assert np.array_equal(got, want)
    ragged = accumulate(frames[:5]).merge(accumulate(frames[5:17])).merge(
        accumulate(frames[17:]))
    assert np.allclose(ragged.mean(), one.mean(), rtol=1e-14, atol=0)
    assert ragged.n_frames == one.n_frames == 24 and len(one.block_sums()[0]) == 6


def test_empty_ring_and_ring_without_contacts_are_flagged_nan():
    frame = hex_crystal(extent=0.06)
    # drop the contacts of the disks beyond 0.04 m: a ring there has disks but no contacts
    a, c = frame.atoms, frame.contacts
    far = set(a["id"][np.hypot(a["x"], a["y"]) > 0.04].astype(int))
    keep = np.array([int(i) not in far and int(j) not in far for i, j in zip(c["id1"], c["id2"])])
    frame = Frame(0, 0.0, a, {k: v[keep] for k, v in c.items()})
    rings = Rings(np.array([0.01, 0.03, 0.045, 0.055, 0.08, 0.09]), H)
    p = average([frame], rings)
    flags = list(p.flags)
    assert flags[0] == "one_block" and np.isfinite(p.values["eps_rr"][0])   # one frame
    assert "no_contacts" in flags[2] and "singular_fabric" in flags[2]
    assert np.isnan(p.values["eps_rr"][2]) and p.values["coordination"][2] == 0
    assert flags[4].startswith("empty") and p.values["nu"][4] == 0
    assert np.isnan(p.values["v_phi"][4]) and np.isnan(p.values["eps_rr"][4])
    assert np.all(np.isnan(p.sem["nu"]))            # one frame: no error estimate
