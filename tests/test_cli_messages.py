"""What the command line says on stderr, as a new user meets it: the documented form of
``--species`` groups, one-line refusals of groups written elsewhere and of types that are
not integers, exactly one ``granavg:`` prefix on every line (from this process, dask's
workers, Python's warnings), and progress as log lines where stderr is no terminal."""

import json
import logging
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import granavg
from granavg.engine import progress
from granavg.engine.species import Species
from granavg.errors import ParameterError
from granavg.examples import couette_2d, pile_3d

from .helpers import run_cli

RUN = couette_2d.run
DOCS = Path(__file__).resolve().parent.parent / "docs" / "species.md"
MAP3 = ",".join(f"{k}={v}" for k, v in pile_3d.contact_map.items())


def refused_in_one_line(proc, *needles):
    """Exit 2, one stderr line, ``granavg: error: `` once at its start, every needle in
    it, no traceback; the line."""
    lines = proc.stderr.splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert lines[0].startswith("granavg: error: ") and lines[0].count("granavg:") == 1
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


def prefixed_once(text):
    """Every non-empty line of ``text`` starts with ``granavg: `` and carries it once."""
    bad = [ln for ln in text.splitlines()
           if ln.strip() and (not ln.startswith("granavg: ") or ln.count("granavg: ") != 1)]
    assert not bad, bad


# -- 1. --species groups as docs/species.md writes them --------------------------------------

