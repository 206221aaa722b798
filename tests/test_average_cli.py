"""`granavg average` through the real CLI: output files, and every bad input."""

import gzip
import json

import numpy as np
import pandas as pd
import pytest

from .conftest import run_cli


@pytest.fixture(scope="module")
def plain_dumps(small_run, tmp_path_factory):
    """Plain-text copies of the small run's dumps, to damage."""
    d = tmp_path_factory.mktemp("plain")
    for name in ("atoms", "contacts"):
        (d / f"{name}.dump").write_bytes(gzip.decompress((small_run / f"{name}.dump.gz").read_bytes()))
    return d


def average(run, out, *args):
    return run_cli("average", run, "--bins", 6, "--t-min", 1, "--out", out, "--no-progress", *args)


def test_average_writes_the_table_and_sidecar(small_run, tmp_path):
    out = tmp_path / "p.csv"
    proc = average(small_run, out)
    assert proc.returncode == 0, proc.stderr
    table = pd.read_csv(out)
    assert len(table) == 6 and (table["n_frames"] == 12).all()
    for name in ("nu", "v_phi", "omega", "coordination", "F_rr", "sigma_rphi", "dsigma_phiphi",
                 "dsigma_fluct_rr", "eps_phiphi"):
        assert name in table and f"{name}_sem" in table
    meta = json.loads((tmp_path / "p.csv.json").read_text())
    assert meta["frames"]["n"] == 12 and meta["run_manifest"]["status"] == "complete"
    assert meta["units"].startswith("SI")
    # an existing output is never overwritten
    again = average(small_run, out)
    assert again.returncode == 2 and "exists" in again.stderr


def test_parquet_output_holds_the_same_table(small_run, tmp_path):
    assert average(small_run, tmp_path / "p.csv").returncode == 0
    proc = average(small_run, tmp_path / "p.parquet", "--parquet")
    assert proc.returncode == 0, proc.stderr
    csv, parquet = pd.read_csv(tmp_path / "p.csv"), pd.read_parquet(tmp_path / "p.parquet")
    assert list(parquet.columns) == list(csv.columns)
    assert np.allclose(parquet["sigma_rr"], csv["sigma_rr"], rtol=1e-9)


def test_density_alone_reads_no_contacts(small_run, plain_dumps, tmp_path):
    missing = tmp_path / "nowhere.dump"
    proc = average(small_run, tmp_path / "p.csv", "--quantities", "nu,v", "--contacts", missing,
                   "--atoms", plain_dumps / "atoms.dump")
    assert proc.returncode == 0, proc.stderr


def damage(src, dst, edit):
    lines = src.read_text().splitlines(keepends=True)
    dst.write_text("".join(edit(lines)))
    return dst


def nth_row(lines, frame, row):
    """Index of row ``row`` of frame ``frame`` (0-based) in a dump's lines."""
    starts = [k for k, ln in enumerate(lines) if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES"))]
    return starts[frame] + 1 + row


@pytest.mark.parametrize("which, edit, message", [
    ("atoms", lambda L: L[:-3], "truncated"),
    ("atoms", lambda L: L[:nth_row(L, 3, 5)] + ["12 1 0.05 1.2.3 0 0 0 0.003 0.0002\n"]
     + L[nth_row(L, 3, 6):], "malformed row"),
    ("atoms", lambda L: L[:nth_row(L, 4, 2)] + [" ".join(L[nth_row(L, 4, 2)].split()[:5] + ["nan"]
     + L[nth_row(L, 4, 2)].split()[6:]) + "\n"] + L[nth_row(L, 4, 2) + 1:], "NaN or inf"),
    ("contacts", lambda L: [ln.replace("ITEM: ENTRIES id1 id2 wall fnx fny ftx fty nx ny overlap",
                                       "ITEM: ENTRIES id1 id2 wall fnx fny ftx fty nx ny depth")
                            for ln in L], "column 'overlap' is missing"),
])
def test_bad_input_is_named(small_run, plain_dumps, tmp_path, which, edit, message):
    bad = damage(plain_dumps / f"{which}.dump", tmp_path / f"{which}.dump", edit)
    files = {"atoms": plain_dumps / "atoms.dump", "contacts": plain_dumps / "contacts.dump",
             which: bad}
    proc = average(small_run, tmp_path / "p.csv", "--atoms", files["atoms"],
                   "--contacts", files["contacts"])
    if message == "truncated":       # skipped with a warning; the rest is averaged
        assert proc.returncode == 0 and "truncated" in proc.stderr and str(bad) in proc.stderr
        return
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr and str(bad) in proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "p.csv").exists()


def test_missing_column_names_what_needs_it(small_run, plain_dumps, tmp_path):
    bad = damage(plain_dumps / "atoms.dump", tmp_path / "atoms.dump",
                 lambda L: [ln.replace(" omegaz ", " spin ") for ln in L])
    proc = average(small_run, tmp_path / "p.csv", "--atoms", bad, "--quantities", "nu,omega")
    assert proc.returncode == 2
    assert "column 'omegaz' is missing" in proc.stderr and "omega needs it" in proc.stderr


def test_line_number_of_a_malformed_row(small_run, plain_dumps, tmp_path):
    lines = (plain_dumps / "atoms.dump").read_text().splitlines(keepends=True)
    k = nth_row(lines, 2, 10)
    lines[k] = "1 2 3\n"
    bad = tmp_path / "atoms.dump"
    bad.write_text("".join(lines))
    proc = average(small_run, tmp_path / "p.csv", "--atoms", bad, "--quantities", "nu")
    assert f"{bad}:{k + 1}:" in proc.stderr


def test_mismatched_time_steps_are_listed(small_run, plain_dumps, tmp_path):
    lines = (plain_dumps / "contacts.dump").read_text().splitlines(keepends=True)
    ts = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: TIMESTEP")]
    lines[ts[2] + 1] = "999999\n"
    bad = tmp_path / "contacts.dump"
    bad.write_text("".join(lines))
    proc = average(small_run, tmp_path / "p.csv", "--atoms", plain_dumps / "atoms.dump",
                   "--contacts", bad)
    assert proc.returncode == 2 and "time steps do not match" in proc.stderr
    assert "frame 3" in proc.stderr and "999999" in proc.stderr


@pytest.mark.parametrize("args, message", [
    (["--edges", "0.08", "0.05"], "increasing"),
    (["--bins", "0"], "give between 1 and"),
    (["--quantities", "nu,vorticity"], "unknown quantity"),
    (["--t-min", "1000"], "no frame at t >= 1000, the start of the average (--t-min)"),
])
def test_bad_options_are_refused(small_run, tmp_path, args, message):
    proc = run_cli("average", small_run, "--out", tmp_path / "p.csv", "--no-progress", *args)
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr


def test_coordination_alone_reads_no_forces_and_agrees_with_the_full_average(small_run):
    """Asked for coordination only, the reader skips the force columns; the profile is
    the one of the full average (the forces enter no coordination channel)."""
    from granavg.pipeline.runs import average_run

    alone = average_run(small_run, bins=5, t_min=1.0, quantities=["coordination"])
    full = average_run(small_run, bins=5, t_min=1.0)
    np.testing.assert_allclose(alone.values["coordination"], full.values["coordination"],
                               rtol=1e-12)
