"""Exact area weights of disks in rings, against geometry and quadrature."""

import numpy as np
import pytest

from granavg.engine.weights import area_inside_circle, cut, ring_weights


def test_special_cases_of_the_area_inside_a_circle():
    a = 0.004
    assert area_inside_circle(0.1, a, 0.2) == pytest.approx(np.pi * a * a)     # inside
    assert area_inside_circle(0.3, a, 0.2) == 0.0                              # outside
    assert area_inside_circle(0.001, a, 0.002) == pytest.approx(np.pi * 0.002**2)  # circle in disk
    assert area_inside_circle(0.0, a, 0.01) == pytest.approx(np.pi * a * a)    # centred
    # a disk cut by a huge circle through its centre: half of it is inside
    assert area_inside_circle(1e3, a, 1e3) == pytest.approx(0.5 * np.pi * a * a, rel=1e-5)


def test_a_disk_inside_one_ring_has_weight_one_there():
    p, k, w = ring_weights(np.array([0.155]), np.array([0.004]), np.linspace(0.1, 0.25, 11))
    assert list(k) == [3] and w[0] == pytest.approx(1.0, abs=1e-15)


def test_weights_of_every_disk_sum_to_one_over_rings_spanning_it():
    rng = np.random.default_rng(7)
    r = rng.uniform(0.11, 0.24, 5000)
    a = rng.choice([0.00371, 0.004495], 5000)
    for n in (5, 20, 60, 200):                 # rings wider and narrower than a disk
        p, k, w = ring_weights(r, a, np.linspace(0.1, 0.25, n + 1))
        assert np.allclose(np.bincount(p, w, len(r)), 1.0, rtol=0, atol=1e-12)
        assert np.all((w > 0) & (w <= 1 + 1e-15))


def test_a_straddling_disk_matches_a_polar_quadrature():
    d, a = 0.15, 0.004
    edges = np.array([0.1470, 0.1493, 0.1512, 0.1530])
    _, k, w = ring_weights(np.array([d]), np.array([a]), edges)
    # midpoint quadrature of the disk's area in polar coordinates about the axis
    rho = np.linspace(d - a, d + a, 4001)
    rho = 0.5 * (rho[1:] + rho[:-1])
    drho = rho[1] - rho[0]
    half_angle = np.arccos(np.clip((rho**2 + d**2 - a**2) / (2 * rho * d), -1, 1))
    strip = 2 * half_angle * rho * drho
    ring = np.searchsorted(edges, rho, side="right") - 1
    quad = np.array([strip[ring == j].sum() for j in k]) / (np.pi * a * a)
    assert np.allclose(w, quad, atol=2e-4)
    assert w.sum() == pytest.approx(area_inside_circle(d, a, edges[-1]) / (np.pi * a * a)
                                    - area_inside_circle(d, a, edges[0]) / (np.pi * a * a))


def test_the_lens_area_agrees_with_the_textbook_formula_in_extended_precision():
    """The lens area (segments r^2 theta - chord x, no sine or cosine) against
    R^2 acos(x/R) + a^2 acos((d-x)/a) - d chord in 80-bit long doubles, for disks cut
    anywhere by circles 10 to 100 radii away, down to slivers 1e-7 a deep: 1e-10 of
    pi a^2 (the reference's own acos near 1 limits it to about 2e-11 in the slivers)."""
    ld = np.longdouble
    if np.finfo(ld).eps > 1e-18:
        pytest.skip("no extended precision long double on this platform")
    rng = np.random.default_rng(3)
    a = rng.uniform(0.003, 0.0045, 4000)
    R = a * 10 ** rng.uniform(1.0, 2.0, a.size)
    u = rng.uniform(-1, 1, a.size)
    u[::4] = np.sign(u[::4]) * (1 - 10 ** rng.uniform(-7, -2, a.size // 4))   # slivers
    d = R + a * u
    mine = area_inside_circle(d, a, R)
    a_, R_, d_ = (v.astype(ld) for v in (a, R, d))
    x = (d_ * d_ + R_ * R_ - a_ * a_) / (2 * d_)
    chord = np.sqrt(R_ * R_ - x * x)
    exact = R_ * R_ * np.arccos(x / R_) + a_ * a_ * np.arccos((d_ - x) / a_) - d_ * chord
    assert np.max(np.abs(mine - exact.astype(float)) / (np.pi * a * a)) < 1e-10


def test_a_segment_keeps_1e_13_of_its_area_on_both_sides_of_the_series_threshold():
    """A circle's segment (chord half-length c at distance x from the centre): the series
    in t = c / x below t = 0.1, r^2 atan2(c, x) - c x above, against the same in 80-bit
    long doubles; dropping the series' last term (2 t^10 / 143) would miss by 2e-12."""
    ld = np.longdouble
    if np.finfo(ld).eps > 1e-18:
        pytest.skip("no extended precision long double on this platform")
    x = 0.1
    chord = x * np.concatenate([np.linspace(0.02, 0.1, 400), np.linspace(0.1, 1.0, 100)])
    mine = np.array([cut(x * x + c * c, c, x) for c in chord])
    c_, x_ = chord.astype(ld), ld(x)
    exact = (x_ * x_ + c_ * c_) * np.arctan2(c_, x_) - c_ * x_
    assert np.max(np.abs(mine - exact.astype(float)) / exact.astype(float)) < 1e-13
