"""Exact sphere-cell volumes (granavg.engine.sphere_weights): against independent
numerical integration and Monte Carlo, and the sum rules."""

import math

import numpy as np
import pytest
from scipy import integrate

from granavg.engine import sphere_weights as sw
from granavg.cells import Boxes, Shells, Slabs3D


def slice_below(X, Y, rho):
    """Area of the disk of radius rho (centre 0) with x < X and y < Y, by quadrature."""
    if rho <= 0 or X <= -rho or Y <= -rho:
        return 0.0
    half = lambda x: math.sqrt(max(rho * rho - x * x, 0.0))            # noqa: E731
    hi = min(X, rho)
    kinks = [k for k in (-half(Y), half(Y)) if -rho < k < hi]
    return integrate.quad(lambda x: max(0.0, min(Y, half(x)) + half(x)), -rho, hi,
                          points=kinks or None, epsabs=1e-15, epsrel=1e-13, limit=200)[0]


def volume_below(X, Y, Z, a=1.0):
    """The sphere's volume with x < X, y < Y, z < Z by quadrature of its slices."""
    hi = min(Z, a)
    if hi <= -a:
        return 0.0
    kinks = []
    for c in (X, Y, math.hypot(X, Y)):
        if abs(c) < a:
            kinks += [math.sqrt(a * a - c * c), -math.sqrt(a * a - c * c)]
    kinks = [k for k in kinks if -a < k < hi]
    return integrate.quad(lambda z: slice_below(X, Y, math.sqrt(max(a * a - z * z, 0.0))),
                          -a, hi, points=kinks or None, epsabs=1e-14, epsrel=1e-12,
                          limit=400)[0]


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_the_volume_below_three_planes_against_quadrature():
    """The closed form (antiderivatives of the slices' areas) against adaptive quadrature
    of the 2D areas: 80 random corners, all signs, inside and beyond the sphere."""
    rng = np.random.default_rng(1)
    corners = [*rng.uniform(-1.2, 1.2, (76, 3)), (0, 0, 0), (0.999, -0.999, 0.0),
               (1e-9, 0.5, -1e-9), (0.6, 0.8, 0.0)]            # a corner on the sphere
    for X, Y, Z in corners:
        assert sw.below3(X, Y, Z, 1.0) == pytest.approx(volume_below(X, Y, Z), abs=1e-12)
    assert sw.below3(2, 2, 2, 1.0) == pytest.approx(4 / 3 * math.pi, rel=1e-15)
    assert sw.below3(0, 0, 0, 1.0) == pytest.approx(math.pi / 6, rel=1e-13)   # an octant


def dense(weights, n_particles, n_cells):
    p, c, w = weights
    out = np.zeros((n_particles, n_cells))
    np.add.at(out, (p, c), w)
    return out


def spheres_inside(rng, n, lo, hi):
    """n spheres (radii 0.5-6 mm) wholly inside the box lo..hi (3 coordinates each)."""
    a = rng.uniform(0.0005, 0.006, n)
    pos = [rng.uniform(l + a, h - a) for l, h in zip(lo, hi)]
    return pos, a


CELLS = {
    "slabs3d": Slabs3D(np.linspace(-0.03, 0.03, 9), "z", 0.01),
    "boxes": Boxes(np.linspace(-0.05, 0.05, 7), np.linspace(-0.04, 0.04, 5),
                   np.linspace(-0.03, 0.03, 9)),
    "shells": Shells(np.linspace(0.0, 0.05, 8), np.linspace(-0.03, 0.03, 5), (0.001, -0.002)),
}


@pytest.mark.parametrize("kind", CELLS)
def test_the_weights_of_a_sphere_inside_the_cells_sum_to_one(kind):
    cells = CELLS[kind]
    rng = np.random.default_rng(4)
    if kind == "shells":                           # inside the outer radius and the layers
        a = rng.uniform(0.0005, 0.006, 3000)
        r = rng.uniform(0, 0.05 - a)
        phi = rng.uniform(0, 2 * np.pi, 3000)
        pos = (0.001 + r * np.cos(phi), -0.002 + r * np.sin(phi),
               rng.uniform(-0.03 + a, 0.03 - a))
    else:
        pos, a = spheres_inside(rng, 3000, (-0.05, -0.04, -0.03), (0.05, 0.04, 0.03))
    W = dense(cells.weights(pos, a), len(a), cells.n)
    assert np.abs(W.sum(axis=1) - 1).max() < 1e-12
    assert W.min() >= 0
    # sum of nu V over the cells is the spheres' volume
    assert np.sum(W * cells.particle_volume(a)[:, None]) == pytest.approx(
        np.sum(4 / 3 * np.pi * a**3), rel=1e-12)


def test_the_shells_quadrature_is_converged():
    """32 nodes per piece (the default) agree with 64 to 1e-10 of a sphere's volume."""
    rng = np.random.default_rng(5)
    n = 2000
    a = rng.uniform(0.002, 0.012, n)
    d = np.minimum(rng.uniform(0.0, 0.1, n), 0.11 - a)
    z = rng.uniform(-0.03 + a, 0.03 - a)
    re, ze = np.linspace(0.0, 0.11, 12), np.linspace(-0.03, 0.03, 7)
    cells = (len(re) - 1) * (len(ze) - 1)
    default = dense(sw.shell_weights(d, z, a, re, ze), n, cells)
    fine = dense(sw.shell_weights(d, z, a, re, ze, nodes=64), n, cells)
    coarse = dense(sw.shell_weights(d, z, a, re, ze, nodes=8), n, cells)
    assert np.abs(default - fine).max() < 1e-10
    assert np.abs(coarse - fine).max() > 1e-7            # the test can tell


@pytest.mark.parametrize("kind", ["boxes", "shells"])
def test_the_weights_match_monte_carlo(kind):
    """Spheres straddling edges and corners: the exact fractions against 10^6 random
    points of each sphere (within 4 standard errors)."""
    cells = CELLS[kind]
    rng = np.random.default_rng(6)
    centres = {"boxes": [(0.05 / 3 + 0.001, 0.0 - 0.002, -0.0075 + 0.003),    # a corner
                         (-0.0166, 0.02, 0.01)],
               "shells": [(0.0150, -0.002, 0.0), (0.001 + 0.021, -0.002 + 0.003, 0.014)]}
    a = 0.005
    for c in centres[kind]:
        w = dense(cells.weights(tuple(np.array([v]) for v in c), np.array([a])), 1,
                  cells.n)[0]
        n = 1_000_000
        u = rng.normal(size=(n, 3))
        u *= (a * rng.random(n) ** (1 / 3) / np.linalg.norm(u, axis=1))[:, None]
        pts = tuple(u[:, k] + c[k] for k in range(3))
        mc = np.bincount(cells.cell_of(pts), minlength=cells.n) / n
        assert np.count_nonzero(w > 1e-3) >= 2                       # it straddles
        assert np.abs(mc - w).max() < 4 * math.sqrt(0.25 / n)
