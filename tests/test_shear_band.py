"""The shear band's estimator (granavg.analysis.shear_band) on profiles whose v0 and s
are known: exact exponentials, the first layer's staircase, noise floors, replicates,
and synthetic ensembles whose stated errors must cover the s they were made with."""

import numpy as np
import pytest

from granavg.analysis import shear_band as sb
from granavg.paper.claims import analyze
from granavg.engine.uncertainty.blocking import Replicates
from granavg.errors import UserError
from tests.helpers import D_MEAN, SCENE, profiles

R_I, R_O, OMEGA = SCENE["R_i"], SCENE["R_o"], SCENE["Omega"]
V0 = 0.645 * OMEGA * R_I


def rings(n):
    edges = np.linspace(R_I, R_O, n + 1)
    return 0.5 * (edges[1:] + edges[:-1])


def staircase(r, s, v0=V0):
    """The exponential beyond the first layer; the first layer (within one mean diameter
    of the wall) moving as one block at the exponential's value at its centre."""
    x = r - R_I
    return v0 * np.exp(-np.where(x < D_MEAN, D_MEAN / 2, x) / s)


def test_an_exact_exponential_gives_back_v0_and_s():
    r = rings(60)
    s = 0.0127
    v = V0 * np.exp(-(r - R_I) / s)
    v[r > R_I + 9 * s] = 1e-12 * V0                     # a floor far below the band
    band = sb.fit_band(r, v, np.full_like(r, 1e-4 * V0), R_I, D_MEAN, OMEGA)
    assert band.v0 == pytest.approx(V0, rel=1e-9) and band.s == pytest.approx(s, rel=1e-9)
    assert r[band.start] - R_I >= D_MEAN > r[band.start - 1] - R_I  # first layer left out


def test_the_first_layers_staircase_biases_a_fit_that_keeps_it():
    """The first layer's rings, all at the layer's velocity, pull a fit that includes
    them (weighted by their small relative errors, as granavg's estimator did before)
    towards a plateau; the estimator that starts beyond them gives back v0 and s exactly.
    Errors as measured: nearly constant in m/s, so relatively small at the wall."""
    r = rings(60)
    for s in (0.005, 0.0127):
        v = staircase(r, s)
        sem = 0.01 * V0 + 0.02 * v
        band = sb.fit_band(r, v, sem, R_I, D_MEAN, OMEGA)
        assert band.s == pytest.approx(s, rel=1e-9) and band.v0 == pytest.approx(V0, rel=1e-9)
        old = sb.fit_band(r, v, sem, R_I, D_MEAN, OMEGA, sb.BandRule(first_layer=True,
                                                                     weights="errors"))
        assert old.s / s - 1 > 0.03 and 1 - old.v0 / V0 > 0.03     # +62% at 5 mm


def test_the_decay_range_stops_at_the_noise():
    rng = np.random.default_rng(2)
    r = rings(60)
    s, floor = 0.0127, 5e-5
    v = V0 * np.exp(-(r - R_I) / s) + rng.normal(0, floor, len(r))
    sem = np.full(len(r), floor)
    band = sb.fit_band(r, v, sem, R_I, D_MEAN, OMEGA)
    r_noise = R_I + s * np.log(V0 / (sb.SIGNIFICANCE * floor))   # the exponential at 3 sem
    assert abs(band.r_max - r_noise) <= 2 * (r[1] - r[0])
    assert band.s == pytest.approx(s, rel=0.1)
    # a constant floor (a creeping bulk) ends the range where it reaches a third of v
    v = V0 * np.exp(-(r - R_I) / 0.006) + 1e-6
    end = sb.decay_end(v, np.full(len(r), 1e-9), 0)
    assert v[end - 1] > 3 * sb.noise_floor(v) >= v[end]


def test_the_scatter_is_zero_where_the_errors_explain_it_and_found_where_they_do_not():
    rng = np.random.default_rng(3)
    x = np.linspace(0, 0.03, 400)
    e = np.full(len(x), 0.05)
    assert sb.scatter(x, 1 - x / 0.01 + 0.5 * e * rng.standard_normal(len(x)), e) == 0.0
    tau = sb.scatter(x, 1 - x / 0.01 + np.hypot(0.05, 0.2) * rng.standard_normal(len(x)), e)
    assert tau == pytest.approx(0.2, rel=0.1)


