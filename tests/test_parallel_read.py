"""Reading on several cores: the files of a series, and the pieces of one plain dump cut
at frame starts, parsed on reader threads, their frames handed on in the order one
thread reads them: the same frames (time step, line, every value) and the same fields,
to the bit, on any number of threads; a damaged row in a later piece is named at its
true file:line."""

import numpy as np
import pytest

import granavg
from granavg.engine import threads
from granavg.io import reader
from granavg.io.reader import DumpReader

pytestmark = pytest.mark.slow            # LAMMPS runs of the 3D pile deck (session fixtures)

CELLS = {"slabs": "z", "range": (0.0, 0.024), "bins": 6}
MAP = {"id1": "c_pp[1]", "id2": "c_pp[2]", "dist": "c_pl[1]", "dx": "c_pl[2]",
       "dy": "c_pl[3]", "dz": "c_pl[4]", "force": "c_pl[5]", "ftx": "c_pl[6]",
       "fty": "c_pl[7]", "ftz": "c_pl[8]"}


@pytest.fixture
def restore_threads():
    yield
    threads.set_count(None)


@pytest.fixture
def small_pieces(monkeypatch):
    """Any file of 4 kB or more is cut into pieces (one per thread)."""
    monkeypatch.setattr(reader, "PIECE", 4096)


def frames(path):
    return [(f.timestep, f.line, f.time, f.data.copy()) for f in DumpReader(path)]


def same(a, b):
    return len(a) == len(b) and all(x[:3] == y[:3] and np.array_equal(x[3], y[3])
                                    for x, y in zip(a, b))


def test_one_file_in_pieces_gives_the_frames_of_one_thread(pile3d_one, small_pieces,
                                                           restore_threads):
    path = pile3d_one / "contacts.dump"
    threads.set_count(1)
    one = frames(path)
    for n in (2, 3, 5):
        threads.set_count(n)
        pieces, depth = DumpReader(path)._pieces(path)
        assert len(pieces) == n and depth >= 2
        assert [p[0] for p in pieces] == sorted({p[0] for p in pieces})
        assert all(p[2] == 1 for p in pieces)              # each counts its own lines
        assert same(one, frames(path)), n
    assert len(one) > 5


def test_fields_are_bit_identical_on_one_two_and_three_threads(pile3d_one, pile3d_series,
                                                               small_pieces,
                                                               restore_threads):
    """A single dump (in pieces) and the same run's series (files in parallel), the
    stress included (contacts read in pieces too)."""
    results = {}
    for n in (1, 2, 3):
        threads.set_count(n)
        for name, atoms, contacts in (
                ("one", pile3d_one / "atoms.dump", pile3d_one / "contacts.dump"),
                ("series", pile3d_series / "atoms.*.txt", pile3d_series / "contacts.*.txt")):
            p = granavg.average(atoms, contacts=contacts, contact_map=MAP,
                                cells=dict(CELLS), gravity=(0, 0, -9.81))
            results[name, n] = p
    for name in ("one", "series"):
        a = results[name, 1]
        for n in (2, 3):
            b = results[name, n]
            for k in a.values:
                assert np.array_equal(a.values[k], b.values[k], equal_nan=True), (name, n, k)
                assert np.array_equal(a.sem[k], b.sem[k], equal_nan=True), (name, n, k)
    for k in ("nu", "sigma_zz"):                    # the same run, dumped two ways
        assert np.array_equal(results["one", 1].values[k], results["series", 1].values[k])


def test_a_damaged_row_in_a_later_piece_is_named_at_its_line(pile3d_one, tmp_path,
                                                            small_pieces, restore_threads):
    lines = (pile3d_one / "atoms.dump").read_text().splitlines(keepends=True)
    bad = len(lines) - 3                          # a row of the last frame (0-based)
    lines[bad] = lines[bad].replace(lines[bad].split()[4], "1.2.3", 1)
    path = tmp_path / "atoms.dump"
    path.write_text("".join(lines))
    for n in (1, 3):
        threads.set_count(n)
        with pytest.raises(granavg.errors.UserError, match=f"atoms.dump:{bad + 1}:"):
            frames(path)


def test_a_duplicate_id_in_a_later_piece_is_named_at_both_its_lines(pile3d_one, tmp_path,
                                                                     small_pieces,
                                                                     restore_threads):
    """The atoms' checks run on the reader thread that parsed the frame; one that fails
    there is done again where the frame's lines are final, so both lines it names are
    the file's own, on any number of threads."""
    from granavg.io.lammps_dumps import LammpsDumps

    lines = (pile3d_one / "atoms.dump").read_text().splitlines(keepends=True)
    bad = len(lines) - 3                          # a row of the last frame (0-based)
    head = lines[bad - 1].split()[0]              # the row before's id
    lines[bad] = head + lines[bad][len(lines[bad].split()[0]):]
    path = tmp_path / "atoms.dump"
    path.write_text("".join(lines))
    for n in (1, 3):
        threads.set_count(n)
        with pytest.raises(granavg.errors.UserError,
                           match=rf"atoms.dump:{bad + 1}: atom id {head} appears twice .*"
                                 rf"\(also line {bad}\)"):
            list(LammpsDumps(path))


