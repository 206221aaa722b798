"""Input formats are adapters behind one frame-source protocol, found by the registry
(:mod:`granavg.io.formats`): a new format is one new file in granavg/io. The CSV adapter
is such a file; the same frames averaged from CSV tables and from the run directory's
dumps give the same profiles, through the public API and through the CLI."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from granavg.engine import average
from granavg.cells import Rings
from granavg.io import formats
from granavg.io.csv_frames import CsvFrames
from granavg.io.profiles_io import read_profiles
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.io.run_dumps import RunDumps

from .conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent / "granavg"


def test_a_format_is_one_file_the_registry_finds():
    found = formats.available()
    assert {"lammps", "csv"} <= set(found)
    named = [p for p in ROOT.rglob("*.py")
             if "csv_frames" in p.read_text() and p.name != "csv_frames.py"]
    assert not named, named                       # nothing else lists the CSV format


@pytest.fixture(scope="module")
def tables(small_run, tmp_path_factory):
    """The small run's frames as CSV tables (atoms; contacts in granavg's columns)."""
    out = tmp_path_factory.mktemp("csv")
    frames = RunDumps(DumpReader(small_run / "atoms.dump.gz"),
                      DumpReader(small_run / "contacts.dump.gz"),
                      dt=read_manifest(small_run)["derived"]["dt_s"])
    atoms, contacts = [], []
    for f in frames:
        a = pd.DataFrame({k: f.atoms[k] for k in ("id", "x", "y", "radius", "vx", "vy",
                                                  "omegaz")})
        a.insert(0, "time", f.time)
        a.insert(0, "step", f.timestep)
        atoms.append(a)
        c = pd.DataFrame(f.contacts)
        c.insert(0, "step", f.timestep)
        contacts.append(c)
    pd.concat(atoms).to_csv(out / "atoms.csv", index=False, float_format="%.17g")
    pd.concat(contacts).to_csv(out / "contacts.csv", index=False, float_format="%.17g")
    return out


def test_csv_frames_average_like_the_run_dumps(small_run, tables, tmp_path):
    m = read_manifest(small_run)
    scene = m["scene"]
    edges = np.linspace(scene["R_i"], scene["R_o"], 6)
    t_min, block = 1.5, 0.5
    proc = run_cli("average", small_run, "--edges", *edges, "--t-min", t_min, "--block-time",
                   block, "--out", tmp_path / "run.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    ref = read_profiles(tmp_path / "run.csv")
    # the public API on the CSV frame source
    api = average(CsvFrames(tables / "atoms.csv", tables / "contacts.csv"),
                  Rings(edges, scene["h"]), density=scene["rho_p"], t_min=t_min,
                  block_time=block)
    # the CLI, the format found from the file name
    proc = run_cli("average", "--atoms", tables / "atoms.csv", "--contacts",
                   tables / "contacts.csv", "--thickness", scene["h"], "--density",
                   scene["rho_p"], "--edges", *edges, "--t-min", t_min, "--block-time", block,
                   "--units", "si", "--out", tmp_path / "cli.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    cli = read_profiles(tmp_path / "cli.csv")
    assert json.loads((tmp_path / "cli.csv.json").read_text())["inputs"]["format"] == "csv"
    assert ref.n_frames == api.n_frames == cli.n_frames > 5
    # the table holds 10 significant digits (%.10g): files agree to the digit, the
    # in-memory profiles to that rounding
    for name in ("nu", "rho", "v_phi", "omega", "coordination", "F_rr", "sigma_rphi",
                 "dsigma_rr", "eps_phiphi"):
        np.testing.assert_array_equal(cli.values[name], ref.values[name], err_msg=name)
        np.testing.assert_array_equal(cli.sem[name], ref.sem[name], err_msg=name)
        assert np.allclose(api.values[name], ref.values[name], rtol=1e-9, atol=0,
                           equal_nan=True), name
        assert np.allclose(api.sem[name], ref.sem[name], rtol=1e-9, equal_nan=True), name


def test_csv_options_and_damage_are_refused_with_one_line(tables, tmp_path):
    proc = run_cli("average", "--atoms", tables / "atoms.csv", "--thickness", 0.006,
                   "--edges", 0.04, 0.08, "--wall-types", 3, "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "csv format takes no --wall-types option" in proc.stderr
    proc = run_cli("average", "--atoms", tables / "atoms.csv", "--thickness", 0.006,
                   "--edges", 0.04, 0.08, "--workers", 2, "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "--workers averages LAMMPS dumps" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    bad = tmp_path / "bad.csv"
    rows = pd.read_csv(tables / "atoms.csv")
    rows.iloc[[0, -1]] = rows.iloc[[-1, 0]].to_numpy()          # a later step first
    rows.to_csv(bad, index=False)
    proc = run_cli("average", "--atoms", bad, "--thickness", 0.006, "--edges", 0.04, 0.08,
                   "--out", tmp_path / "y.csv")
    assert proc.returncode == 2 and f"{bad}:" in proc.stderr and "increasing step" in proc.stderr
    assert "Traceback" not in proc.stderr and not list(tmp_path.glob("[xy].csv*"))


@pytest.mark.slow
def test_csv_tables_that_do_not_fit_together_are_refused(tables, tmp_path):
    atoms = pd.read_csv(tables / "atoms.csv")
    contacts = pd.read_csv(tables / "contacts.csv")
    cases = {}
    no_id = tmp_path / "no_id.csv"
    atoms.drop(columns="id").to_csv(no_id, index=False)
    cases["no id"] = (no_id, tables / "contacts.csv", "contacts need the atoms' id")
    shifted = tmp_path / "shifted.csv"
    contacts.assign(step=contacts.step + 7).to_csv(shifted, index=False)
    cases["steps"] = (tables / "atoms.csv", shifted, "is not a step of")
    holed = tmp_path / "holed.csv"
    atoms.assign(vx=atoms.vx.where(atoms.index != 5)).to_csv(holed, index=False)
    cases["nan"] = (holed, None, f"{holed}:7: no finite value in column 'vx'")
    for name, (a, c, needle) in cases.items():
        args = ["average", "--atoms", a, "--thickness", 0.006, "--edges", 0.04, 0.08,
                "--out", tmp_path / f"{name}.out.csv"]
        if c is not None:
            args[3:3] = ["--contacts", c]
        proc = run_cli(*args)
        assert proc.returncode == 2 and needle in proc.stderr, (name, proc.stderr)
        assert "Traceback" not in proc.stderr
