"""The scale study (granavg.analysis.scales, ``granavg scales``): its verdicts on
constructed profiles, where the answer is known, and on a real LAMMPS pile of our own
deck (tests/decks/pile_3d_si.lmp), where physics gives it: the smoothed weight a
uniform column carries is linear in depth, and a symmetric kernel leaves a linear field
unchanged - the stress must not depend on the width in the bulk - while a jump (the
density at the floor) smoothed over w must."""

import json

import numpy as np
import pytest

from granavg.analysis.scales import FLAT, interior, plateau, steps
from granavg.cells import Slabs3D
from granavg.engine.fields import Fields
from granavg.engine.uncertainty.blocking import Replicates
from granavg.io.profiles_io import read_profiles

from .helpers import MAP3, last_rows, run_cli

CELLS = Slabs3D(np.linspace(0.0, 1.0, 11), "z", 1.0)


def profile(values, sem, replicates=None):
    n = CELLS.n
    return Fields(CELLS, {"q": np.asarray(values, float)}, {"q": np.asarray(sem, float)},
                    np.array([""] * n), 10, {},
                    None if replicates is None else Replicates("jackknife", {"q": replicates}))


def test_a_plateau_is_the_longest_run_of_flat_steps():
    def row(w, z, nodes=5):
        return {"w_from": w, "w_to": 2 * w, "nodes": nodes, "max_sigmas": z}
    rows = [row(1, 5.0), row(2, 1.0), row(4, 2.0), row(8, 9.0), row(16, 0.5)]
    assert plateau(rows) == (2, 8)
    assert plateau([row(1, 5.0), row(2, FLAT + 0.1)]) is None
    assert plateau([row(1, 0.0, nodes=0)]) is None           # nothing judged, no plateau


def test_only_nodes_a_cutoff_from_the_ends_are_judged():
    inside = interior(CELLS, 0.2)
    assert list(np.flatnonzero(inside)) == [2, 3, 4, 5, 6, 7]


def test_paired_replicates_see_a_change_the_independent_errors_hide():
    """Two widths share the frames: their replicates' noise (common to both) cancels in
    the change. A change of 0.05 under a common noise of 1 is invisible to the two
    errors as if independent and many errors of the change when paired."""
    rng = np.random.default_rng(1)
    n, reps = CELLS.n, 10
    noise = rng.normal(0, 1.0, (reps, n))
    jitter = rng.normal(0, 1e-3, (reps, n))
    base = np.ones(n)
    a = profile(base, np.full(n, 1.0), base + noise)
    b = profile(base + 0.05, np.full(n, 1.0), base + 0.05 + noise + jitter)
    paired = steps([1.0, 2.0], [a, b], [0.0, 0.0], ["q"])["q"][0]
    assert paired["paired"] and paired["max_sigmas"] > 3 * FLAT
    a.replicates = None
    alone = steps([1.0, 2.0], [a, b], [0.0, 0.0], ["q"])["q"][0]
    assert not alone["paired"] and alone["max_sigmas"] < 0.1


@pytest.fixture(scope="module")
def pile3d(pile3d_soft):
    """tests/decks/pile_3d_si.lmp with k_n = 20 N/m (a session's run)."""
    return pile3d_soft


