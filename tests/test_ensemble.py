"""Ensembles: independent realisations on dask (real LAMMPS runs of the small cell) and
their combination into profiles with between-run errors, through the real CLI."""

import html
import json

import numpy as np
import pytest

from granavg.paper.claims import analyze
from granavg.paper.report import stationarity_table
from granavg.pipeline.runs import average_run
from granavg.engine.combine import combine_runs
from granavg.engine.stationarity import ensemble_stationarity
from granavg.errors import UserError
from granavg.io.profiles_io import read_profiles
from tests.conftest import SMALL_CELL, SMALL_PRESET, run_cli

#: Every test here reads an ensemble simulated on a dask cluster.
pytestmark = pytest.mark.slow

SHORT = [s if not s.startswith("t_end") else "t_end=3" for s in SMALL_CELL]


@pytest.fixture(scope="module")
def ensemble(tmp_path_factory):
    out = tmp_path_factory.mktemp("ens") / "e"
    sets = [a for s in SHORT for a in ("--set", s)]
    proc = run_cli("simulate", "--preset", SMALL_PRESET, "--out", out, "--seeds", 3, "--workers", 2,
                   *sets)
    assert proc.returncode == 0, proc.stderr
    # dask's scheduler and workers keep their INFO chatter (and shutdown tracebacks) to
    # themselves: the user sees granavg's lines
    assert "Traceback" not in proc.stderr and "Nanny" not in proc.stderr, proc.stderr
    return out


def test_each_seed_is_its_own_complete_run(ensemble):
    record = json.loads((ensemble / "ensemble.json").read_text())
    assert len(set(record["seeds"])) == 3 and set(record["runs"].values()) == {"complete"}
    packings = []
    for name in record["runs"]:
        manifest = json.loads((ensemble / name / "manifest.json").read_text())
        assert manifest["status"] == "complete"
        packings.append((ensemble / name / "prepared.data").read_text())
    assert len(set(packings)) == 3                      # different random packings


