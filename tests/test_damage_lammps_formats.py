"""Damaged input on LAMMPS' layouts, case by case (tests/damage.py): the 3D pile of
tests/decks/pile_3d_si.lmp dumped once as text, binary and yaml (17 digits), and once on
two MPI ranks one file per processor. Each case copies a clean dump, damages it in one
place and averages it with the real command line: a damaged file is refused in one line
(exit 2) naming the file and the frame (line where there are lines, else time step) and
leaves no output; damage that cannot change the fields leaves the numbers as they were.

The binary dump damaged here is the real one rewritten with two chunks per frame, as
LAMMPS writes it on two processors (checked to average to the same numbers); the
per-processor dump is the real two-rank one with rank 1's file split in two along x, as
three processors side by side would write it (checked against the one-file dump)."""

import re
import subprocess

import numpy as np
import pytest

from .damage import (TextDump, YamlDump, accepted, average, binary_rows, out_path,
                     read_binary, refused, same_numbers, set_binary_rows, write_binary)
from .helpers import MAP3, PILE3D_DECK, run_pile3d

pytestmark = pytest.mark.slow

ROUTES = ("text", "binary", "yaml")
ATOMS = {"text": "atoms.dump", "binary": "atoms.bin", "yaml": "atoms.yaml"}


def options(atoms, contacts, out, *extra):
    """The pile averaged over six slabs of 5 mm from the floor, every frame."""
    return ("--atoms", atoms, "--contacts", contacts, "--contact-columns", MAP3,
            "--gravity", 0, 0, -9.81, "--wall-types", 3, "--slabs", "z", "--range", 0,
            0.03, "--bins", 6, "--out", out, *extra)


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    """The pile's dumps: atoms.dump (text), atoms.bin (binary, two chunks a frame),
    atoms.bin.one (LAMMPS' own, one chunk), atoms.yaml, contacts.dump."""
    out = tmp_path_factory.mktemp("damage_pile") / "pile"
    run_pile3d(out, precise="yes", floor="spheres", binary="yes", yaml="yes")
    raw = (out / "atoms.bin").read_bytes()
    (out / "atoms.bin.one").write_bytes(raw)
    frames = read_binary(raw)
    assert write_binary(frames) == raw                       # the writer is LAMMPS' layout
    for f in frames:
        set_binary_rows(f, binary_rows(f), nchunk=2)
    (out / "atoms.bin").write_bytes(write_binary(frames))
    return out


@pytest.fixture(scope="module")
def clean(pile, tmp_path_factory):
    """Each layout's clean profiles."""
    d = tmp_path_factory.mktemp("damage_pile_clean")
    out = {}
    for route in ROUTES:
        proc = average(*options(pile / ATOMS[route], pile / "contacts.dump",
                                d / f"{route}.csv"))
        out[route] = accepted(proc, d / f"{route}.csv")
    out["yaml alone"] = accepted(average(*alone(pile / "atoms.yaml", d / "alone.csv")),
                                 d / "alone.csv")
    return out


def alone(atoms, out):
    """The atoms alone: what their reader makes of them, no contact dump to pair."""
    return ("--atoms", atoms, "--slabs", "z", "--range", 0, 0.03, "--bins", 6, "--out", out)


def test_the_clean_layouts_average_alike(pile, clean, tmp_path):
    """The harness' baseline: the two-chunk binary rewrite averages as LAMMPS' own
    one-chunk file, and every layout as the text dump."""
    out = out_path(tmp_path)
    same_numbers(average(*options(pile / "atoms.bin.one", pile / "contacts.dump", out)),
                 out, clean["binary"])
    for route in ("binary", "yaml"):
        assert clean[route].frames_averaged == clean["text"].frames_averaged == 11
        for k in clean["text"].values:
            assert np.array_equal(clean[route].values[k], clean["text"].values[k],
                                  equal_nan=True), (route, k)


# -- binary dumps --------------------------------------------------------------------------

def _binary(pile):
    return read_binary((pile / "atoms.bin").read_bytes())


def _chunks(n):
    def damage(frames, k):
        return write_binary(frames, nchunk={k: len(frames[k]["chunks"]) + n})
    return damage


def _box_halved(frames, k):
    f = frames[k]
    assert f["flags"][0] == f["flags"][1] == 0                  # periodic along x
    f["bounds"][1] = f["bounds"][0] + 0.5 * (f["bounds"][1] - f["bounds"][0])
    return write_binary(frames)


