"""The promise on damaged input, case by case, from a small real run: a user mistake or a
damaged file gets one line (what, where - file:line where a line exists - and what to
do) and exit code 2, never a traceback and never a partial result; harmless damage
leaves the numbers unchanged. Most cases call the CLI's entry point in this process
(a traceback would fail the test); signals go through a real subprocess."""

import gzip
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from granavg.cli import main
from granavg.io.profiles_io import read_profiles

from .conftest import run_cli


@pytest.fixture(scope="module")
def dumps(small_run, tmp_path_factory):
    """Plain-text lines of the small run's dumps, to damage."""
    d = tmp_path_factory.mktemp("dmg")
    out = {}
    for name in ("atoms", "contacts"):
        text = gzip.decompress((small_run / f"{name}.dump.gz").read_bytes()).decode()
        out[name] = text.splitlines(keepends=True)
        (d / f"{name}.dump").write_text(text)
    out["dir"] = d
    return out


def cli(capsys, *args):
    """Run ``granavg ARGS`` in this process: (exit code, stderr's error lines)."""
    code = main([str(a) for a in args])
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
    return code, err


def refused(capsys, tmp_path, args, *needles, out="p.csv"):
    """The call exits 2 with exactly one error line holding every needle, and leaves
    no output behind."""
    code, err = cli(capsys, *args)
    assert code == 2, err
    assert len(err) == 1, err
    for n in needles:
        assert str(n) in err[0], (n, err[0])
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(out)]
    assert not left, left
    return err[0]


def rows(lines, frame):
    """Indices (0-based) of the data rows of frame ``frame``."""
    heads = [k for k, ln in enumerate(lines) if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES"))]
    ends = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: TIMESTEP")][1:] + [len(lines)]
    return list(range(heads[frame] + 1, ends[frame]))


def columns(lines):
    head = next(ln for ln in lines if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")))
    return head.split()[2:]


def set_value(lines, frame, row, column, value):
    out = list(lines)
    k = rows(lines, frame)[row]
    cells = out[k].split()
    cells[columns(lines).index(column)] = str(value)
    out[k] = " ".join(cells) + "\n"
    return out, k + 1                                       # 1-based line


def write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("".join(lines))
    return path


def average(run, out, *extra):
    return ("average", run, "--bins", 6, "--t-min", 1, "--out", out, "--no-progress", *extra)


# -- damaged atom dumps --------------------------------------------------------------------

@pytest.mark.parametrize("value, needle", [(0, "is not positive"), (-0.003, "is not positive")])
def test_a_radius_that_is_not_positive(capsys, small_run, dumps, tmp_path, value, needle):
    lines, line = set_value(dumps["atoms"], 2, 7, "radius", value)
    bad = write(tmp_path, "atoms.dump", lines)
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
            f"{bad}:{line}:", needle)


def test_a_negative_atom_count(capsys, small_run, dumps, tmp_path):
    lines = list(dumps["atoms"])
    k = next(i for i, ln in enumerate(lines) if ln.startswith("ITEM: NUMBER OF ATOMS"))
    lines[k + 1] = "-5\n"
    bad = write(tmp_path, "atoms.dump", lines)
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
            f"{bad}:{k + 2}:", "NUMBER OF ATOMS")


def test_a_duplicated_atom_row(capsys, small_run, dumps, tmp_path):
    lines = list(dumps["atoms"])
    r = rows(lines, 3)
    lines[r[5]] = lines[r[4]]                               # two rows with one id
    bad = write(tmp_path, "atoms.dump", lines)
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
            f"{bad}:{r[5] + 1}:", "appears twice")


def frames_of(lines):
    starts = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: TIMESTEP")]
    return [lines[a:b] for a, b in zip(starts, starts[1:] + [len(lines)])]


@pytest.mark.parametrize("how", ["frame written twice", "resume appended again",
                                 "earlier timestep repeated"])
def test_repeated_or_backward_frames(capsys, small_run, dumps, tmp_path, how):
    f = frames_of(dumps["atoms"])
    order = {"frame written twice": [0, 1, 2, 2, 3, 4],
             "resume appended again": [0, 1, 2, 3, 4, 2, 3, 4],
             "earlier timestep repeated": [0, 1, 2, 3, 1, 4]}[how]
    bad = write(tmp_path, "atoms.dump", [ln for k in order for ln in f[k]])
    msg = refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
                  f"{bad}:", "does not follow", "cut back")
    assert "line" in msg


