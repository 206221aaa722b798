"""Frames before --t-min scanned past, their rows not parsed (LAMMPS dumps): the
profiles equal those of reading every frame, bit for bit, by ITEM: TIME or by time step x
dt, for single files and dump.* series, the contact dump following the atom dump; rows
that could not be parsed before t_min do not stop the average, and a t_min past the last
frame is refused in one line."""

import re

import numpy as np
import pytest

from granavg.io.dump_columns import parse_map
from granavg.pipeline.dumps import dump_averager
from granavg.pipeline.spec import Spec
from tests.helpers import MAP3 as MAP, run_cli

CELLS = dict(slabs="z", range=(0.0, 0.024), bins=6)


@pytest.fixture(scope="module")
def pile(pile3d_one, pile3d_series):
    """The 3D pile deck's dumps (atoms with ITEM: TIME, contacts without), single files
    and a dump.* series (the session's runs)."""
    return {"one": pile3d_one, "many": pile3d_series}


def profiles(atoms, contacts, scan_early, **options):
    avg, frames = dump_averager(Spec.of(atoms, contacts=contacts, cells=CELLS,
                                        contact_map=parse_map(MAP), **options),
                                scan_early=scan_early)
    return avg.run(False), frames


def times(path):
    return [float(t) for t in re.findall(r"ITEM: TIME\n(\S+)", path.read_text())]


def same(a, b):
    for name in a.values:
        assert np.array_equal(a.values[name], b.values[name], equal_nan=True), name
        assert np.array_equal(a.sem[name], b.sem[name], equal_nan=True), name
    assert list(a.flags) == list(b.flags) and a.n_frames == b.n_frames


@pytest.mark.parametrize("layout", ["one", "many"])
def test_scanning_past_the_early_frames_gives_the_same_profiles(pile, layout):
    d = pile[layout]
    atoms, contacts = (d / "atoms.dump", d / "contacts.dump") if layout == "one" else \
        (d / "atoms.*.txt", d / "contacts.*.txt")
    first = sorted(d.glob("atoms*"))[0]
    t = times(first) if layout == "one" else sorted(
        float(times(p)[0]) for p in d.glob("atoms.*.txt"))
    t_min = 0.5 * (t[3] + t[4])                  # between frames: 4 frames before it
    skipped, frames = profiles(atoms, contacts, True, t_min=t_min)
    assert frames.atoms.from_time == t_min        # by ITEM: TIME
    assert "scanned_past" in skipped.meta["inputs"]
    read, plain = profiles(atoms, contacts, False, t_min=t_min)
    assert plain.atoms.from_time is None and "scanned_past" not in read.meta["inputs"]
    same(skipped, read)
    assert skipped.n_frames == len(t) - 4


def test_by_time_step_and_dt_where_the_dumps_have_no_time(pile, tmp_path):
    d = pile["one"]
    text = re.sub(r"ITEM: TIME\n\S+\n", "", (d / "atoms.dump").read_text())
    (tmp_path / "atoms.dump").write_text(text)
    steps = [int(s) for s in re.findall(r"ITEM: TIMESTEP\n(\d+)", text)]
    dt = 1e-5                                                   # the deck's timestep
    t_min = steps[3] * dt                         # exactly a frame's time: it is kept
    skipped, frames = profiles(tmp_path / "atoms.dump", d / "contacts.dump", True,
                               t_min=t_min, dt=dt)
    assert frames.atoms.steps[0] <= steps[3] and frames.atoms.steps[0] > steps[2]
    read, _ = profiles(tmp_path / "atoms.dump", d / "contacts.dump", False, t_min=t_min,
                       dt=dt)
    same(skipped, read)
    assert skipped.n_frames == len(steps) - 3


def test_rows_before_t_min_are_not_parsed(pile, tmp_path):
    # a frame before t_min with a row of junk (the right number of rows): scanned past, it
    # is not read; read, it is refused with its file:line - so the skip is a scan
    d = pile["one"]
    lines = (d / "atoms.dump").read_text().splitlines(keepends=True)
    heads = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")]
    lines[heads[1] + 2] = "junk " * 13 + "\n"
    (tmp_path / "atoms.dump").write_text("".join(lines))
    t = times(d / "atoms.dump")
    skipped, _ = profiles(tmp_path / "atoms.dump", d / "contacts.dump", True,
                          t_min=0.5 * (t[2] + t[3]))
    read, _ = profiles(d / "atoms.dump", d / "contacts.dump", True,
                       t_min=0.5 * (t[2] + t[3]))
    same(skipped, read)
    proc = run_cli("average", "--atoms", tmp_path / "atoms.dump", "--contacts",
                   d / "contacts.dump", "--contact-columns", MAP, "--slabs", "z", "--out",
                   tmp_path / "p.csv", "--no-progress")
    assert proc.returncode == 2
    assert f"atoms.dump:{heads[1] + 3}" in proc.stderr and "Traceback" not in proc.stderr


def test_a_t_min_past_the_last_frame_is_refused_in_one_line(pile, tmp_path):
    d = pile["one"]
    proc = run_cli("average", "--atoms", d / "atoms.dump", "--contacts",
                   d / "contacts.dump", "--contact-columns", MAP, "--slabs", "z",
                   "--t-min", 1000, "--out", tmp_path / "p.csv", "--no-progress")
    assert proc.returncode == 2
    assert "no frame at t >= 1000, the start of the average (--t-min)" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "p.csv").exists()


def test_the_row_walk_stops_at_the_nth_newline_and_never_past_its_limit():
    from granavg.io.parse import skip_rows
    buf = np.frombuffer(b"1 2\n3 4\n5 6\nITEM: X\n", dtype=np.uint8)
    assert skip_rows(buf, 0, 0, len(buf)) == 0
    assert skip_rows(buf, 0, 3, len(buf)) == 12 and bytes(buf[12:17]) == b"ITEM:"
    assert skip_rows(buf, 4, 2, len(buf)) == 12
    assert skip_rows(buf, 0, 3, 11) == -1                 # the third newline lies at 11
    assert skip_rows(buf, 0, 9, len(buf)) == -1
    assert skip_rows(np.zeros(0, np.uint8), 0, 1, 0) == -1