def _nan_position(frames, k):
    rows = binary_rows(frames[k])
    rows[100, frames[k]["names"].index("x")] = np.nan
    set_binary_rows(frames[k], rows)
    return write_binary(frames)


def _time_backwards(frames, k):
    frames[k]["time"] = frames[k - 1]["time"] - 0.002            # steps still increase
    return write_binary(frames)


@pytest.mark.parametrize("damage, needles", [
    (_chunks(+1), ()),
    (_chunks(-1), ()),
    (_box_halved, ("box",)),
    (_nan_position, (("NaN", "nan"),)),
    (_time_backwards, ("time",)),
], ids=["chunk-count-high", "chunk-count-low", "periodic-box-halved", "nan-position",
        "time-backwards"])
def test_a_damaged_binary_frame_is_refused_naming_it(pile, clean, tmp_path, damage, needles):
    frames = _binary(pile)
    k = 5
    step, start = frames[k]["step"], frames[k]["start"]
    bad = tmp_path / "atoms.bin"
    bad.write_bytes(damage(frames, k))
    out = out_path(tmp_path)
    line = refused(average(*options(bad, pile / "contacts.dump", out)), out, str(bad),
                   (f"timestep {step}", f"byte {start}", str(step)), *needles,
                   clean=clean["binary"])
    assert not re.search(re.escape(str(bad)) + r":\d", line), \
        f"WEAK message: a binary file has no lines: {line}"


def test_a_binary_dump_cut_mid_frame_keeps_the_frames_before_it(pile, clean, tmp_path):
    """Cut inside frame 7's rows (the run killed while writing): either the 7 complete
    frames are averaged, as if the dump had ended there, with a warning naming the file,
    or the file is refused in one line naming it and the cut frame."""
    raw = (pile / "atoms.bin").read_bytes()
    frames = read_binary(raw)
    k = 7
    cut_at = frames[k]["start"] + (frames[k + 1]["start"] - frames[k]["start"]) // 2
    bad = tmp_path / "atoms.bin"
    bad.write_bytes(raw[:cut_at])
    out = out_path(tmp_path)
    proc = average(*options(bad, pile / "contacts.dump", out))
    if proc.returncode != 0:
        refused(proc, out, str(bad), (str(frames[k]["step"]), f"byte {frames[k]['start']}"))
        return
    warned = [ln for ln in proc.stderr.splitlines() if str(bad) in ln and "cut" in ln]
    assert warned, f"WEAK message: no warning names the cut file: {proc.stderr[-500:]}"
    whole = tmp_path / "whole.bin"
    whole.write_bytes(raw[:frames[k]["start"]])
    ref = out_path(tmp_path, "ref.csv")
    same_numbers(proc, out, accepted(average(*options(whole, pile / "contacts.dump", ref)),
                                     ref))
    print(f"observed: {warned[0]}")


# -- dump yaml -----------------------------------------------------------------------------

def _yaml_docs(y, k):
    (a, b), step = y.documents()[k], y.step(k)
    return a, b, step


def _delete(y, *indices):
    for i in sorted(indices, reverse=True):
        del y.lines[i]


def _no_start(y, k):
    _delete(y, y.documents()[k][0])


def _no_end(y, k):
    _delete(y, y.documents()[k][1])


def _no_key(name):
    def damage(y, k):
        i = y.key(k, name)
        _delete(y, *range(i, i + (4 if name == "box" else 1)))
    return damage


def _box_two_lines(y, k):
    _delete(y, y.key(k, "box") + 3)


def _boundary_short(y, k):
    y.lines[y.key(k, "boundary")] = "boundary: [ p, p, p, p, ]\n"


def _nan_data(y, k):
    y.set(y.rows(k)[40], "x", "nan")


def _short_row(y, k):
    r = y.rows(k)[40]
    y.set_values(r, y.values(r)[:-1])


@pytest.mark.parametrize("damage, needles, contacts", [
    (_no_start, (), False),
    (_no_end, (), False),
    (_no_key("box"), ("box",), True),
    (_no_key("keywords"), ("keywords",), True),
    (_no_key("data"), ("data",), True),
    (_box_two_lines, ("box",), True),
    (_boundary_short, ("boundary",), True),
    (_nan_data, (("NaN", "nan"),), True),
    (_short_row, (), True),
], ids=["no-document-start", "no-document-end", "no-box-key", "no-keywords-key",
        "no-data-key", "box-two-lines", "boundary-short", "nan-in-data", "row-short"])
