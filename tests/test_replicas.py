"""Spatial replicas (granavg.engine.replicas): exact sector shares, sector sums that add
up to the cells', and errors that count frozen structure, checked on synthetic fields
whose frozen, common and local parts are known."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from granavg.engine import average
from granavg.cells import Grid, Rings, Slabs
from granavg.engine.accumulate import CellAccumulator
from granavg.engine.cell_average import CellAverage
from granavg.engine.spec import Averaging

HALF = Averaging.of(t_min=0.0, block_time=0.5)
from granavg.engine.frame_sums import frame_sums
from granavg.engine.cells.base import layout_of
from granavg.engine.channels import BLOCKS, Layout
from granavg.engine.uncertainty import structure as replicas
from granavg.engine.uncertainty.blocking import combine_errors, interaction_variance

LAYOUT = Layout(("r", "phi"))
CHANNELS, INDEX = LAYOUT.names, LAYOUT.index


def monte_carlo_shares(x, y, a, geometry, k, n=400_000, seed=0):
    """Fractions of a disk's area in each sector, by sampling points in the disk."""
    rng = np.random.default_rng(seed)
    r, t = a * np.sqrt(rng.uniform(size=n)), rng.uniform(0, 2 * np.pi, n)
    px, py = x + r * np.cos(t), y + r * np.sin(t)
    if geometry.kind == "rings":
        phi = np.arctan2(py - geometry.center[1], px - geometry.center[0]) % (2 * np.pi)
        s = np.minimum((phi / (2 * np.pi / k)).astype(int), k - 1)
    else:
        lo, hi = geometry.span
        u = py if geometry.axis == "x" else px
        s = np.clip(np.floor((u - lo) / ((hi - lo) / k)).astype(int), 0, k - 1)
    return np.bincount(s, minlength=k) / n


@pytest.mark.parametrize("geometry, disk", [
    (Rings.count(4, 0.1, 0.25, 0.006, center=(0.01, -0.02)), (0.01 + 0.17, -0.02 + 0.003)),
    (Rings.count(4, 0.1, 0.25, 0.006), (0.17 * math.cos(2 * math.pi / 8 - 0.01),
                                        0.17 * math.sin(2 * math.pi / 8 - 0.01))),
    (Slabs(np.linspace(0, 1, 5), 0.006, "x", 0.8, (0.1, 0.9)), (0.5, 0.1 + 0.8 / 8 + 0.002)),
    (Slabs(np.linspace(0, 1, 5), 0.006, "y", 0.8, (0.1, 0.9)), (0.1 + 3 * 0.1 - 0.001, 0.5)),
])
def test_sector_shares_are_the_disk_areas_beyond_each_boundary(geometry, disk):
    k, a = 8, 0.004
    sector, share = geometry.sector_shares((np.array([disk[0]]),
                                           np.array([disk[1]])), np.array([a]), k)
    exact = np.zeros(k)
    np.add.at(exact, sector[0], share[0])
    assert exact.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.count_nonzero(exact) == 2                  # the disk straddles a boundary
    assert np.allclose(exact, monte_carlo_shares(*disk, a, geometry, k), atol=3e-3)


def test_a_disk_wider_than_a_sector_or_a_point_goes_whole_to_its_centre():
    rings = Rings.count(2, 0.0, 0.1, 0.006)
    sector, share = rings.sector_shares((np.array([0.001, 0.05]),
                                           np.array([0.0, 0.0])), np.array([0.004, 0.0]), 24)
    assert share[:, 0].tolist() == [1.0, 1.0]