def test_atoms_given_a_directory(capsys, small_run, tmp_path):
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", tmp_path),
            "is a directory")


@pytest.mark.parametrize("content, needle", [
    (b"", "holds no complete frame"),
    (b"ITEM: TIMESTEP\n0\n", "not a readable gzip file"),                 # text named .gz
    (bytes(np.random.default_rng(1).integers(0, 256, 5000, dtype=np.uint8)),
     "not a readable gzip file"),
])
def test_empty_or_foreign_gzip(capsys, small_run, tmp_path, content, needle):
    bad = tmp_path / "atoms.dump.gz"
    bad.write_bytes(content)
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
            str(bad), needle)


def test_random_bytes_as_a_plain_dump(capsys, small_run, tmp_path):
    bad = tmp_path / "atoms.dump"
    bad.write_bytes(bytes(np.random.default_rng(2).integers(0, 256, 5000, dtype=np.uint8)))
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms", bad),
            f"{bad}:")


def test_a_cut_gzip_keeps_every_complete_frame(capsys, small_run, dumps, tmp_path):
    """Cut at 70%: the frames before the cut are averaged, exactly as if the dump had
    ended there, and the warning names the last frame kept."""
    raw = gzip.compress("".join(dumps["atoms"]).encode())
    cut = tmp_path / "atoms.dump.gz"
    cut.write_bytes(raw[: int(0.7 * len(raw))])
    frames = frames_of(dumps["atoms"])
    code, _ = cli(capsys, *average(small_run, tmp_path / "p.csv", "--atoms", cut,
                                   "--quantities", "nu,v"))
    assert code == 0
    got = read_profiles(tmp_path / "p.csv")
    kept = got.timeseries.step.to_numpy()
    assert len(kept) >= 0.6 * len(frames) - 1                # all but the damaged tail
    whole = write(tmp_path, "kept.dump", [ln for f in frames[:len(kept)] for ln in f])
    code, _ = cli(capsys, *average(small_run, tmp_path / "q.csv", "--atoms", whole,
                                   "--quantities", "nu,v"))
    ref = read_profiles(tmp_path / "q.csv")
    assert np.array_equal(got.values["v_phi"], ref.values["v_phi"], equal_nan=True)


# -- damaged tails met by --resume ----------------------------------------------------------

def _cut(raw, at):
    return raw[: int(at * len(raw))]


def _corrupt(raw, at):
    """0xFF over 64 bytes at ``at``: an invalid deflate block, as a writer killed by
    SIGTERM left once in CI ("invalid block type")."""
    k = int(at * len(raw))
    return raw[:k] + b"\xff" * 64 + raw[k + 64:]


@pytest.mark.parametrize("damage", [_cut, _corrupt], ids=["cut", "corrupt"])
def test_resume_bookkeeping_keeps_the_frames_before_a_damaged_gzip(dumps, tmp_path, damage):
    """frame_steps / truncate_dump (what --resume uses to pick its restart and cut the
    dump) read a damaged gzip up to the damage: a prefix of the true frames, no error."""
    from granavg.io.run_directory import frame_steps, truncate_dump
    frames = frames_of(dumps["atoms"])
    steps = [int(f[1]) for f in frames]
    path = tmp_path / "atoms.dump.gz"
    path.write_bytes(damage(gzip.compress("".join(dumps["atoms"]).encode()), 0.5))
    got = frame_steps(path)
    assert got == steps[:len(got)] and 0.3 * len(steps) <= len(got) < len(steps)
    assert truncate_dump(path, got[-1]) == len(got) - 1
    assert gzip.decompress(path.read_bytes()).decode() == "".join(
        ln for f in frames[:len(got) - 1] for ln in f)