def test_a_replicate_at_or_below_zero_in_a_fitted_ring_gets_zero_weight():
    """A replicate's v_phi <= 0 in the fixed range (noise at the band's end) is the limit
    v -> 0+ of a ring whose weight vanishes: the fit is finite and continuous."""
    rng = np.random.default_rng(5)
    r = rings(60)
    s = 0.0127
    v = V0 * np.exp(-(r - R_I) / s) * (1 + rng.normal(0, 0.05, len(r)))
    sem = 0.05 * V0 * np.exp(-(r - R_I) / s) + 1e-6
    band = sb.fit_band(r, v, sem, R_I, D_MEAN, OMEGA)
    k = band.end - 2
    near, low = v.copy(), v.copy()
    near[k], low[k] = 1e-300, -2e-6
    got, ref = sb.refit(band, r, low, R_I, OMEGA), sb.refit(band, r, near, R_I, OMEGA)
    assert np.isfinite(got.s) and got.n_rings == band.n_rings
    assert got.s == pytest.approx(ref.s, rel=1e-3) and got.v0 == pytest.approx(ref.v0, rel=1e-3)
    low[band.start] = -1e-6                             # the band's first ring: no fit
    with pytest.raises(UserError, match="no decay to fit"):
        sb.refit(band, r, low, R_I, OMEGA)


@pytest.mark.parametrize("v", [np.full(20, np.nan), np.zeros(20), np.array([0.006]),
                               np.r_[0.006, 0.003, np.zeros(18)]])
def test_degenerate_profiles_give_a_clear_message(v):
    r = rings(len(v))
    with pytest.raises(UserError, match="no decay to fit"):
        sb.fit_band(r, v, np.full(len(v), 1e-5), R_I, D_MEAN, OMEGA)


def test_the_systematic_error_is_the_largest_shift_of_the_variants():
    rng = np.random.default_rng(7)
    fine, coarse = rings(60), rings(20)
    make = [(r, staircase(r, 0.0127) * (1 + rng.normal(0, 0.05, len(r))),
             0.05 * staircase(r, 0.0127)) for r in (fine, coarse)]
    band = sb.fit_band(*make[0], R_I, D_MEAN, OMEGA)
    out = sb.sensitivity(*make, R_I, D_MEAN, OMEGA, band)
    shift = out.pop("largest shift")
    assert set(out) == set(sb.VARIANTS) | set(sb.ALSO)
    assert shift["s"] == pytest.approx(max(abs(out[k]["s"] - band.s) for k in sb.VARIANTS))
    assert shift["s"] > 0 and all(np.isfinite(x["s"]) for x in out.values())


def ensemble(n, s, runs, rng, rel=0.1, absolute=2e-5, v0_ratio=0.645):
    """Fields of ``runs`` synthetic realisations: every field as in tests/test_claims,
    v_phi a first-layer staircase and exponential with realisation-to-realisation noise,
    relative and absolute (the creeping bulk's)."""
    p = profiles(n, n_rep=runs, noise=1e-3, seed=int(rng.integers(1 << 30)))
    true = staircase(p.cells.centre, s, v0_ratio * OMEGA * R_I)
    reps = dict(p.replicates.values)
    reps["v_phi"] = (true[None] * (1 + rel * rng.standard_normal((runs, n)))
                     + absolute * rng.standard_normal((runs, n)))
    p.replicates = Replicates("runs", reps)
    p.values = {**p.values, "v_phi": reps["v_phi"].mean(axis=0)}
    p.sem = {**p.sem, "v_phi": p.replicates.profile_errors()["v_phi"]}
    return p


@pytest.mark.slow
@pytest.mark.parametrize("s", [0.006, 0.0127])
def test_the_stated_errors_cover_the_s_the_profiles_were_made_with(s):
    """40 synthetic ensembles of 6 realisations each, first-layer staircase and noise:
    s lies within 2 of the report's combined errors (statistical from the realisations,
    systematic from the estimator's variants) of the true s in at least 80% of them
    (a t distribution with 5 degrees of freedom puts 90% within 2), and their mean is
    within 3% of it."""
    rng = np.random.default_rng(11)
    hits, got = 0, []
    for _ in range(40):
        summary = analyze(ensemble(20, s, 6, rng), ensemble(60, s, 6, rng), {"scene": SCENE})
        b = summary["numbers"]["shear_band"]
        hits += abs(b["s_m"] - s) <= 2 * np.hypot(b["s_m_err"], b["s_m_sys"])
        got.append(b["s_m"])
    assert hits >= 32, hits
    assert np.mean(got) == pytest.approx(s, rel=0.03)
