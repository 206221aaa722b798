"""The engine's threads: the chunks of a frame's particles summed on several cores give
the same sums, to the bit, for any thread count, and the same as one pass over all the
particles to round-off; bad thread counts are refused in one line."""

import importlib

import numpy as np
import pytest

from granavg.engine import average, threads
from granavg.cells import Boxes
from granavg.engine.frame_sums import frame_sums
from granavg.engine.cells.sectors import about_axis
from granavg.engine.cells.rings import Rings
from granavg.errors import ParameterError
from granavg.io.frames import Frame
from tests.conftest import run_cli

average_module = importlib.import_module("granavg.engine.frame_sums")   # not the function
BLOCKS = ["vol", "mass", "mom", "spin", "ncontact", "fab", "sig", "kin", "def"]


def random_spheres(n, seed=1):
    """n spheres in a 1 x 1 x 0.3 box with random velocities and spins, each touching
    the next (contacts of random forces and normals): a load for the chunked sums."""
    rng = np.random.default_rng(seed)
    x, y, z = rng.uniform(0, 1, n), rng.uniform(0, 1, n), rng.uniform(0, 0.3, n)
    ids = rng.permutation(n) + 1.0
    atoms = {"id": ids, "x": x, "y": y, "z": z, "radius": rng.uniform(0.004, 0.006, n),
             **{f"v{c}": rng.normal(size=n) for c in "xyz"},
             **{f"omega{c}": rng.normal(size=n) for c in "xyz"}}
    k = np.arange(n - 1)
    nrm = rng.normal(size=(n - 1, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    contacts = {"id1": ids[k], "id2": ids[k + 1], "wall": np.zeros(n - 1),
                **{f"fn{c}": rng.normal(size=n - 1) for c in "xyz"},
                **{f"ft{c}": rng.normal(size=n - 1) for c in "xyz"},
                **{f"n{c}": nrm[:, i] for i, c in enumerate("xyz")},
                "overlap": rng.uniform(0, 1e-4, n - 1)}
    return Frame(0, 0.0, atoms, contacts)


@pytest.fixture
def restore_threads():
    yield
    threads.set_count(None)


def test_the_chunks_sums_are_bit_identical_on_1_2_and_3_threads(restore_threads):
    frame = random_spheres(3 * average_module.CHUNK + 17)      # four chunks
    cells = Boxes(np.linspace(0, 1, 9), np.linspace(0, 1, 9), np.linspace(0, 0.3, 4))
    sums = {}
    for n in (1, 2, 3):
        threads.set_count(n)
        sums[n] = frame_sums(frame, cells, 2500.0, BLOCKS)
    assert np.any(sums[1] != 0)
    assert np.array_equal(sums[1], sums[2]) and np.array_equal(sums[1], sums[3])


def agree(a, b):
    """Equal to round-off: within 1e-12 of each channel's largest sum."""
    return bool(np.all(np.abs(a - b) <= 1e-12 * np.abs(b).max(axis=0)))


def test_chunked_sums_equal_one_pass_over_all_particles_to_round_off(monkeypatch,
                                                                      restore_threads):
    frame = random_spheres(2 * average_module.CHUNK + 5)
    cells = Boxes(np.linspace(0, 1, 6), np.linspace(0, 1, 6), np.linspace(0, 0.3, 3))
    threads.set_count(2)
    chunked = frame_sums(frame, cells, 2500.0, BLOCKS)
    monkeypatch.setattr(average_module, "CHUNK", 1 << 30)          # one pass
    whole = frame_sums(frame, cells, 2500.0, BLOCKS)
    assert agree(chunked, whole)
    # the check can fail: the sums of the first chunk's particles alone are far off
    monkeypatch.undo()
    first = Frame(0, 0.0, {k: v[:average_module.CHUNK] for k, v in frame.atoms.items()}, None)
    own = ["vol", "mass", "mom"]
    assert not agree(frame_sums(first, cells, 2500.0, own),
                     frame_sums(frame, cells, 2500.0, own))


def test_contacts_across_chunks_count_for_both_of_their_particles(monkeypatch,
                                                                   restore_threads):
    # contacts between random rows (each chunk sees only the contacts of its own
    # particles), wall contacts among them, couples and powers too: chunked = one pass
    frame = random_spheres(6000, seed=4)
    rng = np.random.default_rng(5)
    c = len(frame.contacts["id1"])
    ids = frame.atoms["id"]
    contacts = dict(frame.contacts, id1=rng.choice(ids, c), id2=rng.choice(ids, c),
                    wall=(rng.uniform(size=c) < 0.1).astype(float),
                    **{f"m{x}": rng.normal(size=c) for x in "xyz"})
    contacts["id2"] = np.where(contacts["wall"] > 0, 0.0, contacts["id2"])
    frame = Frame(0, 0.0, frame.atoms, contacts)
    cells = Boxes(np.linspace(0, 1, 5), np.linspace(0, 1, 5), np.linspace(0, 0.3, 3))
    want = BLOCKS + ["cst", "lever", "cnet", "wcpl", "ppow", "wpow", "lpow"]
    whole = frame_sums(frame, cells, 2500.0, want)
    monkeypatch.setattr(average_module, "CHUNK", 1024)             # six chunks
    got = []
    for k in (1, 2):
        threads.set_count(k)
        got.append(frame_sums(frame, cells, 2500.0, want))
    assert np.array_equal(got[0], got[1])
    assert agree(got[0], whole)
    # the check can fail: the contacts of one chunk alone are far off
    part = {k: v[:c // 6] for k, v in contacts.items()}
    assert not agree(frame_sums(Frame(0, 0.0, frame.atoms, part), cells, 2500.0, want), whole)


def test_sectors_sums_of_rings_are_bit_identical_across_thread_counts(monkeypatch,
                                                                      restore_threads):
    rng = np.random.default_rng(3)
    n = 5000
    r, phi = rng.uniform(0.12, 0.24, n), rng.uniform(0, 2 * np.pi, n)
    atoms = {"id": np.arange(1.0, n + 1), "x": r * np.cos(phi), "y": r * np.sin(phi),
             "radius": rng.uniform(0.003, 0.0045, n), "vx": rng.normal(size=n),
             "vy": rng.normal(size=n), "omegaz": rng.normal(size=n)}
    frame = Frame(0, 0.0, atoms, None)
    cells = Rings(np.linspace(0.1, 0.26, 11), 0.006)
    monkeypatch.setattr(average_module, "CHUNK", 1024)             # five chunks
    got = []
    for k in (1, 2):
        threads.set_count(k)
        got.append(frame_sums(frame, cells, 1060.0, ["vol", "mass", "mom", "spin"], n_sectors=8))
    assert np.array_equal(got[0], got[1])
    sector, share = about_axis((atoms["x"], atoms["y"]), atoms["radius"], (0.0, 0.0), 8, 2)
    assert np.allclose(share.sum(axis=1), 1.0, rtol=0, atol=1e-14)


def test_a_whole_average_is_the_same_on_one_and_two_threads(restore_threads):
    frames = [random_spheres(70000, seed=s) for s in (1, 2, 3)]
    frames = [Frame(k, float(k), f.atoms, f.contacts) for k, f in enumerate(frames)]
    cells = Boxes(np.linspace(0, 1, 5), np.linspace(0, 1, 5), np.linspace(0, 0.3, 3))
    out = []
    for k in (1, 2):
        threads.set_count(k)
        out.append(average(frames, cells, density=2500.0, sectors=None))
    for name, v in out[0].values.items():
        assert np.array_equal(v, out[1].values[name], equal_nan=True), name


@pytest.mark.parametrize("bad", [0, -2, "two", "1.5", True, ""])
def test_a_bad_thread_count_is_refused_in_one_line(bad, restore_threads):
    with pytest.raises(ParameterError, match="whole number of threads"):
        threads.set_count(bad)


def test_the_environment_sets_the_default_and_a_bad_value_is_refused(monkeypatch,
                                                                     restore_threads):
    monkeypatch.setenv("GRANAVG_THREADS", "3")
    assert threads.count() == 3
    monkeypatch.setenv("GRANAVG_THREADS", "many")
    with pytest.raises(ParameterError, match="GRANAVG_THREADS 'many'"):
        threads.count()
    monkeypatch.delenv("GRANAVG_THREADS")
    assert threads.count() == threads.cores() >= 1


def test_the_cli_refuses_a_bad_thread_count_with_exit_code_2(tmp_path):
    dump = tmp_path / "a.dump"
    dump.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp pp\n"
                    "0 1\n0 1\n-0.1 0.1\nITEM: ATOMS id x y radius\n1 0.5 0.5 0.01\n")
    proc = run_cli("average", "--atoms", str(dump), "--thickness", "0.01", "--grid", "2", "2",
                   "--dt", "1", "--threads", "0", "--out", str(tmp_path / "p.csv"))
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "granavg: error: --threads '0': give a whole number of threads, 1 or more (this "
        f"machine has {threads.cores()} cores)"]
    assert not (tmp_path / "p.csv").exists()


@pytest.mark.parametrize("given, advised", [(None, "False"), ("1", "True"), ("0", "False")])
def test_the_command_turns_numpys_huge_page_advice_off_unless_set(given, advised):
    """The command's frames are allocated and freed frame after frame: numpy's advice to
    back them with 2 MB pages is off in its process (docs/running-big.md, "Huge pages"),
    unless NUMPY_MADVISE_HUGEPAGE is set; a library user's process is left as it is."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if given is not None:
        env["NUMPY_MADVISE_HUGEPAGE"] = given
    probe = ("import {0}; import numpy; m = getattr(numpy, '_core', None) or numpy.core; "
             "print(m.multiarray._set_madvise_hugepage(True))")
    out = subprocess.run([sys.executable, "-c", probe.format("granavg.cli")], env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == [advised]
    library = subprocess.run([sys.executable, "-c", probe.format("granavg.engine")],
                             env=env, capture_output=True, text=True, check=True).stdout.split()
    assert library == ["True" if given != "0" else "False"]
