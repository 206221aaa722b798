"""The local rheology (granavg.analysis.rheology, ``granavg rheology``): analytic shear
flows with known stresses, in 2D and 3D, on Cartesian and polar cells, give every
column (pressure P, shear_stress tau, shear_rate gamma_dot, friction mu,
inertial_number I, N1, N2, axes_angle, fluidity) exactly, unchanged when the frame
turns; the errors are the replicates' spread of the same function; undefined cells are
NaN and flagged, never 0; the fits recover known laws and their errors see the points'
correlation; a written rheology reads back with its units; and on a real Couette run
the command line gives the API's numbers."""

import dataclasses
import json

import numpy as np
import pytest

import granavg
from granavg.analysis.rheology import (COLUMNS, MU_I, Z_OUTSIDE, fit_law, fit_laws,
                                       fit_mu_I, fit_phi_I, local_law, rheology)
from granavg.cells import Boxes, Grid, Rings, Slabs
from granavg.engine.fields import Fields
from granavg.engine.quantities import columns
from granavg.engine.uncertainty.blocking import Replicates
from granavg.engine.unit_system import SI
from granavg.errors import ParameterError, UserError
from granavg.io.profiles_io import read_profiles, write_profiles

from .helpers import run_cli

D_P, RHO = 0.002, 2500.0
#: The flow frame's stress: -P0 + A, -P0 - A on the diagonal, T0 off it, B on S_zz (3D).
P0, A, T0, B = 100.0, 5.0, 30.0, 8.0
#: Shear rate, kinetic (fluctuation) pressure, antisymmetric part of sigma.
G, K, C = 2.0, 1.5, 4.0