@pytest.mark.parametrize("cut", ["mid row", "after TIMESTEP", "mid count", "mid ITEM"])
def test_resume_bookkeeping_on_a_plain_dump_cut_anywhere(dumps, tmp_path, cut):
    """A plain dump cut inside a row, right after 'ITEM: TIMESTEP' or inside the atom
    count: every frame before the cut is complete, the cut one is not."""
    from granavg.io.run_directory import frame_steps
    frames = frames_of(dumps["atoms"])
    last = frames[3]
    head = "".join(ln for f in frames[:3] for ln in f)
    tail = {"mid row": "".join(last[:-1]) + last[-1][:7],
            "after TIMESTEP": last[0], "mid count": "".join(last[:3]) + last[3][:1],
            "mid ITEM": last[0][:3]}[cut]
    path = write(tmp_path, "atoms.dump", [head + tail])
    assert frame_steps(path) == [int(f[1]) for f in frames[:3]]
    if cut == "mid ITEM":            # the cut piece is not kept with the last frame
        from granavg.io.run_directory import truncate_dump
        assert truncate_dump(path, 10**12) == 3 and path.read_text() == head


def test_resume_bookkeeping_keeps_a_whole_gzip_followed_by_garbage(dumps, tmp_path):
    """A complete gzip member then junk (an appended member cut at its header, zero
    padding): every frame of the complete member is kept."""
    from granavg.io.run_directory import frame_steps
    frames = frames_of(dumps["atoms"])
    path = tmp_path / "atoms.dump.gz"
    path.write_bytes(gzip.compress("".join(dumps["atoms"]).encode()) + b"\x1f\x8b\x08junk")
    assert frame_steps(path) == [int(f[1]) for f in frames]


# -- damaged contact dumps -----------------------------------------------------------------

@pytest.mark.parametrize("column, value, needle", [
    ("id2", "same", "in contact with itself"),
    ("nx", 0.5, "not a unit vector"),
    ("wall", 7, "wall code 7"),
    ("id1", 99999, "not in"),
])
def test_contact_rows_that_make_no_sense(capsys, small_run, dumps, tmp_path, column, value,
                                         needle):
    lines = dumps["contacts"]
    r = rows(lines, 2)
    k = next(i for i in r if lines[i].split()[2] == "0")      # a disk-disk contact
    idx = r.index(k)
    if value == "same":
        value = lines[k].split()[0]
    lines, line = set_value(lines, 2, idx, column, value)
    bad = write(tmp_path, "contacts.dump", lines)
    refused(capsys, tmp_path, average(small_run, tmp_path / "p.csv", "--atoms",
                                      dumps["dir"] / "atoms.dump", "--contacts", bad),
            f"{bad}:{line}:", needle)


def test_rows_that_do_not_touch_are_dropped_and_counted(capsys, small_run, dumps, tmp_path):
    """Non-touching neighbour rows (LAMMPS' pair/local without 'cutoff radius') change
    nothing but the count in the sidecar."""
    lines = list(dumps["contacts"])
    added = 0
    for frame in range(len(frames_of(lines))):
        k = rows(lines, frame)[0]
        cells = lines[k].split()
        cells[columns(lines).index("overlap")] = "-0.0001"
        lines.insert(k, " ".join(cells) + "\n")
        added += 1
    heads = [i for i, ln in enumerate(lines) if ln.startswith("ITEM: NUMBER OF ENTRIES")]
    for i in heads:
        lines[i + 1] = f"{int(lines[i + 1]) + 1}\n"
    bad = write(tmp_path, "contacts.dump", lines)
    atoms = dumps["dir"] / "atoms.dump"
    assert cli(capsys, *average(small_run, tmp_path / "p.csv", "--atoms", atoms,
                                "--contacts", bad))[0] == 0
    assert cli(capsys, *average(small_run, tmp_path / "q.csv", "--atoms", atoms,
                                "--contacts", dumps["dir"] / "contacts.dump"))[0] == 0
    p, q = (read_profiles(tmp_path / f) for f in ("p.csv", "q.csv"))
    for name in ("coordination", "F_rr", "sigma_rphi", "eps_rr"):
        assert np.array_equal(p.values[name], q.values[name], equal_nan=True)
    n_avg = p.n_frames
    assert 0 < p.meta["dropped"]["contacts_not_touching"] <= added
    assert p.meta["dropped"]["contacts_not_touching"] >= n_avg


# -- damaged manifests ---------------------------------------------------------------------

def with_manifest(small_run, tmp_path, edit):
    run = tmp_path / "run"
    shutil.copytree(small_run, run, ignore=shutil.ignore_patterns("restart"))
    m = json.loads((run / "manifest.json").read_text())
    text = edit(m)
    (run / "manifest.json").write_text(text if isinstance(text, str) else json.dumps(text))
    return run