def test_the_documented_groups_are_one_option(tmp_path):
    """``--species small=1 large=2,3`` (docs/species.md) is one option of several words,
    before ``--out``: the same fields as the Python API's dict of groups (the Couette
    example has types 1 and 2)."""
    assert "--species small=1 large=2,3" in DOCS.read_text()
    out = tmp_path / "g.csv"
    proc = run_cli("average", RUN, "--bins", 4, "--t-min", 0, "--species", "small=1",
                   "large=2", "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    table = granavg.read(out)
    direct = granavg.average(RUN, cells={"bins": 4}, t_min=0.0,
                             species={"small": [1], "large": [2]})
    assert table.species == direct.species == ("all", "small", "large")
    assert np.allclose(table.values["nu"], direct.values["nu"], rtol=1e-9, atol=0)


def test_one_word_splits_still_work(tmp_path):
    proc = run_cli("average", RUN, "--bins", 4, "--t-min", 0, "--species", "type",
                   "--out", tmp_path / "t.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    assert granavg.read(tmp_path / "t.csv").species == ("all", "type1", "type2")


@pytest.mark.parametrize("args, read_as", [
    (["--species=small=1", "large=2,3", "--t-min", 0], "read as a run directory"),
    ([RUN, "--species", "small=1", "--t-min", 0, "large=2,3"], "an argument no option"),
], ids=["among-run-directories", "after-another-option"])
def test_a_group_written_elsewhere_is_one_line(tmp_path, args, read_as):
    """A group argparse does not give to --species: one line saying it looks like a
    group and how to write the groups, not a complaint about plain dumps' options."""
    proc = run_cli("average", *args, "--bins", 4, "--out", tmp_path / "x.csv",
                   "--no-progress")
    line = refused_in_one_line(proc, "'large=2,3' looks like a species group", read_as,
                               "--species small=1 large=2,3")
    assert "--dt" not in line and "plain LAMMPS dumps" not in line
    assert not list(tmp_path.iterdir())


def test_a_run_directory_after_the_groups_is_one_line(tmp_path):
    proc = run_cli("average", "--species", "small=1", "large=2,3", RUN, "--out",
                   tmp_path / "x.csv", "--no-progress")
    refused_in_one_line(proc, f"{str(RUN)!r} is no group NAME=TYPES",
                        "the run directories before --species")


# -- 2. types that are not integers ----------------------------------------------------------

@pytest.mark.parametrize("spec", ["small=1.5 large=2", {"small": [1.5], "large": [2]},
                                  "small=1 large=a"])
def test_a_type_that_is_not_an_integer_is_refused(spec):
    with pytest.raises(ParameterError, match="not an integer; give atom types as integers"):
        Species.parse(spec)


def test_integer_types_in_any_spelling_are_read():
    assert Species.parse("small=1,2.0 large=3").groups == (("small", (1, 2)), ("large", (3,)))
    assert Species.parse({"small": [np.int64(1)], "large": 2.0}).groups == \
        (("small", (1,)), ("large", (2,)))


def test_a_non_integer_type_on_the_command_line_is_one_line(tmp_path):
    proc = run_cli("average", RUN, "--species", "small=1.5", "large=2", "--out",
                   tmp_path / "x.csv", "--no-progress")
    refused_in_one_line(proc, "--species: the group small names type '1.5', not an integer",
                        "give atom types as integers")
    assert not list(tmp_path.iterdir())


# -- 3. one prefix on every line --------------------------------------------------------------

def _python(code, **env):
    """``python -c code`` with stderr to a pipe (no terminal): the CompletedProcess."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **env}, timeout=300)


def test_a_message_that_carries_the_prefix_gets_no_second_one():
    code = ("import logging; from granavg.pipeline.session import configure_logging; "
            "configure_logging(False); log = logging.getLogger('granavg.x'); "
            "log.warning('granavg: from another process'); log.info('two\\nlines'); "
            "configure_logging(False); log.info('once, after a second set-up')")
    err = _python(code).stderr.splitlines()
    assert err == ["granavg: from another process", "granavg: two", "granavg: lines",
                   "granavg: once, after a second set-up"], err


def test_python_warnings_are_one_prefixed_line():
    code = ("import warnings; from granavg.pipeline.session import configure_logging; "
            "configure_logging(False); warnings.warn('mind the gap', RuntimeWarning)")
    err = _python(code).stderr.splitlines()
    assert len(err) == 1 and err[0].startswith("granavg: RuntimeWarning: mind the gap"), err


def test_dask_imported_first_logs_through_the_same_handler():
    """distributed, imported before the command sets up its logging, has put its own
    handler (no prefix, a time stamp) on its loggers: it goes."""
    pytest.importorskip("distributed")
    code = ("import logging, distributed; from granavg.pipeline.session import "
            "configure_logging; configure_logging(False); "
            "logging.getLogger('distributed.worker').warning('a dask warning')")
    err = _python(code).stderr.splitlines()
    assert err == ["granavg: a dask warning"], err


def test_errors_and_warnings_of_a_command_are_prefixed_once(tmp_path):
    """A run with a warning and an information line, and a refusal."""
    proc = run_cli("average", RUN, "--bins", 4, "--t-min", 0, "--out", tmp_path / "a.csv")
    assert proc.returncode == 0 and "cannot tell a drift" in proc.stderr, proc.stderr
    prefixed_once(proc.stderr)
    assert len(set(proc.stderr.splitlines())) == len(proc.stderr.splitlines())
    proc = run_cli("average", RUN, "--bins", 4, "--out", tmp_path / "a.csv")
    refused_in_one_line(proc, "exists; choose another --out")


@pytest.mark.slow
def test_dask_workers_say_their_lines_with_the_prefix(tmp_path):
    """A local cluster's workers (a cut dump: a worker reads the cut frame too) and
    dask's own chatter with -v: every line prefixed once."""
    pytest.importorskip("distributed")
    import gzip
    text = gzip.decompress(pile_3d.atoms.read_bytes())
    (tmp_path / "atoms.dump").write_bytes(text[:-3000])
    (tmp_path / "contacts.dump").write_bytes(gzip.decompress(pile_3d.contacts.read_bytes()))
    args = ["average", "--atoms", tmp_path / "atoms.dump", "--contacts",
            tmp_path / "contacts.dump", "--contact-columns", MAP3, "--slabs", "z", "--bins", 6,
            "--workers", 2, "--no-progress"]
    env = dict(os.environ, GRANAVG_COST_MODEL="off")
    proc = run_cli(*args, "--out", tmp_path / "a.csv", env=env)
    assert proc.returncode == 0 and "is truncated; skipped" in proc.stderr, proc.stderr
    prefixed_once(proc.stderr)
    proc = run_cli("-v", *args, "--out", tmp_path / "b.csv", env=env)
    assert proc.returncode == 0 and "Scheduler" in proc.stderr, proc.stderr
    prefixed_once(proc.stderr)


@pytest.mark.slow
def test_the_rows_dropped_are_counted_over_every_worker(tmp_path):
    """The count of contact rows left out (not touching) that the log line and the
    sidecar give is the serial one on a local cluster: the workers' counts summed, not
    the first frames' only."""
    pytest.importorskip("distributed")
    import gzip
    for name in ("atoms", "contacts"):      # the 3 frames 8 times (24), times from --dt
        text = gzip.decompress(getattr(pile_3d, name).read_bytes()).decode()
        frames = re.sub(r"ITEM: (UNITS|TIME)\n\S+\n", "", text).split("ITEM: TIMESTEP\n")[1:]
        (tmp_path / f"{name}.dump").write_text("".join(
            f"ITEM: TIMESTEP\n{int(f.split(chr(10), 1)[0]) + 1500 * k}\n"
            f"{f.split(chr(10), 1)[1]}" for k in range(8) for f in frames))
    args = ["average", "--atoms", tmp_path / "atoms.dump", "--contacts",
            tmp_path / "contacts.dump", "--contact-columns", MAP3, "--slabs", "z", "--bins", 6,
            "--dt", 1e-5, "--units", "si", "--no-progress"]
    said = {}
    for how, extra, env in (("serial", [], None), ("workers", ["--workers", 2], dict(
            os.environ, GRANAVG_COST_MODEL="off"))):
        out = tmp_path / f"{how}.csv"
        proc = run_cli(*args, *extra, "--out", out, env=env)
        assert proc.returncode == 0, proc.stderr
        line = [ln for ln in proc.stderr.splitlines() if "were dropped" in ln]
        said[how] = (line, json.loads(Path(f"{out}.json").read_text())["dropped"])
    assert said["serial"][1]["contacts_not_touching"] > 0
    assert said["workers"] == said["serial"]


# -- 4. progress where stderr is no terminal -----------------------------------------------------

class Clock:
    """Seconds that pass by ``step`` at each reading."""

    def __init__(self, step):
        self.now, self.step = 0.0, step

    def __call__(self):
        self.now += self.step
        return self.now


class Frame:
    def __init__(self, time):
        self.time = time


def test_progress_lines_come_now_and_then(caplog):
    """10 frames, 4 s each, a line at most every 10 s: after the 3rd, 6th and 9th frame,
    and one at the end; the frames pass unchanged."""
    frames = [Frame(0.5 * k) for k in range(10)]
    with caplog.at_level(logging.INFO, logger="granavg"):
        seen = list(progress.logged(frames, "averaging", every=10, clock=Clock(4.0)))
    assert seen == frames
    assert caplog.messages == ["averaging: 3/10 frames read (30%), t = 1, 12 s",
                               "averaging: 6/10 frames read (60%), t = 2.5, 24 s",
                               "averaging: 9/10 frames read (90%), t = 4, 36 s",
                               "averaging: 10 frames read in 44 s"]


def test_a_short_pass_says_nothing(caplog):
    with caplog.at_level(logging.INFO, logger="granavg"):
        assert list(progress.logged(iter(range(5)), every=10, clock=Clock(1.0))) == \
            list(range(5))
    assert caplog.messages == []


def test_progress_asked_for_or_not():
    frames = [Frame(0.0)]
    assert progress.progress_of(frames, False) is frames
    assert list(progress.progress_of(frames, None)) == frames      # pytest: no terminal


def test_a_command_with_stderr_in_a_file_logs_its_progress(tmp_path):
    """stderr redirected to a file: the pass' progress as prefixed log lines (here one
    per frame), none with --no-progress; none in a pass shorter than the interval."""
    code = ("import sys; import granavg.engine.progress as p; p.EVERY = 0.0; "
            "from granavg.cli import main; sys.exit(main(sys.argv[1:]))")
    for name, extra in (("a", []), ("b", ["--no-progress"])):
        with open(tmp_path / f"{name}.err", "w") as err:
            proc = subprocess.run([sys.executable, "-c", code, "average", str(RUN), "--bins",
                                   "4", "--t-min", "0", "--out", str(tmp_path / f"{name}.csv"),
                                   *extra], stderr=err, timeout=300)
        assert proc.returncode == 0
    said = (tmp_path / "a.err").read_text()
    prefixed_once(said)
    lines = [ln for ln in said.splitlines() if ln.startswith("granavg: averaging: ")]
    assert lines[0].startswith("granavg: averaging: 1 frame read, t = "), said
    assert lines[-1].startswith("granavg: averaging: 13 frames read in "), said
    assert "averaging:" not in (tmp_path / "b.err").read_text()
    plain = run_cli("average", RUN, "--bins", 4, "--t-min", 0, "--out", tmp_path / "c.csv")
    assert plain.returncode == 0 and "averaging:" not in plain.stderr, plain.stderr