def rotation(dim, a=0.0, b=0.0):
    """A rotation by a about z, then (3D) by b about x."""
    R = np.eye(dim)
    R[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    if dim == 3:
        Rx = np.eye(3)
        Rx[1:, 1:] = [[np.cos(b), -np.sin(b)], [np.sin(b), np.cos(b)]]
        R = Rx @ R
    return R


def tensor_columns(name, axes, T):
    """Columns of a tensor field T (n, D, D) named in a basis."""
    return {c: T[:, i, j] for (i, j), c in zip(np.ndindex(len(axes), len(axes)),
                                              columns(name, axes))}


def flow_stress(dim, p0=P0, t0=T0):
    """The total stress S' in the flow frame: -p0 + A, -p0 - A (and -p0 + B in 3D) on
    the diagonal, t0 off it."""
    Sp = -p0 * np.eye(dim)
    Sp[0, 0] += A
    Sp[1, 1] -= A
    Sp[0, 1] = Sp[1, 0] = t0
    if dim == 3:
        Sp[2, 2] += B
    return Sp


def shear(cells, R, p0=P0, g=G, t0=T0):
    """Simple shear v' = g y' e_x' with the stress :func:`flow_stress` in the flow
    frame, turned by R: the fields' columns (sigma = S + K 1 + an antisymmetric part,
    dsigma_fluct = K 1)."""
    axes, D = cells.axes, cells.dim
    X = np.stack([cells.coordinates().get(a, np.zeros(cells.n)) for a in axes], -1)
    xp = X @ R                                          # R^T x, row by row
    v = np.zeros_like(X)
    v[:, 0] = g * xp[:, 1]
    v = v @ R.T
    Sp = flow_stress(D, p0, t0)
    Wp = np.zeros((D, D))
    Wp[0, 1], Wp[1, 0] = C, -C
    n = cells.n
    S = np.broadcast_to(R @ Sp @ R.T, (n, D, D))
    sigma = S + K * np.eye(D) + R @ Wp @ R.T
    return {**{f"v_{a}": v[:, i] for i, a in enumerate(axes)},
            **tensor_columns("sigma", axes, sigma),
            **tensor_columns("dsigma_fluct", axes, np.broadcast_to(K * np.eye(D), (n, D, D))),
            "nu": np.full(n, 0.6)}


def expected(dim, p0=P0, g=G, t0=T0):
    """The rheology of :func:`shear`, from the flow frame's numbers alone."""
    Sp = flow_stress(dim, p0, t0)
    P = -np.trace(Sp) / dim
    s = Sp + P * np.eye(dim)
    tau = np.sqrt(0.5 * np.sum(s * s))
    stress_axis = 0.5 * np.degrees(np.arctan2(2 * t0, 2 * A))     # its most tensile axis
    angle = (stress_axis - 45.0 + 90.0) % 180.0 - 90.0              # D's at 45 degrees
    out = {"pressure": P, "shear_stress": tau, "shear_rate": abs(g), "friction": tau / P,
           "inertial_number": abs(g) * D_P / np.sqrt(P / RHO), "N1": 2 * A, "nu": 0.6,
           "axes_angle": angle if dim == 2 else abs(angle), "fluidity": abs(g) * P / tau}
    if dim == 3:
        out["N2"] = Sp[1, 1] - Sp[2, 2]
    return out


def fields_of(cells, values, reps=None, kind="jackknife", flags=None, meta=None):
    n = cells.n
    rep = None if reps is None else Replicates(kind, reps)
    sem = rep.profile_errors() if rep else {k: np.full(n, np.nan) for k in values}
    return Fields(cells, values, sem,
                  np.array(flags if flags is not None else [""] * n, dtype=object), 10,
                  dict(meta or {}), rep)


GRID = Grid(np.linspace(0.0, 1.0, 6), np.linspace(-0.6, 0.6, 7), 1.0)
BOXES = Boxes(np.linspace(-0.5, 0.5, 5), np.linspace(-0.5, 0.5, 5), np.linspace(0, 1, 5))


@pytest.mark.parametrize("cells", [GRID, BOXES], ids=["2D grid", "3D boxes"])
@pytest.mark.parametrize("turn", [(0.0, 0.0), (0.7, 0.0), (2.2, 1.1)],
                         ids=["flow frame", "turned", "turned twice"])
def test_simple_shear_gives_every_number_exactly_in_any_frame(cells, turn):
    """v' = g y' e_x', S' known: P, tau, gamma_dot, mu, I, N1, N2, the angle and the
    fluidity as the flow frame's numbers give them, in every cell, however the frame
    turns (the flow frame is found from D and the velocity); the antisymmetric part of
    sigma and the kinetic stress enter as stated (S = sym(sigma - dsigma_fluct))."""
    R = rotation(cells.dim, *turn)
    got = rheology(fields_of(cells, shear(cells, R)), diameter=D_P, density=RHO)
    want = expected(cells.dim)
    assert set(got.values) == set(want)
    for name, value in want.items():
        assert np.allclose(got.values[name], value, rtol=1e-10, atol=1e-10), name
    assert not any(f for f in got.flags)
    assert got.units["pressure"] == "Pa" and got.units["shear_rate"] == "1/s" and \
        got.units["axes_angle"] == "deg" and got.units["inertial_number"] == "1"


def test_the_shear_rate_is_the_rate_of_simple_shear_and_the_stress_sqrt_j2():
    """gamma_dot = g for v_x = g y (both signs of g); a stress that is pure pressure has
    tau = 0, mu = 0 and no stress axes (the angle NaN and flagged, not 0)."""
    for g in (3.0, -3.0):
        got = rheology(fields_of(GRID, shear(GRID, np.eye(2), g=g)), diameter=D_P,
                       density=RHO)
        assert np.allclose(got.values["shear_rate"], 3.0)
    iso = shear(GRID, np.eye(2), t0=0.0)
    for k in ("sigma_xx", "sigma_yy"):
        iso[k] = np.full(GRID.n, -P0 + K)
    got = rheology(fields_of(GRID, iso), diameter=D_P, density=RHO)
    assert np.allclose(got.values["shear_stress"], 0.0)
    assert np.allclose(got.values["friction"], 0.0)
    assert np.all(np.isnan(got.values["axes_angle"]))
    assert all("no_shear_stress" in f for f in got.flags)


def test_a_wall_moving_along_the_gradient_does_not_turn_the_flow_frame():
    """Simple shear seen from a frame moving fast along the gradient direction: the
    velocity lies along e_y, but it changes along y, so the flow is not a shear along
    its streamlines and the velocity gradient decides: N1 keeps its sign."""
    values = shear(GRID, np.eye(2))
    values["v_y"] = values["v_y"] + 50.0
    got = rheology(fields_of(GRID, values), diameter=D_P, density=RHO)
    assert np.allclose(got.values["N1"], 2 * A)


def rings_state(rings, v_phi, t0=T0):
    """Ring fields: v_phi(r), a stress with S_rr = -P0 + A, S_phiphi = -P0 - A,
    S_rphi = t0."""
    n = rings.n
    S = np.zeros((n, 2, 2))
    S[:, 0, 0], S[:, 1, 1], S[:, 0, 1], S[:, 1, 0] = -P0 + A, -P0 - A, t0, t0
    return {"v_r": np.zeros(n), "v_phi": v_phi, **tensor_columns("sigma", rings.axes, S),
            "nu": np.full(n, 0.8)}


def test_polar_cells_add_the_curvature_terms():
    """Rings: a rigid rotation has no shear (D_rphi = (dv/dr - v/r)/2 = 0: flagged, I
    NaN); Couette flow v_phi = a/r + b r has gamma_dot = 2 |a| / r^2 (second-order
    differences: to 1e-5 on 400 rings), its flow direction e_phi even where it is
    irrotational (b = 0), so N1 = S_phiphi - S_rr."""
    rings = Rings.count(400, 0.04, 0.08, 0.006)
    r = rings.centre
    rigid = rheology(fields_of(rings, rings_state(rings, 0.5 * r)), diameter=D_P,
                     density=RHO)
    assert np.max(rigid.values["shear_rate"]) < 1e-12
    assert np.all(np.isnan(rigid.values["inertial_number"]))
    for a, b in ((1e-4, 0.3), (1e-4, 0.0), (-2e-4, 0.1)):
        got = rheology(fields_of(rings, rings_state(rings, a / r + b * r)), diameter=D_P,
                       density=RHO)
        assert np.allclose(got.values["shear_rate"], 2 * abs(a) / r ** 2, rtol=1e-5)
        assert np.allclose(got.values["N1"], -2 * A)
        assert not any("no_flow_frame" in f for f in got.flags)


def test_a_kernels_strain_rate_is_taken_as_given():
    """Fields of a smoothing kernel hold D and W: the shear rate is D's, the flow frame
    from L = D - W (no velocity derivative taken)."""
    cells = Slabs(np.linspace(0.0, 1.0, 5), 1.0, "y", 1.0)
    values = shear(cells, np.eye(2))
    n = cells.n
    rate = np.zeros((n, 2, 2))
    rate[:, 0, 1] = rate[:, 1, 0] = 3.5                        # v_x = 7 y: D_xy = 3.5
    spin = np.zeros((n, 2, 2))
    spin[:, 0, 1], spin[:, 1, 0] = -3.5, 3.5                   # W_ij = (L_ji - L_ij) / 2
    values.update(tensor_columns("D", cells.axes, rate), **tensor_columns("W", cells.axes, spin))
    values = {k: v for k, v in values.items() if not k.startswith("v_")}
    got = rheology(fields_of(cells, values), diameter=D_P, density=RHO)
    assert np.allclose(got.values["shear_rate"], 7.0) and np.allclose(got.values["N1"], 2 * A)
    assert "kernel" in got.meta["rheology"]["strain_rate"]


@pytest.mark.parametrize("kind", ["jackknife", "runs"])
def test_the_errors_are_the_replicates_spread_of_the_same_function(kind):
    """Each replicate a shear with its own pressure, shear stress and rate: every
    column's error is the jackknife (or between-run) spread of that column computed by
    hand on the replicates, cell by cell; the values come from the fields, not from the
    replicates' mean."""
    rng = np.random.default_rng(3)
    n_rep = 9
    p0 = P0 * (1 + 0.03 * rng.standard_normal(n_rep))
    g = G * (1 + 0.1 * rng.standard_normal(n_rep))
    t0 = T0 * (1 + 0.05 * rng.standard_normal(n_rep))
    each = [shear(GRID, np.eye(2), p, h, t) for p, h, t in zip(p0, g, t0)]
    reps = {k: np.stack([e[k] for e in each]) for k in each[0]}
    got = rheology(fields_of(GRID, shear(GRID, np.eye(2)), reps, kind), diameter=D_P,
                   density=RHO)
    tau = np.sqrt(A ** 2 + t0 ** 2)
    by_hand = {"pressure": p0, "shear_stress": tau, "shear_rate": np.abs(g),
               "friction": tau / p0, "inertial_number": np.abs(g) * D_P * np.sqrt(RHO / p0),
               "fluidity": np.abs(g) * p0 / tau,
               "axes_angle": 0.5 * np.degrees(np.arctan2(2 * t0, 2 * A)) - 45.0}
    for name, x in by_hand.items():
        if kind == "jackknife":
            err = np.sqrt((n_rep - 1) / n_rep * np.sum((x - x.mean()) ** 2))
        else:
            err = np.std(x, ddof=1) / np.sqrt(n_rep)
        assert np.allclose(got.sem[name], err, rtol=1e-9), name
        assert np.allclose(got.replicates.values[name], x[:, None], rtol=1e-9), name
    assert np.allclose(got.values["friction"], expected(2)["friction"])
    assert got.replicates.kind == kind


def test_undefined_cells_are_nan_and_flagged_never_zero():
    """Slabs across y: the first two slabs do not shear (v uniform), the fifth has a
    pressure within its error of 0, the sixth is in tension. Their I, mu, fluidity, N1
    and angle are NaN with no_shear or no_pressure; the measured P, tau, gamma_dot stay;
    the fields' own flags are kept."""
    cells = Slabs(np.linspace(0.0, 0.6, 7), 1.0, "y", 1.0)
    y = cells.coordinates()["y"]
    P = np.array([50.0, 50.0, 50.0, 50.0, 0.5, -20.0])

    def state(pressure):
        n = cells.n
        S = np.zeros((n, 2, 2))
        S[:, 0, 0] = S[:, 1, 1] = -pressure
        S[:, 0, 1] = S[:, 1, 0] = 10.0
        return {"v_x": np.where(y < 0.3, 0.6, 2.0 * y), "v_y": np.zeros(n),
                **tensor_columns("sigma", cells.axes, S), "nu": np.full(n, 0.7)}
    rng = np.random.default_rng(0)
    each = [state(P + rng.standard_normal(cells.n)) for _ in range(8)]
    reps = {k: np.stack([e[k] for e in each]) for k in each[0]}
    flags = ["sem_lower_bound"] + [""] * 5
    got = rheology(fields_of(cells, state(P), reps, flags=flags), diameter=D_P, density=RHO)
    f = [str(x).split(";") for x in got.flags]
    assert [("no_shear" in x) for x in f] == [True, True, False, False, False, False]
    assert [("no_pressure" in x) for x in f] == [False, False, False, False, True, True]
    assert f[0][0] == "sem_lower_bound"
    v = got.values
    for k in (0, 1):
        assert v["shear_rate"][k] < 1e-12 and np.isfinite(v["friction"][k])
        assert all(np.isnan(v[c][k])
                   for c in ("inertial_number", "fluidity", "N1", "axes_angle"))
    for k in (4, 5):
        assert np.isfinite(v["pressure"][k])
        assert all(np.isnan(v[c][k]) for c in ("friction", "inertial_number", "fluidity"))
    for k in (2, 3):
        assert all(np.isfinite(v[c][k]) for c in v), k
    for c in ("friction", "inertial_number", "fluidity", "N1", "axes_angle"):
        assert np.all(np.isnan(got.sem[c][np.isnan(v[c])])), c
    for c in ("friction", "inertial_number", "fluidity"):    # none is 0 where it is defined
        assert not np.any(v[c] == 0.0), c


def test_a_mixtures_species_take_their_own_diameter_and_the_whole_pressure():
    """Species fields: each species' mu is its partial stress's; its I takes its own
    diameter, its own shear rate and the whole's pressure; a species of unknown size
    gets no I (NaN, flag no_diameter), not the mean's."""
    whole = shear(GRID, np.eye(2))
    half = {k: (0.5 * v if k.startswith(("sigma", "dsigma")) else v) for k, v in whole.items()}
    parts = {n: fields_of(GRID, vals) for n, vals in
             (("all", whole), ("small", half), ("large", half))}
    mixture = Fields.of_species(parts, {})
    got = rheology(mixture, diameter={"all": D_P, "small": 0.5 * D_P}, density=RHO)
    assert got.species == ("all", "small", "large")
    whole_I = expected(2)["inertial_number"]
    assert np.allclose(got.of("all").values["inertial_number"], whole_I)
    assert np.allclose(got.of("small").values["inertial_number"], 0.5 * whole_I)
    assert np.allclose(got.of("small").values["friction"],
                       expected(2)["friction"])                  # tau/P of half
    assert np.allclose(got.of("small").values["pressure"], 0.5 * expected(2)["pressure"])
    assert np.all(np.isnan(got.of("large").values["inertial_number"]))
    assert all("no_diameter" in f for f in got.of("large").flags)


def test_what_the_rheology_cannot_take_is_refused_in_one_line():
    values = shear(GRID, np.eye(2))
    plain = fields_of(GRID, values)
    with pytest.raises(UserError, match="give diameter"):
        rheology(plain, density=RHO)
    with pytest.raises(UserError, match="give density"):
        rheology(plain, diameter=D_P)
    with pytest.raises(UserError, match="positive"):
        rheology(plain, diameter=-1.0, density=RHO)
    in_time = Fields.stack([plain, plain], [0.0, 1.0])
    with pytest.raises(UserError, match="fields in time"):
        rheology(in_time, diameter=D_P, density=RHO)
    real = fields_of(GRID, values, meta={"unit_system": {
        "style": "real", "length": "A", "time": "fs", "mass": "g/mol", "force":
        "kcal/(mol A)", "stress": "atm", "momentum_flux": "g/mol A^2/fs^2/A^3"}})
    with pytest.raises(UserError, match="real units"):
        rheology(real, diameter=D_P, density=RHO)
    no_v = fields_of(GRID, {k: v for k, v in values.items() if not k.startswith("v_")})
    with pytest.raises(UserError, match="velocity"):
        rheology(no_v, diameter=D_P, density=RHO)
    for err in ("give diameter", "fields in time"):
        with pytest.raises(UserError) as caught:
            rheology(in_time if "time" in err else plain, density=RHO)
        assert "\n" not in str(caught.value)


@pytest.mark.parametrize("profile", ["constant", "r^0.4", "r^-0.3"])
def test_couette_flow_whose_velocity_varies_slowly_keeps_its_flow_direction(profile):
    """v_phi(r) constant or a slow power of r: in the polar basis |L e_phi| = v_phi / r
    (the curvature term) exceeds |L e_r| = |dv_phi/dr|, yet the flow runs along its
    circles: e_f = e_phi, so N1 = S_phiphi - S_rr = -2A in every ring."""
    rings = Rings.count(40, 0.04, 0.08, 0.006)
    x = rings.centre / 0.04
    v = {"constant": 0.01 + 0 * x, "r^0.4": 0.01 * x ** 0.4, "r^-0.3": 0.01 * x ** -0.3}
    got = rheology(fields_of(rings, rings_state(rings, v[profile])), diameter=D_P,
                   density=RHO)
    assert np.allclose(got.values["N1"], -2 * A)
    assert not any("no_flow_frame" in f for f in got.flags)


def noise_fields(cells, kind, n_rep=8, seed=0, rate=0.0):
    """Fields with no mean shear rate and no mean shear stress: each replicate's velocity
    and stress deviator pure noise about a pressure P0 (jackknife: the delete-one means
    of ``n_rep`` blocks; runs: ``n_rep`` realisations); ``rate``: a simple shear
    v_x = rate y added."""
    rng = np.random.default_rng(seed)
    axes, D, n = cells.axes, cells.dim, cells.n
    y = cells.coordinates()["y"]
    each = []
    for _ in range(n_rep):
        v = 0.05 * rng.standard_normal((n, D))
        v[:, 0] += rate * y
        T = 0.5 * rng.standard_normal((n, D, D))
        T = T + np.swapaxes(T, 1, 2) - P0 * np.eye(D)
        each.append({**{f"v_{a}": v[:, i] for i, a in enumerate(axes)},
                     **tensor_columns("sigma", axes, T),
                     "nu": np.full(n, 0.6)})
    reps = {k: np.stack([e[k] for e in each]) for k in each[0]}
    values = {k: x.mean(axis=0) for k, x in reps.items()}
    if kind == "jackknife":
        reps = {k: (n_rep * values[k] - x) / (n_rep - 1) for k, x in reps.items()}
    return fields_of(cells, values, reps, kind)


NOISE_CELLS = {"2D": Grid(np.linspace(0, 1, 21), np.linspace(-0.6, 0.6, 21), 1.0),
               "3D": Boxes(np.linspace(0, 1, 9), np.linspace(-0.6, 0.6, 9),
                           np.linspace(0, 1, 8))}


@pytest.mark.parametrize("kind", ["jackknife", "runs"])
@pytest.mark.parametrize("dim", ["2D", "3D"])
def test_pure_noise_is_rarely_taken_for_a_shear(dim, kind):
    """No mean shear rate nor shear stress, only noise (400 and 448 cells, 8 replicates):
    the norms gamma_dot and tau are positive and biased up, but judged on their
    deviators' components together few cells pass - about the nominal 2.3%, under 10%
    - where the norms against their own errors let a fifth to most of them through.
    A clear simple shear is a shear in every cell."""
    cells = NOISE_CELLS[dim]
    got = rheology(noise_fields(cells, kind), diameter=D_P, density=RHO)
    for flag in ("no_shear", "no_shear_stress"):
        passed = np.mean([flag not in str(f).split(";") for f in got.flags])
        assert passed < 0.10, (flag, passed)
    sheared = rheology(noise_fields(cells, kind, rate=5.0), diameter=D_P, density=RHO)
    assert not any("no_shear" in str(f).split(";") for f in sheared.flags)


def test_the_replicates_keep_the_fields_flow_frame():
    """Simple shear v_x = g y (flow direction e_x). Two replicates are the pure shear with
    the same strain rate (v_x = g y / 2, v_y = g x / 2: no direction the velocity does
    not change along), the velocity along e_y on one, between e_x and e_y on the other:
    alone, they would take e_y for the flow direction (N1 = -2A) or none (NaN). They
    keep the fields' e_x: N1 = 2A on every replicate, its error 0."""
    values = shear(GRID, np.eye(2))
    x, y = GRID.coordinates()["x"], GRID.coordinates()["y"]
    along_y = dict(values, v_x=G * y / 2, v_y=G * x / 2 + 50.0)
    between = dict(values, v_x=G * y / 2 + 100.0, v_y=G * x / 2 + 100.0)
    each = [values] * 6 + [along_y, between]
    reps = {k: np.stack([e[k] for e in each]) for k in values}
    got = rheology(fields_of(GRID, values, reps), diameter=D_P, density=RHO)
    assert np.allclose(got.replicates.values["N1"], 2 * A)
    assert np.allclose(got.sem["N1"], 0.0)


def test_a_column_undefined_on_a_replicate_has_no_error(caplog):
    """30 runs with a clear pressure, but one is in tension in cell 0: its friction, I and
    fluidity are undefined there. The cell keeps its values, but their errors are NaN,
    not the spread of the 29 others; the other cells' errors are finite."""
    rng = np.random.default_rng(4)
    each = [shear(GRID, np.eye(2), p0=P0 * (1 + 0.02 * rng.standard_normal()))
            for _ in range(30)]
    for k in ("sigma_xx", "sigma_yy"):
        each[0][k] = each[0][k].copy()
        each[0][k][0] = 10.0 + K                                  # S_xx = S_yy = +10
    reps = {k: np.stack([e[k] for e in each]) for k in each[0]}
    values = {k: x.mean(axis=0) for k, x in reps.items()}
    got = rheology(fields_of(GRID, values, reps, "runs"), diameter=D_P, density=RHO)
    for c in ("friction", "inertial_number", "fluidity"):
        assert np.isfinite(got.values[c][0]) and np.isnan(got.sem[c][0]), c
        assert np.all(np.isfinite(got.sem[c][1:])), c
    assert "undefined on some replicate" in caplog.text


def test_fluidity_needs_a_shear_stress():
    """A shear under a stress whose deviator is noise (its shear stress 0.3 Pa, the
    replicates' +-0.5 to +-2 Pa): tau is not distinguishable from 0, so mu = tau / P is
    noise and the fluidity gamma_dot / mu is NaN, with the flag no_shear_stress, not a
    large number."""
    def state(t0):
        out = shear(GRID, np.eye(2), t0=t0)
        for k in ("sigma_xx", "sigma_yy"):
            out[k] = np.full(GRID.n, -P0 + K)
        return out
    each = [state(t) for t in (1.0, -1.0, 2.0, -2.0, 0.5, -0.5, 1.5, -1.5)]
    reps = {k: np.stack([e[k] for e in each]) for k in each[0]}
    got = rheology(fields_of(GRID, state(0.3), reps), diameter=D_P, density=RHO)
    assert all("no_shear_stress" in f for f in got.flags)
    assert np.all(np.isfinite(got.values["shear_rate"]))
    assert np.all(np.isnan(got.values["fluidity"])) and np.all(np.isnan(got.sem["fluidity"]))


def test_bad_diameters_of_a_mixture_are_refused_in_one_line():
    """A species' diameter in the mapping that is not a positive number, or a name that
    is not a species, is refused (ParameterError), not a traceback or a NaN I."""
    whole = shear(GRID, np.eye(2))
    mixture = Fields.of_species({n: fields_of(GRID, whole) for n in ("all", "small")}, {})
    for bad in ({"all": D_P, "small": -1.0}, {"all": D_P, "small": "big"},
                {"all": D_P, "smal": D_P}, {"all": float("nan")}):
        with pytest.raises(ParameterError, match="diameter") as caught:
            rheology(mixture, diameter=bad, density=RHO)
        assert "\n" not in str(caught.value)


# -- fits ------------------------------------------------------------------------------------

TRUE = {"mu_s": 0.35, "mu_2": 0.8, "I_0": 0.3}
LINE = Slabs(np.linspace(0.0, 1.0, 31), 1.0, "y", 1.0)


def points(mu_of, I, noise, common=0.0, n_rep=24, seed=1, extra=None, i_noise=0.0):
    """A rheology-like Fields of cells with I and mu (and nu = 0.6 - 0.2 I): ``n_rep``
    realisations each with independent noise on every cell and a shift ``common`` x
    N(0, 1) of all its cells together; values their mean, errors between runs. I is
    exact (error 0) unless ``i_noise``: each realisation's I then scatters by that
    share about the cell's, its mu and nu still the cell's (errors of I alone)."""
    rng = np.random.default_rng(seed)
    n = len(I)
    cells = Slabs(np.linspace(0.0, 1.0, n + 1), 1.0, "y", 1.0)
    each_I = I * (1 + i_noise * rng.standard_normal((n_rep, n))) if i_noise else \
        np.tile(I, (n_rep, 1))
    mu = mu_of(I) if extra is None else np.where(np.isnan(extra), mu_of(I), extra)
    shift = common * rng.standard_normal((n_rep, 1))
    reps = {"inertial_number": each_I,
            "friction": mu + shift + noise * rng.standard_normal((n_rep, n)),
            "nu": 0.6 - 0.2 * I + shift / 10 + noise / 10 * rng.standard_normal((n_rep, n))}
    rep = Replicates("runs", reps)
    values = {k: v.mean(axis=0) for k, v in reps.items()}
    sem = rep.profile_errors()
    return Fields(cells, values, sem, np.array([""] * n, dtype=object), 10,
                  {"rheology": {}}, rep)


def law(I):
    return MU_I.f(I, *TRUE.values())


I_POINTS = np.geomspace(1e-3, 3.0, 30)


def test_the_fit_recovers_a_known_law_within_its_errors():
    """Independent noise: mu_s, mu_2, I_0 within 3 errors of the law the points were
    made from, chi^2/dof near 1, and the replicates' errors near the fit's own (the
    points are independent here); phi(I) too."""
    fit = fit_mu_I(points(law, I_POINTS, 0.05))
    for k, v in TRUE.items():
        assert abs(fit.params[k] - v) < 3 * fit.errors[k], (k, fit.params, fit.errors)
        assert 0.5 < fit.errors[k] / fit.fit_errors[k] < 2.0, k
    assert 0.4 < fit.chi2_dof < 2.0 and fit.dof == 27
    assert not any(len(c) for c in fit.nonlocal_cells.values())
    phi = fit_phi_I(points(law, I_POINTS, 0.05))
    assert abs(phi.params["phi_max"] - 0.6) < 3 * phi.errors["phi_max"]
    assert abs(phi.params["a"] - 0.2) < 3 * phi.errors["a"]


def test_points_that_move_together_give_the_larger_error():
    """Every realisation shifts all cells together (a run's pressure moves every cell):
    the fit's own errors, points taken as independent, miss it; the replicates' refits
    see it - the error of mu_s is the common shift's error, several times the naive."""
    common = 0.03
    data = points(law, I_POINTS, 0.002, common=common)
    fit = fit_mu_I(data)
    shift_error = np.std(data.replicates.values["friction"][:, 0] - law(I_POINTS[0]),
                         ddof=1) / np.sqrt(24)
    assert fit.errors["mu_s"] > 3 * fit.fit_errors["mu_s"]
    assert fit.errors["mu_s"] == pytest.approx(shift_error, rel=0.3)


def test_independent_sources_add_their_variances():
    """Two runs fitted together: each source's share of the error from its own
    replicates, the total their quadrature sum."""
    a = points(law, I_POINTS, 0.05, seed=1)
    b = points(law, I_POINTS, 0.05, seed=2)
    fit = fit_mu_I([a, b], labels=["run a", "run b"])
    assert [s["source"] for s in fit.by_source] == ["run a", "run b"]
    for k in TRUE:
        both = np.hypot(*(s[k] for s in fit.by_source))
        assert fit.errors[k] == pytest.approx(both)
        assert abs(fit.params[k] - TRUE[k]) < 3 * fit.errors[k]


def test_creep_below_mu_s_is_found_and_left_out():
    """Five cells at small I with mu 0.1 below mu_s (creep outside a shear band): found
    as nonlocal, left out of the fit, which still recovers mu_s; :func:`local_law`
    calls the law kept inside the band and broken beyond it."""
    creep = np.full(len(I_POINTS), np.nan)
    creep[:5] = TRUE["mu_s"] - 0.1
    data = points(law, I_POINTS, 0.01, extra=creep)
    fit = fit_mu_I(data)
    assert sorted(fit.nonlocal_cells["cells"]) == [0, 1, 2, 3, 4]
    assert abs(fit.params["mu_s"] - TRUE["mu_s"]) < 3 * fit.errors["mu_s"]
    assert np.all(fit.points[0].z[:5] < -Z_OUTSIDE)
    band = np.arange(len(I_POINTS)) >= 5
    judged = local_law(fit, band)
    assert judged["band"] == "reproduced" and judged["tail"] == "reproduced"
    assert judged["tail_nonlocal"] == 5
    clean = fit_mu_I(points(law, I_POINTS, 0.01))
    assert local_law(clean, band)["tail"] == "not reproduced"   # the law holds there too
    bent = points(lambda I: law(I) + 0.2 * (I > 0.3), I_POINTS, 0.01)
    assert local_law(fit_mu_I(bent), band)["band"] == "not reproduced"


def test_too_few_points_are_refused_in_one_line():
    few = points(law, I_POINTS[:3], 0.05)
    with pytest.raises(UserError, match="needs more than 3") as caught:
        fit_mu_I(few)
    assert "\n" not in str(caught.value)
    with pytest.raises(UserError, match="not a rheology"):
        fit_mu_I(fields_of(GRID, shear(GRID, np.eye(2))))


def test_the_figures_draw_points_fit_and_creep():
    import matplotlib

    matplotlib.use("Agg")
    from granavg.analysis.rheology import plot_fits

    creep = np.full(len(I_POINTS), np.nan)
    creep[:3] = TRUE["mu_s"] - 0.1
    fit = fit_mu_I(points(law, I_POINTS, 0.01, extra=creep))
    ax = plot_fits(fit, fit_phi_I(points(law, I_POINTS, 0.01)))
    assert ax[0].get_xscale() == "log" and "friction" in ax[0].get_ylabel()
    labels = [c.get_label() for c in ax[0].containers]
    assert "cells" in labels and any("nonlocal" in x for x in labels)
    assert any(ln.get_label().startswith("mu(I)") for ln in ax[0].get_lines())


def smooth(I):
    """A friction that keeps falling with I, without a yield: no creep anywhere."""
    return 0.3 + 0.05 * np.log10(I / 1e-3)


def no_yield(law):
    """The law fitted to every point it is given (nothing left out as nonlocal)."""
    return dataclasses.replace(law, yield_param=None)


def consistent(fit, data):
    """The fit's used and nonlocal points are apart, and its parameters and chi^2 those
    of the law fitted to its used points alone."""
    pt = fit.points[0]
    assert not np.any(pt.used & pt.nonlocal_)
    again = fit_law(data, no_yield(MU_I), exclude=fit)
    assert np.array_equal(again.points[0].used, np.ones(len(again.points[0].x), bool))
    for k, v in fit.params.items():
        assert again.params[k] == pytest.approx(v, rel=1e-4, abs=1e-6), k
    assert again.chi2 == pytest.approx(fit.chi2, rel=1e-4)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_a_smooth_law_is_not_eaten_from_below(noise):
    """mu = 0.3 + 0.05 log10(I / 1e-3) on 30 points: mu(I) fits it poorly at small I, but
    no point lies below the fit of the points above it by more than 3 of its errors
    scaled by the misfit: at most a point or two left out, and mu_s where the fit to
    all points puts it."""
    data = points(smooth, I_POINTS, noise)
    fit = fit_mu_I(data)
    assert len(fit.nonlocal_cells["cells"]) <= 2
    every = fit_law(data, no_yield(MU_I))
    assert abs(fit.params["mu_s"] - every.params["mu_s"]) < every.errors["mu_s"]
    consistent(fit, data)


@pytest.mark.parametrize("drop", [0.1, 0.05])
def test_creep_over_a_third_of_the_points_is_found(drop):
    """12 of 30 points, the lowest in I, at mu_s - 0.1 or - 0.05 (a fit to all points
    takes them in, chi^2/dof 70 to 180): all found and left out, the law recovered; the
    fit's parameters and chi^2 are those of its used points."""
    creep = np.full(len(I_POINTS), np.nan)
    creep[:12] = TRUE["mu_s"] - drop
    data = points(law, I_POINTS, 0.01, extra=creep)
    fit = fit_mu_I(data)
    assert sorted(fit.nonlocal_cells["cells"]) == list(range(12))
    for k in ("mu_s", "mu_2"):
        assert abs(fit.params[k] - TRUE[k]) < 3 * fit.errors[k], k
    assert fit.chi2_dof < 2.0
    consistent(fit, data)


def test_errors_of_I_enter_the_weights_and_the_refits():
    """Each realisation's I scatters by 5% about the cell's: the points' I errors weigh
    them (effective variance: chi^2/dof near 1; with I taken as exact it is several
    times larger), the refits move I too (larger errors than with I fixed on the
    replicates), and the law is recovered within its errors."""
    data = points(law, I_POINTS, 0.002, i_noise=0.05)
    assert np.all(data.sem["inertial_number"] > 0)
    fit = fit_mu_I(data)
    for k, v in TRUE.items():
        assert abs(fit.params[k] - v) < 3 * fit.errors[k], k
    assert 0.4 < fit.chi2_dof < 2.0
    exact = Fields(data.cells, data.values, dict(data.sem, inertial_number=np.zeros(30)),
                   data.flags, 10, data.meta, data.replicates)
    assert fit_mu_I(exact).chi2_dof > 3 * fit.chi2_dof
    fixed = Replicates("runs", dict(data.replicates.values, inertial_number=np.tile(
        data.values["inertial_number"], (24, 1))))
    still = Fields(data.cells, data.values, data.sem, data.flags, 10, data.meta, fixed)
    assert fit_mu_I(still).errors["I_0"] < 0.8 * fit.errors["I_0"]


def test_a_point_undefined_on_a_replicate_takes_the_sources_errors(caplog):
    """A point used whose friction is NaN on one replicate: the refits keep one set of
    points, so that source's errors are NaN (with a warning), not refits on other sets."""
    data = points(law, I_POINTS, 0.05)
    data.replicates.values["friction"][3, 7] = np.nan
    fit = fit_mu_I(data)
    assert fit.points[0].used[7]
    assert all(np.isnan(v) for v in fit.errors.values())
    assert "undefined on a replicate" in caplog.text


def bare(data):
    """The same points without replicates, so without errors."""
    n = data.cells.n
    return Fields(data.cells, data.values, {k: np.full(n, np.nan) for k in data.values},
                  data.flags, 10, data.meta, None)


def test_sources_with_and_without_errors_are_not_pooled():
    a = points(law, I_POINTS, 0.05)
    with pytest.raises(UserError, match="no replicates") as caught:
        fit_mu_I([a, bare(a)], labels=["a", "bare"])
    assert "\n" not in str(caught.value) and "bare" in str(caught.value)


def test_a_point_without_an_error_of_I_is_left_out(caplog):
    data = points(law, I_POINTS, 0.05)
    data.sem["inertial_number"][5] = np.nan
    pt = fit_mu_I(data).points[0]
    assert not pt.used[5] and not pt.nonlocal_[5] and pt.used.sum() == 29
    assert "without an error" in caplog.text


def test_the_local_law_is_not_judged_without_errors():
    """Without replicates the fit has no chi^2 and its z are not in errors: both verdicts
    inconclusive. A band point without an error (z NaN) does not count: the band's
    verdict is that of the others."""
    creep = np.full(len(I_POINTS), np.nan)
    creep[:5] = TRUE["mu_s"] - 0.1
    data = points(law, I_POINTS, 0.01, extra=creep)
    band = np.arange(len(I_POINTS)) >= 5
    judged = local_law(fit_mu_I(bare(data)), band)
    assert judged["band"] == judged["tail"] == "inconclusive"
    data.sem["friction"][20] = np.nan
    fit = fit_mu_I(data)
    assert np.isnan(fit.points[0].z[20])
    judged = local_law(fit, band)
    assert judged["band"] == "reproduced" and judged["band_points"] == 24
    assert np.isfinite(judged["band_max_z"])


def test_an_unknown_species_is_refused_in_one_line():
    whole = shear(GRID, np.eye(2))
    mixture = Fields.of_species({n: fields_of(GRID, whole) for n in ("all", "small")}, {})
    got = rheology(mixture, diameter=D_P, density=RHO)
    for source, name in ((got, "large"), (points(law, I_POINTS, 0.05), "small")):
        with pytest.raises(ParameterError, match="not a species") as caught:
            fit_mu_I(source, species=name)
        assert "\n" not in str(caught.value)


# -- a real average, the command line --------------------------------------------------------

@pytest.fixture(scope="module")
def couette(tmp_path_factory):
    """The shipped Couette run averaged over 16 rings, in memory and written."""
    fields = granavg.average(granavg.examples.couette_2d.run, cells={"bins": 16}, t_min=1.0)
    path = tmp_path_factory.mktemp("couette") / "p16.csv"
    write_profiles(fields, path)
    return fields, path


def test_a_real_couette_run(couette):
    """Errors from the run's sector and block replicates; the rings beyond the band,
    where v_phi is within its noise, have no shear rate and are flagged, their I NaN,
    and so is the first ring, whose disks turn with the wall as one block; the band's
    next rings have their I; the sidecar says d_p and rho_p (the scene's) and the
    units."""
    fields, _ = couette
    got = granavg.rheology(fields)
    assert got.replicates.kind == "structure" and got.replicates.n == fields.replicates.n
    assert got.meta["rheology"]["diameter"] == pytest.approx(
        (250 * 0.00742 + 40 * 0.00899) / 290)
    assert got.meta["rheology"]["density"] == 1060.0
    flagged = np.array(["no_shear" in str(f) for f in got.flags])
    assert flagged[0] and not flagged[1:4].any() and flagged[-8:].all()
    assert np.all(np.isnan(got.values["inertial_number"][flagged]))
    assert np.all(got.values["pressure"] > 0) and np.all(np.isfinite(got.sem["pressure"]))
    assert got.units["pressure"] == "Pa" and got.units["fluidity_sem"] == "1/s"


def test_a_written_rheology_reads_back_with_its_units_and_values(couette, tmp_path):
    """A rheology written as a profile table (as ``granavg rheology`` writes it) and read
    back with ``granavg.read`` and ``read_profiles``: the units of every column from the
    sidecar's ``dimensions`` (``axes_angle`` and its error in ``deg``, not a unit
    system's), and the same values, errors, flags and replicates."""
    fields, _ = couette
    got = granavg.rheology(fields)
    assert {c: got.units[c] for c in got.values} == {
        c: SI.unit(COLUMNS[c].unit) for c in got.values}
    path = write_profiles(got, tmp_path / "rh.csv")
    side = json.loads((tmp_path / "rh.csv.json").read_text())
    assert side["dimensions"]["axes_angle"] == "deg"
    assert side["columns"]["axes_angle"] == side["columns"]["axes_angle_sem"] == "deg"
    for back in (granavg.read(path), read_profiles(path)):
        assert back.units == got.units
        assert back.units["axes_angle_sem"] == "deg" and back.units["shear_rate"] == "1/s"
        assert set(back.values) == set(got.values) == set(COLUMNS) - {"N2"}      # 2D
        for name, value in got.values.items():
            assert np.allclose(back.values[name], value, rtol=1e-9, equal_nan=True), name
            assert np.allclose(back.sem[name], got.sem[name], rtol=1e-9, equal_nan=True)
            assert np.allclose(back.replicates.values[name], got.replicates.values[name],
                               rtol=1e-9, equal_nan=True), name
        assert list(back.flags) == list(got.flags)


def test_the_help_lists_the_columns_with_their_units():
    """``granavg rheology --help`` names every column of the registry with its unit
    (SI) and help, from :data:`COLUMNS`."""
    proc = run_cli("rheology", "--help")
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.split())
    for c in COLUMNS.values():
        assert f"{c.name} [{SI.unit(c.unit)}] {' '.join(c.help.split())}" in text, c.name