def random_frame(n=600, seed=3):
    rng = np.random.default_rng(seed)
    r, t = np.sqrt(rng.uniform(0.105**2, 0.245**2, n)), rng.uniform(0, 2 * np.pi, n)
    atoms = {"x": r * np.cos(t), "y": r * np.sin(t), "radius": rng.uniform(3e-3, 4.5e-3, n),
             "vx": rng.normal(size=n), "vy": rng.normal(size=n), "omegaz": rng.normal(size=n),
             "id": np.arange(1, n + 1), "mass": np.ones(n)}
    i = rng.integers(0, n, 900)
    j = (i + 1 + rng.integers(0, n - 1, 900)) % n
    dx, dy = atoms["x"][j] - atoms["x"][i], atoms["y"][j] - atoms["y"][i]
    d = np.hypot(dx, dy)
    contacts = {"id1": i + 1, "id2": j + 1, "wall": np.zeros(900, bool),
                "fnx": rng.normal(size=900), "fny": rng.normal(size=900),
                "ftx": rng.normal(size=900), "fty": rng.normal(size=900),
                "nx": dx / d, "ny": dy / d, "overlap": rng.uniform(0, 1e-4, 900)}
    return SimpleNamespace(timestep=0, time=0.0, atoms=atoms, contacts=contacts)


@pytest.mark.parametrize("geometry", [
    Rings.count(7, 0.1, 0.25, 0.006),
    Slabs(np.linspace(-0.25, 0.25, 6), 0.006, "x", 0.5, (-0.25, 0.25)),
])
def test_sector_sums_add_up_to_the_cells_sums(geometry):
    frame = random_frame()
    blocks = [b for b in BLOCKS if b not in ("wall", "body", "bpow")]
    cells = frame_sums(frame, geometry, 1060.0, blocks)
    sectors = frame_sums(frame, geometry, 1060.0, blocks, n_sectors=24)
    assert sectors.shape == (geometry.n, 24, layout_of(geometry.axes, blocks).n)
    assert np.allclose(sectors.sum(axis=1), cells, rtol=1e-12, atol=1e-15)
    vol = sectors[:, :, INDEX["vol"]]                  # every sector holds disks
    assert np.all(vol.sum(axis=0) > 0)


def synthetic_average(rng, frozen, common, local, k=24, n_cells=3, frames=512, tau=4.0):
    """Fields of synthetic sector sums: nu of sector s at frame t is
    0.8 + F_s + T(t) + e_s(t), with F frozen (sd ``frozen``), T common to all sectors and
    e local to each (sds ``common``, ``local``), both AR(1) with correlation time tau.
    Returns the profiles with errors from time and structure, and from time alone."""
    rings = Rings.count(n_cells, 0.1, 0.25, 0.006)
    avg = CellAverage([], rings, ["nu"], 1060.0, Averaging.of(t_min=0.0, block_time=1.0))
    avg.prepare()
    slot = avg._slot(0)                          # the whole average's accumulators
    rho = math.exp(-1.0 / tau)
    F = rng.normal(0, frozen, (n_cells, k))
    T, e = 0.0, np.zeros((n_cells, k))
    vol = rings.volume[:, None] / k
    for t in range(frames):
        T = rho * T + math.sqrt(1 - rho**2) * rng.normal(0, common)
        e = rho * e + math.sqrt(1 - rho**2) * rng.normal(0, local, e.shape)
        sums = np.zeros((n_cells, k, avg.layout.n))       # the channels nu needs
        sums[:, :, avg.layout.index["vol"]] = (0.8 + F + T + e) * vol
        slot.replicas.add(t, float(t), sums)
        slot.acc.add(t, float(t), sums.sum(axis=1))
    structure = avg.conclude()
    slot.replicas = None
    return structure, avg.conclude()


def truth_and_errors(frozen, common, local, realisations=120, seed=11):
    """The spread of nu over realisations, the rms of each method's errors, the runs."""
    rng = np.random.default_rng(seed)
    runs = [synthetic_average(rng, frozen, common, local) for _ in range(realisations)]
    x = np.stack([p.values["nu"] for p, _ in runs])
    rms = [np.sqrt(np.mean(np.stack([r[m].sem["nu"] for r in runs]) ** 2, axis=0))
           for m in (0, 1)]
    return x.std(axis=0, ddof=1), rms, runs