def test_average_of_runs_is_their_mean_with_the_between_run_error(ensemble, tmp_path):
    runs = sorted(p for p in ensemble.iterdir() if p.is_dir())
    opts = dict(bins=8, t_min=1.5)
    proc = run_cli("average", *runs, "--bins", 8, "--t-min", 1.5, "--out", tmp_path / "e.csv",
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    ens = read_profiles(tmp_path / "e.csv")
    single = [average_run(r, progress=False, **opts) for r in runs]
    for name in ("nu", "v_phi", "sigma_rr", "eps_rphi"):
        x = np.stack([p.values[name] for p in single])
        assert np.allclose(ens.values[name], x.mean(axis=0), rtol=1e-9, atol=0)
        within = np.sqrt(np.sum([p.sem[name] ** 2 for p in single], axis=0)) / 3
        assert np.allclose(ens.sem[name], np.fmax(x.std(axis=0, ddof=1) / np.sqrt(3), within),
                           rtol=1e-9)
    assert np.all(ens.n_runs == 3)
    assert [r["run"] for r in ens.meta["runs"]] == [str(r) for r in runs]
    assert ens.replicates.kind == "runs" and ens.replicates.n == 3
    assert "between-run" in ens.meta["errors"]["method"]


def test_an_ensemble_in_time_has_between_run_errors_at_each_time(ensemble):
    """Three runs of one scene averaged in windows: at each window, the mean of the
    runs' fields and the between-run error, as for one average (docs/time.md)."""
    import granavg

    runs = sorted(p for p in ensemble.iterdir() if p.is_dir())
    opts = dict(cells={"bins": 8}, t_min=1.0, windows=1.0)
    ens = granavg.average(runs, **opts)
    single = [granavg.average(r, **opts) for r in runs]
    assert ens.in_time and len(ens.times) >= 2 and np.allclose(ens.times, single[0].times)
    for name in ("nu", "v_phi", "sigma_rr"):
        x = np.stack([np.asarray(p.values[name]) for p in single])      # (run, time, ring)
        assert np.allclose(ens.values[name], x.mean(axis=0), rtol=1e-9, atol=0)
        within = np.sqrt(np.sum([np.asarray(p.sem[name]) ** 2 for p in single], axis=0)) / 3
        assert np.allclose(ens.sem[name], np.fmax(x.std(axis=0, ddof=1) / np.sqrt(3), within),
                           rtol=1e-9)


def test_an_ensemble_of_a_mixture_has_between_run_errors_per_species(ensemble):
    """Three runs split by type: each species' fields, concentration included, are the
    mean of the runs' with the between-run error (at least the mean's error from the
    runs' own, as for every field)."""
    import granavg

    runs = sorted(p for p in ensemble.iterdir() if p.is_dir())
    opts = dict(cells={"bins": 8}, t_min=1.5, species="type")
    ens = granavg.average(runs, **opts)
    single = [granavg.average(r, **opts) for r in runs]
    assert ens.species == single[0].species == ("all", "type1", "type2")
    for s in ens.species[1:]:
        for name in ("nu", "v_phi", "c"):
            x = np.stack([np.asarray(p.of(s).values[name]) for p in single])
            assert np.allclose(ens.of(s).values[name], x.mean(axis=0), rtol=1e-9, atol=0)
        x = np.stack([np.asarray(p.of(s).values["c"]) for p in single])
        own = np.stack([np.asarray(p.of(s).sem["c"]) for p in single])
        assert np.all(np.isfinite(own[:, x[0] > 0]))        # one run's: its replicates'
        within = np.sqrt(np.sum(own ** 2, axis=0)) / 3
        assert np.allclose(ens.of(s).sem["c"], np.fmax(x.std(axis=0, ddof=1) / np.sqrt(3),
                                                       within), rtol=1e-9)


def test_runs_that_agree_by_chance_keep_their_own_errors(ensemble):
    """Two runs equal in every ring have between-run error 0; the ensemble error is then
    the mean's error from the runs' own errors, sem / sqrt(2), never 0 (a 0 would let
    such rings dominate every weighted fit: with two paper runs it moved s by 50%)."""
    run = sorted(p for p in ensemble.iterdir() if p.is_dir())[0]
    p = average_run(run, bins=8, t_min=1.5, progress=False)
    twin = combine_runs([p, p], ["a", "b"])
    for name in ("nu", "v_phi", "sigma_rr"):
        ok = np.isfinite(p.sem[name])
        assert np.allclose(twin.sem[name][ok], p.sem[name][ok] / np.sqrt(2), rtol=1e-12)
        assert np.all(twin.sem[name][ok & (p.sem[name] > 0)] > 0)


def test_the_analysis_of_an_ensemble_uses_between_run_errors(ensemble, tmp_path):
    runs = sorted(p for p in ensemble.iterdir() if p.is_dir())
    p8, p16 = (read_profiles(_avg(runs, n, tmp_path)) for n in (8, 16))
    summary = analyze(p8, p16, p8.meta["run_manifest"])
    assert summary["errors"] == {**summary["errors"], "kind": "runs", "replicates": 3}
    assert np.isfinite(summary["numbers"]["shear_band"]["decades_err"])
    assert np.isfinite(summary["numbers"]["stress_exponents"]["sigma_rr_err"])
    assert len(summary["runs"]) == 3
    # named as the directory that holds them names them, not by this machine's paths
    assert sorted(r["run"] for r in summary["runs"]) == [r.name for r in runs]
    assert {r.name for r in runs} < set(summary["stationarity"])
    # the window judged from the spread between the realisations, beside each run's verdict
    per_run = [r["stationarity"] for r in summary["runs"]]
    assert all(per_run) and summary["stationarity"]["ensemble (3 runs)"] == \
        ensemble_stationarity(per_run)
    assert {r["n_runs"] for r in summary["stationarity"]["ensemble (3 runs)"].values()} == {3}
    table = "".join(stationarity_table(summary, html.escape))
    assert "<td>ensemble (3 runs)</td>" in table and "2 degrees of freedom" in table


def test_runs_with_different_rings_or_quantities_are_refused(ensemble, tmp_path):
    runs = sorted(p for p in ensemble.iterdir() if p.is_dir())
    proc = run_cli("average", runs[0], runs[1], "--atoms", runs[0] / "atoms.dump.gz",
                   "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "one run directory" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "x.csv").exists()
    a, b = (average_run(r, bins=n, t_min=1.5, progress=False) for r, n in zip(runs, (8, 9)))
    with pytest.raises(UserError, match="rings differ"):
        combine_runs([a, b], ["a", "b"])
    b = average_run(runs[1], bins=8, t_min=1.5, quantities=["nu", "v"], progress=False)
    with pytest.raises(UserError, match="quantities differ"):
        combine_runs([a, b], ["a", "b"])


def _avg(runs, n, tmp_path):
    out = tmp_path / f"e{n}.csv"
    proc = run_cli("average", *runs, "--bins", n, "--t-min", 1.0, "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    return out