@pytest.mark.slow
def test_the_command_line_gives_the_apis_numbers(couette, tmp_path):
    """``granavg rheology`` on the written table: its table holds the API's numbers on
    the same file to the table's precision (and on the fields in memory to the file's
    round-off); fits.json the API's fits of that file; the figure is written."""
    fields, path = couette
    out = tmp_path / "rh"
    proc = run_cli("rheology", path, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "mu(I)" in proc.stderr and "cells with inertial_number and friction" in proc.stderr
    table = read_profiles(out / "p16.csv")
    api = granavg.rheology(path)
    memory = granavg.rheology(fields)
    for name, value in api.values.items():
        assert np.allclose(table.values[name], value, rtol=1e-9, atol=0, equal_nan=True)
        assert np.allclose(table.sem[name], api.sem[name], rtol=1e-9, equal_nan=True)
        assert np.allclose(memory.values[name], value, rtol=1e-7, equal_nan=True), name
    assert list(table.flags) == list(api.flags)
    assert table.units["pressure"] == "Pa"
    fits = json.loads((out / "fits.json").read_text())
    assert fits["sources"][0]["table"] == "p16.csv"
    for key, made in fit_laws(api, labels=["p16.csv"]).items():
        if isinstance(made, str):                   # too few cells with I for mu(I)
            assert fits[key] == {"error": made}
            continue
        assert fits[key]["params"] == made.params and fits[key]["errors"] == made.errors
        assert fits[key]["points"]["p16.csv"]["cells"] == made.points[0].cells.tolist()
    assert "params" in fits["phi_I"]
    assert (out / "fits.png").exists() and (out / "fits.pdf").exists()


@pytest.mark.slow
@pytest.mark.parametrize("case", ["missing", "not a table", "diameter", "out exists"])
def test_bad_input_is_one_line_and_exit_2(couette, tmp_path, case):
    _, path = couette
    out = tmp_path / "rh"
    args = {"missing": [tmp_path / "nothing.csv"],
            "not a table": [tmp_path / "junk.csv"],
            "diameter": [path, "--diameter", "-0.1"],
            "out exists": [path]}[case]
    (tmp_path / "junk.csv").write_text("not,a\n1,table\n")
    (tmp_path / "junk.csv.json").write_text("{}")
    if case == "out exists":
        out.mkdir()
        (out / "kept").write_text("x")
    proc = run_cli("rheology", *args, "--out", out)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("granavg: error:"), proc.stderr
    assert "Traceback" not in proc.stderr
    assert (out / "kept").exists() if case == "out exists" else not out.exists()