def test_the_atoms_are_made_ready_on_the_reader_threads(pile3d_one, pile3d_series,
                                                        small_pieces, restore_threads,
                                                        monkeypatch):
    """A frame's per-frame work (units, wrapping, checks) runs on the reader threads, in
    parallel, not on the one thread that hands the frames on; the frames are the same."""
    import threading

    from granavg.io.lammps_dumps import LammpsDumps

    where = []
    made = LammpsDumps._atoms

    def recorded(self, fa):
        where.append(threading.current_thread().name)
        return made(self, fa)
    monkeypatch.setattr(LammpsDumps, "_atoms", recorded)
    for path in (pile3d_one / "atoms.dump", pile3d_series / "atoms.*.txt"):
        threads.set_count(1)
        where.clear()
        one = list(LammpsDumps(path))
        assert set(where) == {"MainThread"} and len(where) == len(one)
        threads.set_count(3)
        where.clear()
        many = list(LammpsDumps(path))
        assert set(where) == {"granavg-read"} and len(where) == len(many), (path, where)
        for a, b in zip(one, many):
            assert a.timestep == b.timestep and a.atoms.keys() == b.atoms.keys()
            assert all(np.array_equal(a.atoms[k], b.atoms[k]) for k in a.atoms)


def big_frames(path, n=70_000, frames=3):
    """A plain dump of ``frames`` frames of ``n`` spheres (more than one engine chunk)."""
    rng = np.random.default_rng(3)
    with open(path, "w") as fh:
        for k in range(frames):
            fh.write(f"ITEM: TIMESTEP\n{100 * k}\nITEM: NUMBER OF ATOMS\n{n}\n"
                     "ITEM: BOX BOUNDS pp pp ff\n0 1\n0 1\n0 0.1\n"
                     "ITEM: ATOMS id radius x y z vx vy vz\n")
            rows = np.column_stack([np.arange(1, n + 1), np.full(n, 0.004),
                                    rng.uniform(0, 1, (n, 2)), rng.uniform(0.004, 0.096, n),
                                    rng.normal(size=(n, 3))])
            np.savetxt(fh, rows, fmt=["%d", "%g", "%g", "%g", "%g", "%g", "%g", "%g"])
    return path


def test_workers_on_one_machine_with_big_frames_average_in_this_process(tmp_path, caplog,
                                                                        monkeypatch):
    """Frames of more than one engine chunk: --workers without a scheduler says in one
    line that one process uses every core and averages in it (no cluster started: no
    dask metadata), the fields those of one process."""
    import logging

    monkeypatch.setenv("GRANAVG_COST_MODEL", "on")
    path = big_frames(tmp_path / "big.dump")
    cells = {"slabs": "z", "range": (0.0, 0.1), "bins": 4}
    one = granavg.average(path, dt=1.0, cells=dict(cells), quantities=["nu", "v"])
    with caplog.at_level(logging.INFO, logger="granavg"):
        two = granavg.average(path, dt=1.0, cells=dict(cells), quantities=["nu", "v"],
                              workers=2)
    said = [m for m in caplog.messages if "averaging in this process" in m]
    assert len(said) == 1 and "70000 particles" in said[0], caplog.messages
    assert "dask" not in two.meta
    for k in one.values:
        assert np.array_equal(one.values[k], two.values[k], equal_nan=True), k


def test_one_reader_thread_where_asked_starts_no_reader(pile3d_one, pile3d_series,
                                                         small_pieces, restore_threads,
                                                         monkeypatch):
    """``readers=1`` (what reading only the first frames asks for: a frame read ahead on
    another thread would be parsed for nothing) reads a series and a file in pieces on
    the consumer's thread alone, the same frames; the default starts reader threads."""
    from granavg.io import prefetch

    started = []

    class Counted(prefetch.Ahead):
        def __init__(self, *args, **kwargs):
            started.append(kwargs.get("name"))
            super().__init__(*args, **kwargs)
    monkeypatch.setattr(prefetch, "Ahead", Counted)
    threads.set_count(3)
    for path in (pile3d_one / "atoms.dump", pile3d_series / "atoms.*.txt"):
        started.clear()
        many = [(f.timestep, f.line, f.data.copy()) for f in DumpReader(path)]
        assert started and set(started) == {"granavg-read"}, (path, started)
        started.clear()
        one = [(f.timestep, f.line, f.data.copy()) for f in DumpReader(path, readers=1)]
        assert started == [], (path, started)
        assert [x[:2] for x in one] == [x[:2] for x in many]
        assert all(np.array_equal(x[2], y[2]) for x, y in zip(one, many))
