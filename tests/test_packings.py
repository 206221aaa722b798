"""Shipped sheared packings and the discarded transient: the presets' start and window.

Real parts: the shipped data files, a real (short) LAMMPS run from one of them, the CLI.
"""

import json
import math

import numpy as np
import pytest

from granavg.errors import UserError
from granavg.io.dumpfile import open_text
from granavg.io.lammps_data import read_data
from granavg.pipeline.description import RunAverage
from granavg.sim import packings
from granavg.sim.scene import PRESETS, preset
from tests.conftest import run_cli

SET = "rolling-sheared"
PRESET = "paper-rolling"


def test_every_preset_with_a_packing_has_one_for_its_seed_and_the_paper_cell():
    for name, scene in PRESETS.items():
        if not scene.packing:
            continue
        data = read_data(packings.check(scene.packing, scene.seed))
        assert int(np.sum(data["type"] <= 2)) == scene.n_small + scene.n_large, name


@pytest.mark.parametrize("name, preset_name", [(SET, PRESET),
                                               ("rolling-base-sheared", "paper-strong-plate"),
                                               ("rolling-coulomb-sheared", "paper")])
def test_the_shipped_packings_are_the_paper_cell_jammed(name, preset_name):
    """Each shipped packing holds the paper's disks (sizes and counts) inside the annulus,
    and its recorded end state is jammed: bulk C >= 3, rattlers < 15%."""
    scene = preset(preset_name)
    assert scene.packing == name
    record = packings.provenance(name)
    assert packings.seeds(name), "no packing shipped"
    for seed in packings.seeds(name):
        data = read_data(packings.check(name, seed))
        mob = data["type"] <= 2
        d = np.round(2 * data["radius"][mob], 6)
        assert np.sum(d == round(scene.d_s, 6)) == scene.n_small
        assert np.sum(d == round(scene.d_l, 6)) == scene.n_large
        r = np.hypot(data["x"][mob, 0], data["x"][mob, 1])
        assert r.min() > scene.R_i and r.max() < scene.R_o
        state = record["end_state_last_100_s"][f"seed{seed}"]
        assert state["C_bulk"] >= 3.0 and state["rattler_fraction"] < 0.15, (seed, state)


def test_unknown_set_and_missing_seed_are_refused_in_one_line(tmp_path):
    with pytest.raises(UserError, match="no such shipped packing set"):
        packings.check("no-such-set", 1)
    with pytest.raises(UserError, match="shipped seeds: "):
        packings.check(SET, 1)
    proc = run_cli("simulate", "--preset", PRESET, "--set", "seed=1", "--out", tmp_path / "x")
    assert proc.returncode == 2 and "no packing grown from seed 1" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "x").exists()


def test_an_ensemble_larger_than_the_shipped_set_is_refused_before_any_work(tmp_path):
    k = len(packings.seeds(SET)) + 1
    proc = run_cli("simulate", "--preset", PRESET, "--seeds", k, "--out", tmp_path / "e")
    assert proc.returncode == 2 and "needs K of them" in proc.stderr
    assert not (tmp_path / "e").exists()


def test_a_run_from_a_shipped_packing_starts_exactly_there(tmp_path):
    """LAMMPS shears the shipped file: the first dumped frame (t = 0) holds its positions
    (to the dump's 12 digits), and the end of shear is written as sheared.data."""
    out = tmp_path / "run"
    proc = run_cli("simulate", "--preset", PRESET, "--out", out, "--no-progress",
                   "--set", "t_end=0.1", "--set", "dump_dt=0.05", "--set", "restart_dt=0.1")
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["preparation"].startswith(f"shipped sheared packing {SET}/seed20011")
    # the forecast from the first speed/accuracy study, before LAMMPS starts
    # (docs/sweep/paper-rolling/)
    assert "expected wall time" in proc.stderr
    assert manifest["forecast"]["accuracy_class"] == "5%"     # the first study's base setting
    start = read_data(packings.check(SET, 20011))
    with open_text(out / "atoms.dump.gz") as fh:
        lines = fh.readlines()
    n = int(lines[3])
    cols = lines[8].split()[2:]
    rows = np.array([ln.split() for ln in lines[9:9 + n]], float)
    ids = rows[:, cols.index("id")].astype(int)
    where = {i: k for k, i in enumerate(start["id"])}
    k = np.array([where[i] for i in ids])
    xy = rows[:, [cols.index("x"), cols.index("y")]]
    assert np.max(np.abs(xy - start["x"][k])) < 1e-12
    end = read_data(out / "sheared.data")
    assert len(end["id"]) == len(start["id"])
    mobile = start["type"] <= 2
    moved = np.hypot(*(end["x"][mobile] - start["x"][mobile]).T)
    # the packing shears on (springs reload: a few mm at most), no disk jumps a diameter
    assert 0 < moved.max() < preset(PRESET).d_s


def test_the_window_starts_after_the_scenes_discarded_rotations():
    """average's default t_min is the transient the run recorded (derived.t_discard_s,
    discard_rotations x 2 pi / Omega of its scene); manifests without it fall back to
    their scene's discard_rotations, and from before the setting to two rotations."""
    derived = {"t_end_s": 250.0, "dump_interval_s": 2.0}
    for rotations in (0.25, 2.0, 3.5):
        scene = preset(PRESET).with_overrides([f"discard_rotations={rotations}"])
        t = scene.derive().t_discard
        assert t == pytest.approx(rotations * 2 * math.pi / 0.1)
        recorded = RunAverage.of({"scene": scene.to_dict(),
                                  "derived": {**derived, "t_discard_s": t}}, ["nu"])
        older = RunAverage.of({"scene": scene.to_dict(), "derived": derived}, ["nu"])
        assert recorded.t_min == older.t_min == pytest.approx(t)
        assert recorded.averager().meta["frames"]["t_min_s"] == pytest.approx(t)
    old = preset(PRESET).to_dict()
    del old["discard_rotations"]
    assert RunAverage.of({"scene": old, "derived": derived}, ["nu"]).t_min == \
        pytest.approx(4 * math.pi / 0.1)