def _set(section, key, value):
    def edit(m):
        m[section][key] = value
        return m
    return edit


def _drop(section, key=None):
    def edit(m):
        if key is None:
            del m[section]
        else:
            del m[section][key]
        return m
    return edit


@pytest.mark.parametrize("edit, needle", [
    (lambda m: [], "a manifest is a JSON object"),
    (_drop("scene"), "scene.R_i is missing"),
    (_drop("derived", "dt_s"), "derived.dt_s is missing"),
    (_drop("scene", "h"), "scene.h is missing"),
    (_set("scene", "h", "0.006"), "scene.h = '0.006' is not a number > 0"),
    (_set("scene", "Omega", "fast"), "scene.Omega = 'fast'"),
    (_set("scene", "Omega", 0), "scene.Omega = 0 is not a number > 0"),
    (_set("scene", "h", 0), "scene.h = 0"),
    (_set("scene", "rho_p", -1060), "scene.rho_p = -1060"),
    (_set("scene", "n_small", 2.5), "scene.n_small = 2.5"),
    (lambda m: json.dumps(m)[:200], "damaged"),
])
def test_a_damaged_manifest(capsys, small_run, tmp_path, edit, needle):
    run = with_manifest(small_run, tmp_path, edit)
    refused(capsys, tmp_path, average(run, tmp_path / "p.csv"), "manifest.json", needle)


def test_a_run_that_did_not_complete_is_averaged_with_a_warning(small_run, tmp_path):
    run = with_manifest(small_run, tmp_path, lambda m: {**m, "status": "running"})
    proc = run_cli(*average(run, tmp_path / "p.csv"))
    assert proc.returncode == 0 and "status is 'running'" in proc.stderr


# -- arguments and output paths ------------------------------------------------------------

@pytest.mark.parametrize("extra, needle", [
    (["--block-time", "-1"], "--block-time -1: must be a finite number > 0"),
    (["--block-time", "nan"], "--block-time: 'nan': give a finite number"),
    (["--t-min", "inf"], "--t-min: 'inf': give a finite number"),
    (["--bins", "1000000000"], "--bins 1000000000: give between 1 and"),
    (["--edges", "0.05", "inf"], "--edges: 'inf': give a finite number"),
    (["--edges", "0.08", "0.05"], "increasing"),
    (["--workers", "0"], "--workers 0"),
])
def test_bad_options_before_any_work(capsys, small_run, tmp_path, extra, needle):
    args = ("average", small_run, "--out", tmp_path / "p.csv", "--no-progress", *extra)
    refused(capsys, tmp_path, args, needle)