def test_a_damaged_yaml_document_is_refused_naming_it(pile, clean, tmp_path, damage, needles,
                                                     contacts):
    """Every case names the file at the damaged document's lines (its ``---``, the
    damaged line, the next document's ``---``) or its time step. A document's lost
    ``---`` or ``...`` is read without a contact dump: the reader's own verdict (with
    one, the frames' pairing may find a gap, naming another place)."""
    y = YamlDump.read(pile / "atoms.yaml")
    k = 5
    a, b, step = _yaml_docs(y, k)
    row = y.rows(k)[40]
    damage(y, k)
    bad = y.write(tmp_path / "atoms.yaml")
    out = out_path(tmp_path)
    near = {a, a + 1, a + 2, row, row + 1, b, b + 1, b + 2}
    args = options(bad, pile / "contacts.dump", out) if contacts else alone(bad, out)
    refused(average(*args), out, str(bad),
            tuple(f"{bad}:{n}:" for n in sorted(near)) + (f"timestep {step}",), *needles,
            clean=clean["yaml" if contacts else "yaml alone"])


# -- dumps written one file per processor --------------------------------------------------

@pytest.fixture(scope="module")
def ranks(tmp_path_factory):
    """The bidisperse pile on two MPI ranks side by side in x (processors * 1 1): its
    one-file dumps and atoms.0.dump, atoms.1.dump, atoms.2.dump (rank 1's rows split at
    x = 12 mm, as a third processor would hold them)."""
    from granavg.sim.lammps_session import executable, lammps_env

    out = tmp_path_factory.mktemp("damage_ranks")
    proc = subprocess.run([executable("mpirun"), "-np", "2", executable("lmp"), "-in",
                           str(PILE3D_DECK), "-log", str(out / "log.lammps"), "-screen",
                           "none", "-var", "out", str(out), "-var", "precise", "yes",
                           "-var", "floor", "spheres", "-var", "bidisperse", "yes",
                           "-var", "perproc", "yes"], env=lammps_env(),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    one = TextDump.read(out / "atoms.1.dump")
    parts = ([], [])
    for frame in one.frames():
        head = next(k for k, ln in enumerate(frame) if ln.startswith("ITEM: ATOMS"))
        x = frame[head].split()[2:].index("x")
        rows = frame[head + 1:]
        side = [float(r.split()[x]) >= 0.012 for r in rows]
        count = next(k for k, ln in enumerate(frame) if ln.startswith("ITEM: NUMBER OF"))
        for p, part in enumerate(parts):
            mine = [r for r, s in zip(rows, side) if s == bool(p)]
            assert mine
            lines = frame[:head + 1]
            lines[count + 1] = f"{len(mine)}\n"
            part.extend(lines + mine)
    (out / "atoms.1.dump").write_text("".join(parts[0]))
    (out / "atoms.2.dump").write_text("".join(parts[1]))
    return out


def _ranks_options(d, out):
    return ("--atoms", d / "atoms.%.dump", "--contacts", d / "contacts.dump",
            "--contact-columns", MAP3, "--gravity", 0, 0, -9.81, "--wall-types", 3,
            "--slabs", "z", "--range", 0, 0.03, "--bins", 6, "--out", out)


@pytest.fixture(scope="module")
def ranks_clean(ranks, tmp_path_factory):
    d = tmp_path_factory.mktemp("damage_ranks_clean")
    return accepted(average(*_ranks_options(ranks, d / "p.csv")), d / "p.csv")


def _ranks_copy(ranks, tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    for name in ("atoms.0.dump", "atoms.1.dump", "atoms.2.dump", "contacts.dump"):
        (d / name).write_bytes((ranks / name).read_bytes())
    return d


def test_the_three_processor_files_are_the_one_file_dump(ranks, ranks_clean, tmp_path):
    out = out_path(tmp_path)
    proc = average("--atoms", ranks / "atoms.dump", *_ranks_options(ranks, out)[2:])
    same_numbers(proc, out, ranks_clean, rtol=1e-12)


def _rank_missing(p):
    def damage(d):
        (d / f"atoms.{p}.dump").unlink()
    return damage


def _rank_empty(d):
    (d / "atoms.2.dump").write_text("")


def _rank_fewer_frames(d):
    t = TextDump.read(d / "atoms.2.dump")
    t.keep_frames(8)
    t.write(d / "atoms.2.dump")


@pytest.mark.parametrize("damage, needles", [
    (_rank_missing(0), (("atoms.0.dump", "processor 0", "rank 0"),)),
    (_rank_missing(1), (("atoms.1.dump", "processor 1", "rank 1"),)),
    (_rank_empty, ("atoms.2.dump",)),
    (_rank_fewer_frames, ("atoms.2.dump", ("48500", "49000"))),
], ids=["rank-0-missing", "rank-gap", "rank-file-empty", "rank-fewer-frames"])
def test_a_damaged_set_of_processor_files_is_refused_naming_the_file(
        ranks, ranks_clean, tmp_path, damage, needles):
    """rank-fewer-frames: atoms.2.dump ends after timestep 48500 (8 of 11 frames); the
    line names it and the time step where it ends or the first it lacks."""
    d = _ranks_copy(ranks, tmp_path)
    damage(d)
    out = out_path(tmp_path)
    refused(average(*_ranks_options(d, out)), out, *needles, clean=ranks_clean)


# -- every layout: damaged atom rows -------------------------------------------------------

def _damage_rows(route, pile, tmp_path, frame, edit):
    """The ``route``'s dump with ``edit(values, names)`` applied to frame ``frame``'s
    rows (an array, in file order); the damaged file and its frame's locations: the
    needles a message may name them by, per row."""
    if route == "text":
        t = TextDump.read(pile / "atoms.dump")
        names, idx = t.columns(), t.rows(frame)
        values = np.array([t.cells(k) for k in idx], dtype=object)
        edit(values, names)
        for k, v in zip(idx, values):
            t.lines[k] = " ".join(map(str, v)) + "\n"
        path = t.write(tmp_path / "atoms.dump")
        return path, lambda r: (f"{path}:{idx[r] + 1}:",)
    if route == "yaml":
        y = YamlDump.read(pile / "atoms.yaml")
        names, idx, step = y.keywords(), y.rows(frame), y.step(frame)
        values = np.array([y.values(k) for k in idx], dtype=object)
        edit(values, names)
        for k, v in zip(idx, values):
            y.set_values(k, [str(c) for c in v])
        path = y.write(tmp_path / "atoms.yaml")
        return path, lambda r: (f"{path}:{idx[r] + 1}:", f"timestep {step}")
    frames = _binary(pile)
    f = frames[frame]
    rows = binary_rows(f).astype(object)
    edit(rows, f["names"])
    set_binary_rows(f, np.array(rows, float))
    path = tmp_path / "atoms.bin"
    path.write_bytes(write_binary(frames))
    return path, lambda r: (f"timestep {f['step']}",)


def _set(column, value, row):
    def edit(values, names):
        values[row, names.index(column)] = value
    return edit


def _duplicate(values, names):
    values[8, names.index("id")] = values[7, names.index("id")]


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize("edit, row, needles", [
    (_duplicate, 8, ("twice",)),
    (_set("diameter", 0, 7), 7, (("radius", "diameter"),)),
    (_set("diameter", -0.002, 7), 7, (("radius", "diameter"),)),
    (_set("id", 17.5, 9), 9, ("17.5",)),
], ids=["duplicate-id", "radius-zero", "radius-negative", "non-integer-id"])
def test_a_damaged_atom_row_is_refused_naming_it(pile, clean, tmp_path, route, edit, row,
                                                 needles):
    path, where = _damage_rows(route, pile, tmp_path, 3, edit)
    out = out_path(tmp_path)
    line = refused(average(*options(path, pile / "contacts.dump", out)), out, str(path),
                   where(row), *needles, clean=clean[route])
    named = re.findall(re.escape(str(path)) + r":(\d+):", line)
    if route == "binary":
        assert not named, f"WEAK message: a binary file has no lines: {line}"
    else:
        right = [w for w in where(row) if w.startswith(str(path))]
        assert not named or f"{path}:{named[0]}:" in right, \
            f"WEAK message: names line {named[0]}, the row is at {right}: {line}"


@pytest.mark.parametrize("route", ROUTES)
def test_an_atom_dump_without_vx(pile, clean, tmp_path, route):
    """Either refused in one line naming the file and vx, or averaged without the
    fields that need the velocity, every other one as in the clean run (none computed
    from a velocity taken as zero)."""
    if route == "text":
        t = TextDump.read(pile / "atoms.dump")
        t.drop_column("vx")
        path = t.write(tmp_path / "atoms.dump")
    elif route == "yaml":
        y = YamlDump.read(pile / "atoms.yaml")
        y.drop_column("vx")
        path = y.write(tmp_path / "atoms.yaml")
    else:
        frames = _binary(pile)
        for f in frames:
            j = f["names"].index("vx")
            rows = np.delete(binary_rows(f), j, axis=1)
            del f["names"][j]
            set_binary_rows(f, rows)
        path = tmp_path / "atoms.bin"
        path.write_bytes(write_binary(frames))
    out = out_path(tmp_path)
    proc = average(*options(path, pile / "contacts.dump", out))
    if proc.returncode != 0:
        refused(proc, out, str(path), "vx")
        return
    got = accepted(proc, out)
    ref = clean[route]
    assert "sigma_zz" in got.values and got.frames_averaged == ref.frames_averaged
    changed = [k for k in got.values if k not in ref.values or not np.array_equal(
        got.values[k], ref.values[k], equal_nan=True)]
    assert not changed, f"DEFECT silent wrong: computed without vx: {changed[:8]}"
    print(f"observed: exit 0, fields dropped: {sorted(set(ref.values) - set(got.values))}")


# -- text contact rows ---------------------------------------------------------------------

def _touching_row(c, frame):
    """A contact row of ``frame`` (index into its lines) between two mobile spheres
    that touch (a force)."""
    return next(k for k in c.rows(frame) if c.get(k, "c_pl[5]") != 0
                and c.get(k, "c_pp[1]") < 700 and c.get(k, "c_pp[2]") < 700)


def _unknown_atom(c, k):
    c.set(k, "c_pp[1]", 99999)
    return ("99999",)


def _not_unit(c, k):
    for x in ("c_pl[2]", "c_pl[3]", "c_pl[4]"):
        c.set(k, x, repr(1.1 * c.get(k, x)))                    # |d| = 1.1 dist
    return ()


@pytest.mark.parametrize("damage", [_unknown_atom, _not_unit],
                         ids=["contact-names-unknown-atom", "contact-normal-not-unit"])
def test_a_damaged_contact_row_is_refused_naming_its_line(pile, clean, tmp_path, damage):
    c = TextDump.read(pile / "contacts.dump")
    k = _touching_row(c, 4)
    needles = damage(c, k)
    bad = c.write(tmp_path / "contacts.dump")
    out = out_path(tmp_path)
    refused(average(*options(pile / "atoms.dump", bad, out)), out, f"{bad}:{k + 1}:",
            *needles, clean=clean["text"])


# -- windows and ranges --------------------------------------------------------------------

def test_a_time_window_ending_on_a_frame_takes_it_in_every_layout(pile, tmp_path):
    """The binary dump's time 0.48000000000000004 (48000 x 1e-5) is the text's and the
    yaml's 0.48 (%g): --t-max 0.48 takes that frame in every layout, the same five
    frames (0.46 .. 0.48) and the same numbers."""
    got = {}
    for route in ROUTES:
        out = out_path(tmp_path, f"{route}.csv")
        got[route] = accepted(average(*options(pile / ATOMS[route], pile / "contacts.dump",
                                               out, "--t-min", 0.46, "--t-max", 0.48)), out)
    frames = {r: got[r].frames_averaged for r in ROUTES}
    print(f"observed: frames averaged {frames}")
    assert frames == {r: 5 for r in ROUTES}, f"DEFECT silent wrong: frames averaged {frames}"
    for k in got["text"].values:
        assert np.array_equal(got["binary"].values[k], got["text"].values[k],
                              equal_nan=True), k


def test_a_range_above_all_data_is_refused_naming_the_datas_extent(pile, tmp_path):
    """--range 1 2 (m) over a pile 3 cm high: one line naming --range and where the
    data are along z (both ends, within a sphere's diameter)."""
    t = TextDump.read(pile / "atoms.dump")
    z = np.array([t.get(k, "z") for f in range(len(t.frame_starts())) for k in t.rows(f)])
    out = out_path(tmp_path)
    args = list(options(pile / "atoms.dump", pile / "contacts.dump", out))
    at = args.index("--range")
    args[at + 1:at + 3] = [1, 2]
    line = refused(average(*args), out, "--range")
    numbers = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", line)]
    near = lambda target: any(abs(v - target) <= 2.5e-3 for v in numbers)   # noqa: E731
    assert near(z.min()) and near(z.max()), \
        f"WEAK message: does not name the data's extent ({z.min():.4g} .. {z.max():.4g}): " \
        f"{line}"
