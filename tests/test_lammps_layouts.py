"""LAMMPS' other dump layouts: binary dumps (granavg.io.binary_dump), ``dump yaml``
(granavg.io.yaml_dump) and dumps written one file per processor (a ``%`` in the name).
The 3D pile deck writes its atom dump as text with 17 digits, in LAMMPS' binary layout
(``-var binary yes``) and as YAML with 17 digits (``-var yaml yes``), and on two MPI
ranks also one file per rank (``-var perproc yes``); every layout reads as the same frames
and averages to the same fields bit for bit, through the API, the command line and
dask; a cut or an old-layout binary file, and a dump local split over processors (whose
headers LAMMPS writes to the first file alone), are said in one line."""

import subprocess

import numpy as np
import pytest

import granavg
from granavg.io.dump_columns import dump_header
from granavg.io.reader import DumpReader

from .helpers import MAP3, PILE3D_DECK, run_cli, run_pile3d

pytestmark = pytest.mark.slow

CMAP = dict(kv.split("=") for kv in MAP3.split(","))
SLABS = {"slabs": "z", "range": (0.0, 0.03), "bins": 6}


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    out = tmp_path_factory.mktemp("binary") / "pile"
    run_pile3d(out, precise="yes", floor="spheres", binary="yes", yaml="yes")
    return out


def _fields(atoms, pile, **extra):
    return granavg.average(atoms, contacts=pile / "contacts.dump", contact_map=CMAP,
                           gravity=(0, 0, -9.81), wall_types=[3], cells=SLABS, **extra)


def test_the_binary_frames_are_the_text_frames(pile):
    names, units = dump_header(pile / "atoms.bin")
    assert names == dump_header(pile / "atoms.dump")[0] and units[0] == "si"
    text, binary = list(DumpReader(pile / "atoms.dump")), list(DumpReader(pile / "atoms.bin"))
    assert len(binary) == len(text) == 11
    for t, b in zip(text, binary):
        assert (b.timestep, b.columns, b.boundary) == (t.timestep, t.columns, t.boundary)
        assert b.time == pytest.approx(t.time, rel=1e-12)    # the text's is %g
        assert np.array_equal(b.box, t.box) and np.array_equal(b.data, t.data)
    some = list(DumpReader(pile / "atoms.bin", ["x", "fz"], steps=(45500, 47000)))
    assert [f.timestep for f in some] == [45500, 46000, 46500, 47000]
    assert some[0].columns == ["x", "fz"] and some[0].data.shape[1] == 2
    heads = list(DumpReader(pile / "atoms.bin", [], headers_only=True))
    assert len(heads) == 11 and heads[0].data.shape == (text[0].data.shape[0], 0)


def test_the_binary_dump_averages_to_the_same_fields_on_every_route(pile, tmp_path):
    text = _fields(pile / "atoms.dump", pile, t_min=0.46)
    binary = _fields(pile / "atoms.bin", pile, t_min=0.46)
    assert binary.n_frames == text.n_frames == 9
    for k in text.values:
        assert np.array_equal(binary.values[k], text.values[k], equal_nan=True), k
        assert np.array_equal(binary.sem[k], text.sem[k], equal_nan=True), k
    proc = run_cli("average", "--atoms", pile / "atoms.bin", "--contacts",
                   pile / "contacts.dump", "--contact-columns", MAP3, "--gravity", 0, 0, -9.81,
                   "--wall-types", 3, "--slabs", "z", "--range", 0, 0.03, "--bins", 6,
                   "--t-min", 0.46, "--out", tmp_path / "b.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    cli = granavg.read(tmp_path / "b.csv")
    assert np.allclose(cli.values["sigma_zz"], text.values["sigma_zz"], rtol=1e-9, atol=0)
    pytest.importorskip("distributed")
    dask = _fields(pile / "atoms.bin", pile, t_min=0.46, workers=2)
    for k in text.values:
        assert np.allclose(dask.values[k], text.values[k], rtol=1e-12, atol=0,
                           equal_nan=True), k


def test_a_dump_yaml_is_the_text_dump(pile, tmp_path, caplog):
    names, units = dump_header(pile / "atoms.yaml")
    assert names == dump_header(pile / "atoms.dump")[0] and units[0] == "si"
    text, yaml = list(DumpReader(pile / "atoms.dump")), list(DumpReader(pile / "atoms.yaml"))
    assert len(yaml) == len(text) == 11
    for t, y in zip(text, yaml):
        assert (y.timestep, y.time, y.columns, y.boundary) == (t.timestep, t.time, t.columns,
                                                               t.boundary)
        assert np.array_equal(y.box, t.box) and np.array_equal(y.data, t.data)
    some = list(DumpReader(pile / "atoms.yaml", ["x"], steps=(45500, 46500)))
    assert [f.timestep for f in some] == [45500, 46000, 46500]
    plain = _fields(pile / "atoms.dump", pile, t_min=0.46)
    fields = _fields(pile / "atoms.yaml", pile, t_min=0.46)
    for k in plain.values:
        assert np.array_equal(fields.values[k], plain.values[k], equal_nan=True), k
    lines = (pile / "atoms.yaml").read_text().splitlines(keepends=True)
    cut = tmp_path / "cut.yaml"
    cut.write_text("".join(lines[:-20]))
    assert len(list(DumpReader(cut))) == 10 and "the last frame is cut" in caplog.text


def test_a_cut_binary_dump_keeps_its_complete_frames(pile, tmp_path, caplog):
    data = (pile / "atoms.bin").read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[:len(data) - 1000])
    frames = list(DumpReader(cut))
    assert len(frames) == 10 and "the last frame is cut" in caplog.text
    (tmp_path / "head.bin").write_bytes(data[:40])
    proc = run_cli("average", "--atoms", tmp_path / "head.bin", "--slabs", "z", "--bins", 2,
                   "--out", tmp_path / "x.csv", "--no-progress")
    assert proc.returncode == 2 and "cut inside its first header" in proc.stderr, proc.stderr


