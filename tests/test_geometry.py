"""Slabs and grids: exact area weights (sum rules, quadrature), the Cartesian basis, and
agreement with rings on basis-free sums, through the public manifest-free API."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from granavg.engine import average
from granavg.cells import Grid, Rings, Slabs
from granavg.engine.weights import grid_weights, strip_weights
from granavg.io.reader import DumpReader
from granavg.io.run_dumps import RunDumps

H = 0.006


def random_frame(n=400, seed=0):
    rng = np.random.default_rng(seed)
    atoms = {"x": rng.uniform(-0.1, 0.1, n), "y": rng.uniform(-0.05, 0.05, n),
             "radius": rng.uniform(0.002, 0.005, n), "vx": np.full(n, 0.03),
             "vy": np.full(n, -0.01), "omegaz": rng.normal(0, 1, n)}
    return SimpleNamespace(timestep=0, time=0.0, atoms=atoms, contacts=None)


@pytest.mark.parametrize("geometry", [
    Slabs(np.linspace(-0.11, 0.11, 41), H, "x", length=0.12),
    Slabs(np.linspace(-0.06, 0.06, 7), H, "y", length=0.22),
    Grid(np.linspace(-0.11, 0.11, 23), np.linspace(-0.06, 0.06, 13), H),
], ids=["slabs-x", "slabs-y", "grid"])
def test_sum_of_nu_v_over_cells_is_the_disks_volume(geometry):
    f = random_frame()
    p = average([f], geometry, quantities=["nu", "v"])
    disks = np.pi * H * np.sum(f.atoms["radius"] ** 2)
    assert np.sum(p.values["nu"] * geometry.volume) == pytest.approx(disks, rel=1e-12)
    # a uniform translation comes out as itself in every occupied cell (Cartesian basis)
    occupied = p.values["nu"] > 0
    assert np.allclose(p.values["v_x"][occupied], 0.03, rtol=1e-12)
    assert np.allclose(p.values["v_y"][occupied], -0.01, rtol=1e-12)
    assert "v_r" not in p.values and set(geometry.coordinates()) <= set(p.to_pandas().columns)


def test_weights_against_quadrature():
    """Fractions of a disk in cells against a fine-grid quadrature of the disk."""
    rng = np.random.default_rng(3)
    xe, ye = np.linspace(0, 1, 6), np.linspace(0, 1, 4)
    for _ in range(5):
        x, y, a = rng.uniform(0.2, 0.8), rng.uniform(0.2, 0.8), rng.uniform(0.05, 0.2)
        p, cell, w = grid_weights([x], [y], [a], xe, ye)
        g = np.linspace(-a, a, 2001)
        gx, gy = np.meshgrid(x + g, y + g)
        inside = (gx - x) ** 2 + (gy - y) ** 2 < a * a
        i = np.clip(np.searchsorted(xe, gx[inside]) - 1, 0, 4)
        j = np.clip(np.searchsorted(ye, gy[inside]) - 1, 0, 2)
        quad = np.bincount(i * 3 + j, minlength=15) / inside.sum()
        exact = np.bincount(cell, w, minlength=15)
        assert np.abs(exact - quad).max() < 2e-3
        _, scell, sw = strip_weights([x], [a], xe)
        assert np.allclose(np.bincount(scell, sw, minlength=5), exact.reshape(5, 3).sum(1),
                           atol=1e-12)


def test_a_disk_split_by_the_grid_lines_through_its_centre_gives_quarters():
    """Four cells meeting at the disk's centre each hold a quarter (pi a^2 / 4); a cell
    holding the whole disk all of it; a cell beyond it nothing."""
    _, cell, w = grid_weights([0.0], [0.0], [2.0], np.array([-3.0, 0.0, 3.0]),
                              np.array([-3.0, 0.0, 3.0]))
    assert np.allclose(np.bincount(cell, w, minlength=4), 0.25, rtol=1e-14)
    _, cell, w = grid_weights([0.0], [0.0], [2.0], np.array([-5.0, 5.0, 9.0]),
                              np.array([-5.0, 5.0]))
    assert np.bincount(cell, w, minlength=2) == pytest.approx([1.0, 0.0], abs=1e-14)


def test_stress_trace_is_the_same_summed_over_rings_or_a_grid(small_run):
    """sum_k V_k tr sigma_k does not depend on the cells or their basis: rings (polar)
    and a grid (Cartesian) covering every disk agree to round-off on a LAMMPS frame."""
    m = json.loads((small_run / "manifest.json").read_text())
    frames = list(RunDumps(DumpReader(small_run / "atoms.dump.gz"),
                             DumpReader(small_run / "contacts.dump.gz"),
                             dt=m["derived"]["dt_s"]))[-1:]
    a = frames[0].atoms
    reach = np.max(np.hypot(a["x"], a["y"]) + a["radius"]) * 1.001
    rings = Rings(np.linspace(0.0, reach, 9), H)
    grid = Grid(np.linspace(-reach, reach, 11), np.linspace(-reach, reach, 11), H)
    pr = average(frames, rings, quantities=["nu", "sigma", "F"])
    pg = average(frames, grid, quantities=["nu", "sigma", "F"])
    tr_r = np.nansum(rings.volume * (pr.values["sigma_rr"] + pr.values["sigma_phiphi"]))
    tr_g = np.nansum(grid.volume * (pg.values["sigma_xx"] + pg.values["sigma_yy"]))
    assert tr_g == pytest.approx(tr_r, rel=1e-10)
    fr = np.nansum(rings.volume * (pr.values["F_rr"] + pr.values["F_phiphi"]))
    fg = np.nansum(grid.volume * (pg.values["F_xx"] + pg.values["F_yy"]))
    assert fg == pytest.approx(fr, rel=1e-10)


def test_masses_from_the_atoms_set_density_and_dynamic_stress():
    f = random_frame(50)
    f.atoms["mass"] = 4 / 3 * np.pi * f.atoms["radius"] ** 3 * 2500.0      # spheres
    g = Slabs(np.linspace(-0.11, 0.11, 3), H, "x", length=0.12)
    p = average([f], g, quantities=["rho", "dsigma"])
    assert np.sum(p.values["rho"] * g.volume) == pytest.approx(f.atoms["mass"].sum(), rel=1e-12)
    assert np.sum(p.values["dsigma_xx"] * g.volume) == pytest.approx(
        np.sum(f.atoms["mass"] * 0.03 ** 2), rel=1e-12)