def test_output_paths_that_cannot_be_used(capsys, small_run, tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    refused(capsys, tmp_path, average(small_run, afile / "p.csv"), "is a file")
    refused(capsys, tmp_path, average(small_run, "/proc/granavg/p.csv"), "cannot write")
    refused(capsys, tmp_path, average(small_run, afile), "exists", out="afile.")
    side = tmp_path / "q.csv.json"
    side.write_text("{}")                                   # a sidecar without its table
    refused(capsys, tmp_path, average(small_run, tmp_path / "q.csv"), "q.csv.json exists",
            out="q.csv.r")
    assert side.read_text() == "{}" and not (tmp_path / "q.csv").exists()   # untouched


@pytest.mark.parametrize("what", ["a plain file", "missing"])
def test_the_run_is_not_a_directory(capsys, tmp_path, what):
    run = tmp_path / "run"
    if what == "a plain file":
        run.write_text("x")
    refused(capsys, tmp_path, average(run, tmp_path / "p.csv"),
            "is a file" if what == "a plain file" else "no such run directory")


# -- analyze on damaged profiles -----------------------------------------------------------

@pytest.fixture(scope="module")
def good_profiles(small_run, tmp_path_factory):
    d = tmp_path_factory.mktemp("good")
    for n in (8, 16):
        assert main(["average", str(small_run), "--bins", str(n), "--t-min", "1",
                     "--out", str(d / f"p{n}.csv"), "--no-progress"]) == 0
    return d


def copy_profiles(src, dst, name):
    for suffix in ("", ".json", ".replicates.npz", ".timeseries.csv"):
        shutil.copy(src / f"{name}{suffix}", dst / f"{name}{suffix}")
    return dst / name


@pytest.mark.parametrize("damage, needle", [
    (lambda p: p.with_name(p.name + ".json").write_text(
        p.with_name(p.name + ".json").read_text()[:300]), "damaged JSON"),
    (lambda p: p.with_name(p.name + ".json").write_text('{"units": "SI"}'), "no ring geometry"),
    (lambda p: p.write_text(p.read_text()[: len(p.read_text()) // 2]), "rows for"),
    (lambda p: p.write_bytes(bytes(range(256)) * 20), "not a readable profiles table"),
    (lambda p: p.write_text(""), "not a readable profiles table"),
])
def test_analyze_refuses_damaged_profiles_and_writes_nothing(capsys, good_profiles, tmp_path,
                                                             damage, needle):
    bad = copy_profiles(good_profiles, tmp_path, "p8.csv")
    damage(bad)
    out = tmp_path / "report"
    refused(capsys, tmp_path, ("analyze", bad, good_profiles / "p16.csv", "--out", out),
            needle, out="report")


def test_analyze_names_the_file_that_lacks_a_quantity(capsys, small_run, good_profiles,
                                                      tmp_path):
    nu = tmp_path / "nu.csv"
    assert cli(capsys, *average(small_run, nu, "--quantities", "nu,v"))[0] == 0
    refused(capsys, tmp_path, ("analyze", nu, good_profiles / "p16.csv", "--out",
                               tmp_path / "report"), f"{nu}: the profiles lack", out="report")


def test_analyze_out_an_existing_file(capsys, good_profiles, tmp_path):
    f = tmp_path / "report"
    f.write_text("x")
    refused(capsys, tmp_path, ("analyze", good_profiles / "p8.csv", good_profiles / "p16.csv",
                               "--out", f), "not an empty directory", out="nothing")
    assert f.read_text() == "x"


# -- signals -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def long_run(small_run, dumps, tmp_path_factory):
    """The small run with its frames repeated (time steps renumbered) so that averaging
    takes several seconds."""
    d = tmp_path_factory.mktemp("long")
    shutil.copy(small_run / "manifest.json", d / "manifest.json")
    for name in ("atoms", "contacts"):
        frames = frames_of(dumps[name])
        step = int(frames[1][1]) - int(frames[0][1])
        out = []
        for k in range(3000):
            f = list(frames[k % len(frames)])
            f[1] = f"{int(frames[0][1]) + k * step}\n"
            out.extend(f)
        (d / f"{name}.dump.gz").write_bytes(gzip.compress("".join(out).encode(), 1))
    return d


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_averaging_with_one_line_and_no_output(long_run, tmp_path, sig, code):
    out = tmp_path / "p.csv"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "granavg", "average", str(long_run),
                             "--bins", "20", "--t-min", "0", "--out", str(out),
                             "--no-progress"], stderr=subprocess.PIPE, text=True, env=env,
                            # as from a terminal (a background job inherits SIGINT ignored)
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    cpu = 0.0
    while cpu < 1.5 and proc.poll() is None:                # imports done, frames being read
        time.sleep(0.1)
        fields = open(f"/proc/{proc.pid}/stat").read().rsplit(")", 1)[1].split()
        cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    assert proc.poll() is None, "finished before the signal: make the run longer"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert "interrupted; nothing written" in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_an_error_after_a_signal_counts_as_the_interrupt():
    # a signal landing inside a compiled call or a ctypes callback comes out as another
    # error (SystemError, a RuntimeError): that is still Ctrl-C, not a bug to show
    # as a traceback; without a signal the same error is a bug and is raised
    import granavg.pipeline.session as session
    try:
        assert session.interrupt_code(RuntimeError("no compiled object yet")) is None
        assert session.interrupt_code(KeyboardInterrupt()) == 130
        assert session.interrupt_code(session.Terminated()) == 143
        session._signalled.append(signal.SIGINT)
        assert session.interrupt_code(SystemError("returned a result with an exception set")) == 130
        session._signalled.append(signal.SIGTERM)
        assert session.interrupt_code(RuntimeError("no compiled object yet")) == 143
    finally:
        session._signalled.clear()


def test_a_block_with_fewer_rows_than_its_header_is_never_read_beyond():
    """The parse kernel stops where the block ends (the next header), however the
    columns are skipped, and reports the first missing row."""
    import numpy as np
    from granavg.io.parse import MALFORMED, parse_block
    block = b"1 2.5 3\n4 5.5 6\nITEM:"             # two rows, the next header cut short
    buf = np.frombuffer(block, dtype=np.uint8)
    end = block.index(b"ITEM:")
    for target in ([0, 1, 2], [-1, -1, 0]):             # every column; only the last
        out, status, row, _ = parse_block(buf, 0, 3, 3, np.array(target), end)
        assert (status, row) == (MALFORMED, 2)
    out, status, row, col = parse_block(buf, 0, 2, 3, np.array([0, 1, 2]), end)
    assert status == 0 and col == end and out.tolist() == [[1, 2.5, 3], [4, 5.5, 6]]


@pytest.mark.parametrize("gz", [False, True])
def test_frames_skipped_by_a_step_window_keep_the_line_numbers_after_them(tmp_path, gz):
    """A worker's window skips the frames before it by counting their lines (in place
    in a mapped plain file): a damaged row after them is still named at its line, and
    the frames in the window are read whole."""
    from granavg.errors import UserError
    from granavg.io.reader import DumpReader

    def frame(step, bad=False):
        rows = ["1 0.1 0.1", "2 0.2 abc" if bad else "2 0.2 0.2", "3 0.3 0.3"]
        return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS ff ff pp\n"
                "0 1\n0 1\n-0.5 0.5\nITEM: ATOMS id x y\n" + "\n".join(rows) + "\n")
    text = frame(0) + frame(10) + frame(20) + frame(30, bad=True)     # 12 lines a frame
    path = tmp_path / ("d.dump.gz" if gz else "d.dump")
    path.write_bytes(gzip.compress(text.encode()) if gz else text.encode())
    (got,) = list(DumpReader(path, ["x", "y"], steps=(20, 20)))
    assert got.timestep == 20 and got.line == 34 and np.allclose(got.column("y"), [0.1, 0.2, 0.3])
    for steps in ((30, 30), None):
        with pytest.raises(UserError, match=rf"{path}:47: malformed row"):
            list(DumpReader(path, ["x", "y"], steps=steps))


def test_the_integer_check_finds_the_first_bad_row_and_the_first_huge_id():
    from granavg.engine._checks import not_integers
    v = np.array([1.0, 2.0, 2.5, np.nan, 2.0 ** 53, 7.0])
    assert not_integers(v, False, 2.0 ** 53) == (2, -1)          # ids off: no huge row
    assert not_integers(v, True, 2.0 ** 53) == (2, 4)
    assert not_integers(np.array([np.nan, 1.0]), False, 2.0 ** 53) == (0, -1)
    assert not_integers(np.arange(6.0)[::2], True, 2.0 ** 53) == (-1, -1)   # a strided view
    long = np.arange(200001.0)
    long[150000] = 0.5                                    # the path that releases the GIL
    assert not_integers(long, True, 2.0 ** 53) == (150000, -1)


def test_the_contact_rows_check_finds_each_fault_in_one_pass():
    from granavg.engine._checks import contact_rows_checked
    id1, id2 = np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.0, 2.0, 0.0, 5.0])
    wall = np.array([0.0, 0.0, 1.0, 3.0])
    nx, ny = np.array([1.0, 0.6, 0.0, 0.0]), np.array([0.0, 0.8, 1.0, 1.1])
    code, itself, norm, worst, off = contact_rows_checked(4, id1, id2, wall, nx, ny, None)
    assert (code, itself, worst) == (3, 1, 3) and np.isclose(off, 0.1)
    assert np.array_equal(norm, np.hypot(nx, ny))
    # a wall row of an atom with its own id is no self-contact; no wall column: none read
    _, itself, _, _, _ = contact_rows_checked(4, id1, np.array([9.0, 9.0, 3.0, 9.0]),
                                              wall, None, None, None)
    assert itself == -1
    code, itself, norm, worst, _ = contact_rows_checked(4, id1, id2, None, None, None, None)
    assert (code, itself, worst, len(norm)) == (-1, 1, -1, 0)
    nz = np.array([0.0, 0.0, 0.0, 2.0])                          # 3D: |n| with nz
    *_, worst, off = contact_rows_checked(4, None, None, None, nx, ny, nz)
    assert worst == 3 and np.isclose(off, np.sqrt(1.21 + 4.0) - 1.0)