@pytest.mark.parametrize("frozen, common, local", [
    (0.02, 0.0, 0.002),          # frozen structure dominates (the bulk of a jammed cell)
    (0.0, 0.02, 0.002),          # the whole packing fluctuates together
    (0.0, 0.0, 0.02),            # local, time-varying noise: both parts count it
    (0.01, 0.01, 0.01),
])
def test_structure_errors_match_the_spread_of_independent_realisations(frozen, common, local):
    truth, (reported, _), runs = truth_and_errors(frozen, common, local)
    # 120 realisations: the spread itself is known to ~7%
    assert np.allclose(reported / truth, 1.0, atol=0.2), reported / truth
    z = np.concatenate([(p.values["nu"] - 0.8) / p.sem["nu"] for p, _ in runs])
    # errors from ~10 blocks or sectors make z a Student t of ~10 degrees of freedom:
    # P(|z| < 2) = 0.93; with (at worst, common noise) 120 independent cases its 3-sigma
    # range is 0.85 - 0.99
    assert 0.85 <= np.mean(np.abs(z) < 2) <= 0.99
    assert runs[0][0].meta["errors"]["kind"] == "time+structure"
    assert runs[0][0].replicates.kind == "structure"
    assert runs[0][1].meta["errors"]["kind"] == "time"


def test_time_alone_misses_the_frozen_structure():
    truth, (structure, time_only), _ = truth_and_errors(0.02, 0.0, 0.002, realisations=40)
    assert np.all(time_only < 0.2 * truth)
    assert np.all(structure > 0.75 * truth)


def test_summing_the_two_parts_without_the_interaction_would_overcount_local_noise():
    """The verdict can fail: where local noise dominates, E_s + E_t counts it twice."""
    truth, (structure, time_only), runs = truth_and_errors(0.0, 0.0, 0.02)
    sector_part = []
    for p, _ in runs:
        sect = p.replicates.split(p.replicates.values["nu"])[0]
        sector_part.append((sect.shape[0] - 1) * np.var(sect, axis=0))
    naive = np.sqrt(np.mean(sector_part, axis=0) + time_only**2)
    # expected sqrt(2) = 1.41; the spread of 120 realisations is known to ~5% (3 cells)
    assert np.mean(naive / truth) > 1.2 and np.allclose(structure / truth, 1.0, atol=0.2)
    vs, vt, vi = 4.0, 3.0, 2.5
    assert combine_errors(vs, vt, vi) == pytest.approx(math.sqrt(4.5))
    assert combine_errors(vs, vt, 9.0) == pytest.approx(2.0)       # never below a part
    assert combine_errors(np.nan, vt, vi) == pytest.approx(math.sqrt(3.0))
    assert interaction_variance([1.0, 1.0], 2, 1) != interaction_variance([1.0, 1.0], 2, 1)


def halves_of(frozen, noise, rng):
    """Sector sums (n, K, channels) of two halves: the same frozen nu plus fresh noise."""
    out = []
    for _ in range(2):
        t = np.zeros(frozen.shape + (len(CHANNELS),))
        t[:, :, INDEX["vol"]] = (frozen + rng.normal(0, noise, frozen.shape)) / frozen.shape[1]
        out.append(t)
    return out