def test_a_binary_dump_without_column_names_is_refused_in_one_line(pile, tmp_path):
    data = bytearray((pile / "atoms.bin").read_bytes())
    data[22:26] = (1).to_bytes(4, "little")            # the format revision: 1, no names
    old = tmp_path / "old.bin"
    old.write_bytes(bytes(data))
    proc = run_cli("average", "--atoms", old, "--slabs", "z", "--bins", 2,
                   "--out", tmp_path / "x.csv", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("granavg: error")]
    assert len(errors) == 1 and "without column names" in errors[0], proc.stderr


@pytest.fixture(scope="module")
def ranks(tmp_path_factory):
    """The bidisperse pile on two MPI ranks, side by side in x: its dumps in one file and
    one file per rank."""
    from granavg.sim.lammps_session import executable, lammps_env

    out = tmp_path_factory.mktemp("ranks")
    proc = subprocess.run([executable("mpirun"), "-np", "2", executable("lmp"), "-in",
                           str(PILE3D_DECK), "-log", str(out / "log.lammps"), "-screen",
                           "none", "-var", "out", str(out), "-var", "precise", "yes",
                           "-var", "floor", "spheres", "-var", "bidisperse", "yes",
                           "-var", "perproc", "yes"], env=lammps_env(),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


def test_a_dump_split_over_processors_is_the_one_file_dump(ranks, tmp_path):
    parts = [p.stat().st_size for p in sorted(ranks.glob("atoms.[0-9].dump"))]
    assert len(parts) == 2 and min(parts) > 0.3 * sum(parts)      # both ranks hold atoms
    one, split = list(DumpReader(ranks / "atoms.dump")), list(DumpReader(ranks / "atoms.%.dump"))
    assert len(split) == len(one) == 11
    for a, b in zip(one, split):
        assert a.timestep == b.timestep and np.array_equal(a.data, b.data)
    kw = dict(contacts=ranks / "contacts.dump", contact_map=CMAP, gravity=(0, 0, -9.81),
              wall_types=[3], cells=SLABS, species="type")
    whole = granavg.average(ranks / "atoms.dump", **kw)
    parted = granavg.average(ranks / "atoms.%.dump", **kw)
    for k in whole.values:
        assert np.array_equal(parted.values[k], whole.values[k], equal_nan=True), k
    proc = run_cli("average", "--atoms", ranks / "atoms.%.dump", "--contacts",
                   ranks / "contacts.%.dump", "--contact-columns", MAP3, "--wall-types", 3,
                   "--slabs", "z", "--bins", 2, "--out", tmp_path / "x.csv", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("granavg: error")]
    assert len(errors) == 1 and "rows without frame headers" in errors[0], proc.stderr
    missing = run_cli("average", "--atoms", ranks / "nothing.%.dump", "--slabs", "z",
                      "--bins", 2, "--out", tmp_path / "y.csv", "--no-progress")
    assert missing.returncode == 2 and "no file matches" in missing.stderr, missing.stderr