@pytest.mark.slow
def test_the_piles_stress_does_not_depend_on_the_width_its_floor_does(pile3d, tmp_path):
    out = tmp_path / "study" / "pile.csv"
    args = ("--atoms", pile3d / "atoms.dump", "--contacts", pile3d / "contacts.dump",
            "--contact-columns", MAP3, "--gravity", 0, 0, -9.81, "--slabs", "z",
            "--range", 0, 0.018, "--bins", 9, "--no-progress")
    proc = run_cli("scales", *args, "--widths", 0.25, 0.5, 1, 2, "--fields", "nu,sigma_zz",
                   "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert all(out.with_name(out.name + s).exists() for s in ("", ".json", ".png", ".pdf"))
    study = json.loads(out.with_name("pile.csv.json").read_text())
    rows, cols = last_rows(pile3d / "atoms.dump")
    d = float(np.mean(rows[:, cols.index("diameter")]))
    assert abs(study["diameter"] - d) < 1e-12 * d
    sig, nu = study["fields"]["sigma_zz"], study["fields"]["nu"]
    assert sig["plateau"] == pytest.approx([0.25 * d, 2 * d], rel=1e-12), sig["steps"]
    assert all(s["paired"] and s["nodes"] >= 1 for s in sig["steps"])
    # the floor inside the cells: the density's jump there, smoothed over w, depends on w
    floor = tmp_path / "floor.csv"
    below = proc.stderr
    proc = run_cli("scales", *args[:-6], "--range", -0.006, 0.018, "--bins", 12,
                   "--widths", 0.5, 1, 2, "--quantities", "nu", "--out", floor,
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    nu = json.loads(floor.with_name("floor.csv.json").read_text())["fields"]["nu"]
    assert nu["plateau"] is None and all(s["max_sigmas"] > FLAT for s in nu["steps"]), nu
    assert study["fields"]["nu"]["steps"][-1]["max_sigmas"] <= FLAT    # the bulk's is flat
    # below the mean radius the study says the fields are particle-resolved, once
    assert below.count("particle-resolved") == 1, below
    # the study's rows at one width are the average command's at that width
    one = tmp_path / "one.csv"
    proc = run_cli("average", *args, "--kernel", "lucy", "--width", repr(d), "--out", one)
    assert proc.returncode == 0 and "particle-resolved" not in proc.stderr, proc.stderr
    p = read_profiles(one)
    table = np.genfromtxt(out, delimiter=",", names=True)
    at = table[table["width_d"] == 1.0]
    for name in ("nu", "sigma_zz"):
        assert np.allclose(at[name], p.values[name], rtol=1e-9, atol=0), name


@pytest.mark.parametrize("extra, needle", [
    (("--kernel", "exact"), "--kernel exact has no width"),
    (("--widths", 1, 0.5), "--widths 1 0.5: give positive widths in increasing order"),
    (("--diameter", -1), "--diameter -1: must be a finite number > 0"),
    (("--widths", 0.1, 1), "--widths 0.1: 0.1 d = "),
    (("--kernel", "cubic"), "--kernel 'cubic': choose exact or gauss, heaviside or lucy"),
])
def test_scale_study_refusals_in_one_line(pile3d, tmp_path, extra, needle):
    proc = run_cli("scales", "--atoms", pile3d / "atoms.dump", "--slabs", "z",
                   "--quantities", "nu", "--out", tmp_path / "s.csv", *extra)
    errors = [ln for ln in proc.stderr.splitlines() if "error:" in ln]
    assert proc.returncode == 2 and len(errors) == 1 and needle in errors[0], proc.stderr
    assert not list(tmp_path.iterdir())


def test_3d_slabs_errors_count_a_static_piles_frozen_structure(pile3d, tmp_path):
    """A pile at rest changes little in time: errors from time alone are near zero, a
    lower bound that says nothing of the packing's structure. 3D slabs split into strips
    along x (as 2D slabs do along their length), and the strips' spread counts it; the
    stress components the balance fixes in a slab keep their time errors."""
    args = ("average", "--atoms", pile3d / "atoms.dump", "--contacts",
            pile3d / "contacts.dump", "--contact-columns", MAP3, "--slabs", "z",
            "--range", 0.002, 0.018, "--bins", 8, "--no-progress")
    for name, extra in (("strips", ()), ("time", ("--sectors", "off"))):
        proc = run_cli(*args, *extra, "--out", tmp_path / f"{name}.csv")
        assert proc.returncode == 0, proc.stderr
    strips, time = read_profiles(tmp_path / "strips.csv"), read_profiles(tmp_path / "time.csv")
    assert strips.meta["errors"]["kind"] == "time+structure"
    assert strips.meta["errors"]["sectors"]["axis"] == "x"
    assert time.meta["errors"]["kind"] == "time"
    for name in ("nu", "sigma_zz"):
        assert np.array_equal(strips.values[name], time.values[name])
    assert np.all(strips.sem["nu"] > 10 * time.sem["nu"]), (strips.sem["nu"], time.sem["nu"])
    assert np.array_equal(strips.sem["sigma_zz"], time.sem["sigma_zz"])


@pytest.mark.slow
def test_a_runs_scale_study_takes_the_scenes_diameter(small_run, tmp_path):
    """On a run directory the mean diameter is the scene's (its counts and diameters);
    the table holds the exact weights' rows (width 0) and each width's."""
    from granavg.io.run_directory import read_manifest
    out = tmp_path / "s.csv"
    proc = run_cli("scales", small_run, "--bins", 10, "--widths", 1, 2, "--quantities",
                   "nu,v", "--t-min", 1, "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    scene = read_manifest(small_run)["scene"]
    d = (scene["n_small"] * scene["d_s"] + scene["n_large"] * scene["d_l"]) / \
        (scene["n_small"] + scene["n_large"])
    study = json.loads(out.with_name("s.csv.json").read_text())
    assert abs(study["diameter"] - d) < 1e-12 * d
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert list(np.unique(table["width_d"])) == [0.0, 1.0, 2.0] and len(table) == 30
    assert set(study["fields"]) >= {"nu", "v_phi"}