def test_the_frozen_structures_correlation_chooses_the_sectors():
    rng = np.random.default_rng(2)
    n, kf = 30, 24
    V = np.ones(n)
    independent = rng.normal(0.8, 0.02, (n, kf))
    per_q, common, unresolved, table = replicas.choose_sectors(
        *halves_of(independent, 0.01, rng), V, 1.0, ["nu"], LAYOUT)
    assert (per_q["nu"], common, unresolved) == (24, 24, [])
    assert table["frozen_share"]["nu"] == pytest.approx(0.8, abs=0.1)   # 0.02^2 / 0.0005
    smooth = np.repeat(rng.normal(0.8, 0.02, (n, kf // 3)), 3, axis=1)   # 3 sectors alike
    per_q, common, unresolved, table = replicas.choose_sectors(
        *halves_of(smooth, 0.01, rng), V, 1.0, ["nu"], LAYOUT)
    assert per_q["nu"] <= 6 and common == per_q["nu"] and not unresolved
    assert table["fine"]["nu"][0] == pytest.approx(2 / 3, abs=0.1)
    halves_alike = np.repeat(rng.normal(0.8, 0.04, (n, 2)), 12, axis=1)
    per_q, common, unresolved, _ = replicas.choose_sectors(
        *halves_of(halves_alike, 0.01, rng), V, 1.0, ["nu"], LAYOUT)
    assert (common, unresolved) == (replicas.MIN_REPLICAS, ["nu"])
    # noise alone, no frozen part: not detected, so it sets nothing
    per_q, common, unresolved, table = replicas.choose_sectors(
        *halves_of(np.full((n, kf), 0.8), 0.01, rng), V, 1.0, ["nu"], LAYOUT)
    assert (per_q["nu"], common, unresolved, table["fine"]) == (24, 24, [], {})
    # a quantity the balance fixes takes no part
    assert replicas.choose_sectors(*halves_of(halves_alike, 0.01, rng), V, 1.0, ["nu"],
                                   LAYOUT, exclude={"nu"})[:3] == ({}, 24, [])


def test_the_balance_fixes_the_stress_across_the_cells_and_the_walls():
    from granavg.engine.quantities import balanced_names
    rings = balanced_names(["nu", "sigma", "boundary", "eps"], ("r", "phi"), "r")
    assert rings == {"sigma_rr", "sigma_rphi", "sigma_phir", "boundary_r", "boundary_phi"}
    assert balanced_names(["sigma"], ("x", "y"), "y") == {"sigma_xy", "sigma_yx", "sigma_yy"}
    shells = balanced_names(["sigma"], ("r", "phi", "z"), "r")
    assert shells == {"sigma_rr", "sigma_rphi", "sigma_rz", "sigma_phir", "sigma_zr"}


def test_grids_and_slabs_without_a_span_keep_time_errors():
    fr = []
    for t in range(20):
        f = random_frame(seed=t)
        f.timestep, f.time = t, float(t)
        fr.append(f)
    g = average(fr, Grid(np.linspace(-0.25, 0.25, 3), np.linspace(-0.25, 0.25, 3), 0.006),
                density=1060.0)
    assert g.meta["errors"]["kind"] == "time" and g.replicates.kind == "jackknife"
    s = average(fr, Slabs(np.linspace(-0.25, 0.25, 3), 0.006, "x", 0.5), density=1060.0)
    assert s.meta["errors"]["kind"] == "time"
    s = average(fr, Slabs(np.linspace(-0.25, 0.25, 3), 0.006, "x", 0.5, (-0.25, 0.25)),
                density=1060.0)
    assert s.meta["errors"]["kind"] == "time+structure"
    assert s.meta["errors"]["sectors"]["axis"] == "y"
    r = average(fr, Rings.count(3, 0.1, 0.25, 0.006), density=1060.0, sectors=8)
    assert r.replicates.parts["sectors"] == 8 and r.meta["errors"]["sectors"]["chosen"] == "pinned"


@pytest.mark.parametrize("cuts", [(33,), (7, 33, 61), (1, 2, 40, 79)])
def test_replica_accumulators_merge_exactly_across_chunks(cuts):
    """Chunks of whole blocks merged, the sectors' blocks coarsened (80 frames, at most
    32 blocks): the one-pass fields and errors bit for bit."""
    rings = Rings.count(3, 0.1, 0.25, 0.006)
    frames = []
    for t in range(80):
        f = random_frame(seed=100 + t)
        f.timestep, f.time = t, 0.5 * t
        frames.append(f)
    whole = CellAverage(frames, rings, ["nu", "v", "sigma"], 1060.0, HALF)
    one = whole.run(False)
    bounds = (0, *cuts, 80)
    parts = [CellAverage(frames[a:b], rings, ["nu", "v", "sigma"], 1060.0, HALF)
             for a, b in zip(bounds[:-1], bounds[1:])]
    for p in parts:
        p.run(False)
    for p in parts[1:]:
        parts[0].merge(p.state())
    merged = parts[0].conclude()
    assert whole.slots[0].replicas.level == parts[0].slots[0].replicas.level == 2   # 160
    # blocks -> 32 at most
    for q in one.values:
        assert np.array_equal(merged.values[q], one.values[q], equal_nan=True), q
        assert np.array_equal(merged.sem[q], one.sem[q], equal_nan=True), q


def test_ensembles_keep_their_between_run_errors():
    from granavg.engine.combine import combine_runs
    rng = np.random.default_rng(8)
    runs = [synthetic_average(rng, 0.02, 0.0, 0.002)[0] for _ in range(4)]
    ens = combine_runs(runs, ["a", "b", "c", "d"])
    x = np.stack([p.values["nu"] for p in runs])
    assert ens.replicates.kind == "runs" and ens.replicates.parts is None
    between = x.std(axis=0, ddof=1) / 2
    within = np.sqrt(np.sum(np.stack([p.sem["nu"] for p in runs]) ** 2, axis=0)) / 4
    assert np.allclose(ens.sem["nu"], np.fmax(between, within))
    assert "between-run" in ens.meta["errors"]["method"]


def test_frames_that_start_late_still_fill_the_sectors_blocks():
    """Replica blocks count from the first frame, not from t_min = 0."""
    for start in (0.0, 1000.0):
        acc = CellAccumulator((1, 2, 1), 0.0, 0.1, replicas.REPLICA_BLOCKS)
        for k in range(100):
            acc.add(k, start + 0.1 * k, np.ones((1, 2, 1)))
        assert 16 <= acc.n_blocks <= 32, start
    a = CellAccumulator((1, 2, 1), 0.0, 0.1, replicas.REPLICA_BLOCKS)
    b = CellAccumulator((1, 2, 1), 0.0, 0.1, replicas.REPLICA_BLOCKS)
    for k in range(100):
        (a if k < 40 else b).add(k, 1000.0 + 0.1 * k, np.full((1, 2, 1), float(k)))
    merged = a.merge(b)
    assert merged.n_blocks <= 32 and merged.n_frames == 100
    assert np.sum(merged.block_sums()[1]) == pytest.approx(2 * sum(range(100)))


@pytest.mark.parametrize("sectors, ok", [("off", True), (np.int64(8), True), (3, False),
                                         (49, False), ("many", False)])
def test_the_sectors_option_is_checked(sectors, ok):
    from granavg.errors import ParameterError
    rings = Rings.count(3, 0.1, 0.25, 0.006)
    if ok:
        avg = CellAverage([], rings, ["nu"], 1060.0,
                          Averaging.of(t_min=0.0, block_time=1.0, sectors=sectors))
        assert avg.k_fine == (0 if sectors == "off" else 8)
    else:
        with pytest.raises(ParameterError, match="sectors"):
            CellAverage([], rings, ["nu"], 1060.0,
                        Averaging.of(t_min=0.0, block_time=1.0, sectors=sectors))


@pytest.mark.slow
def test_a_report_of_tables_with_different_sectors_falls_back_to_time(small_run, tmp_path):
    """The real CLI: a run averaged twice with different --sectors; the report says its
    derived numbers carry time errors, with a warning, instead of failing or mixing."""
    import json

    from .conftest import run_cli
    for n, k in ((8, 4), (16, 6)):
        proc = run_cli("average", small_run, "--bins", n, "--t-min", 1.5, "--sectors", k,
                       "--out", tmp_path / f"p{n}.csv", "--no-progress")
        assert proc.returncode == 0, proc.stderr
    proc = run_cli("analyze", tmp_path / "p8.csv", tmp_path / "p16.csv", "--out",
                   tmp_path / "r", "--no-figures")
    assert proc.returncode == 0, proc.stderr
    assert "do not split their rings into the same sectors" in proc.stderr
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["errors"]["kind"] == "jackknife"
    assert np.isfinite(summary["numbers"]["density"]["nu_bulk_err"])
    for n in (8, 16):
        proc = run_cli("average", small_run, "--bins", n, "--t-min", 1.5, "--sectors", 4,
                       "--out", tmp_path / f"s{n}.csv", "--no-progress")
        assert proc.returncode == 0, proc.stderr
    proc = run_cli("analyze", tmp_path / "s8.csv", tmp_path / "s16.csv", "--out",
                   tmp_path / "s", "--no-figures")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["errors"]["kind"] == "structure"
    assert summary["errors"]["parts"]["sectors"] == 4
