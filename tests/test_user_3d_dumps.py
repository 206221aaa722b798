"""Other people's 3D runs, as LAMMPS' own examples write them (issue 36): real LAMMPS
runs of two decks that are not granavg's, with the example's dump settings - `dump
custom id type mass radius x y z vx vy vz` (no angular velocities), no `dump_modify
units`, default %g floats, `pp pp fm` box bounds, a first frame with no atom:

- tests/decks/pour_3d_lj.lmp: spheres poured into a laterally periodic column;
- tests/decks/tilted_lj.lmp: spheres (3D) or disks (2D) in a periodic tilted box.

Each class of defect found on such input holds on a test of its own: what the data lack
narrows "all the data allow" (one log line) or refuses a request for it (one line);
tilted boxes are averaged in their own cell (sum rules, LAMMPS' virial) or refused where
cells would not fit them; every float option is finite; the outputs of one command
appear together or not at all (a full disk by a file-size limit, signals); signals and
refusals with --workers are one line; and the messages say why, name the option, the
file of a series, and refuse options that do not apply."""

import logging
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from granavg.cli import _finite, _parser
from granavg.io.profiles_io import read_profiles

from .helpers import MAP3, cli, frame_lines as frames, last_rows, run_user_deck

NO_FT = "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],force=c_pl[5]"
MAP2 = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[5],"
        "ftx=c_pl[6],fty=c_pl[7]")
#: LAMMPS' default %g: 6 significant digits, compared with margin.
PRINTED = 1e-4


@pytest.fixture(scope="module")
def pour(tmp_path_factory):
    """600 spheres poured and settled: 101 frames, the first before any insertion."""
    out = tmp_path_factory.mktemp("pour")
    run_user_deck("pour_3d_lj.lmp", out, steps=50000, every=500)
    return out


@pytest.fixture(scope="module")
def tilted(tmp_path_factory):
    """The tilted boxes (xy = ly / 2), 3D and 2D, x y z and scaled xs ys zs: {(dim,
    scaled): (directory, the last frame's pair pressure)}."""
    out = {}
    for dim in (3, 2):
        for scaled in ("no", "yes"):
            d = tmp_path_factory.mktemp(f"tilted{dim}{scaled}")
            last = run_user_deck("tilted_lj.lmp", d, dim=dim, scaled=scaled)
            out[dim, scaled] = (d, last["c_p"])
    return out


@pytest.fixture(autouse=True)
def info_lines(caplog):
    """granavg's information lines, as the command logs them."""
    caplog.set_level(logging.INFO, logger="granavg")


def refused(capsys, tmp_path, args, *needles):
    """Exit 2, exactly one error line holding every needle, nothing written, no
    traceback."""
    code, err = cli(capsys, *args)
    errors = [ln for ln in err if "error:" in ln]
    assert code == 2 and len(errors) == 1, err
    for n in needles:
        assert str(n) in errors[0], (n, errors[0])
    assert not any("Traceback" in ln or "np.float64" in ln for ln in err), err
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("p.csv")]
    return errors[0]


def pour_args(pour, out, *extra, contacts=True, cmap=MAP3):
    more = ("--contacts", pour / "contacts.dump", "--contact-columns", cmap) if contacts else ()
    return ("average", "--atoms", pour / "atoms.dump", *more, "--dt", 0.001, "--out", out,
            "--no-progress", *extra)


def drop_columns(src, dest, names):
    """A copy of a real dump without some columns (as a dump that never had them)."""
    out, keep = [], None
    for ln in Path(src).read_text().splitlines(keepends=True):
        if ln.startswith("ITEM:"):
            keep = None
            if ln.startswith("ITEM: ATOMS"):
                cols = ln.split()[2:]
                keep = [k for k, c in enumerate(cols) if c not in names]
                ln = "ITEM: ATOMS " + " ".join(cols[k] for k in keep) + "\n"
            out.append(ln)
        elif keep is None:
            out.append(ln)
        else:
            cells = ln.split()
            out.append(" ".join(cells[k] for k in keep) + "\n")
    Path(dest).write_text("".join(out))
    return dest


# -- 1. what the data lack narrows "all the data allow" -----------------------------------

def test_a_pour_without_spin_averages_everything_else_and_says_so(capsys, caplog, pour,
                                                                 tmp_path):
    """No --quantities: exit 0, one log line naming what was left out and why, the sidecar
    too; the others are as computed alone; the slab stress carries the weight above in
    the bulk to 1%; the spheres' volume is all in the slabs (sum rule)."""
    code, err = cli(capsys, *pour_args(pour, tmp_path / "all.csv", "--slabs", "z", "--range",
                                       0, 10, "--bins", 5, "--gravity", 0, 0, -1,
                                       "--t-min", 30))
    assert code == 0, err
    said = [m for m in caplog.messages if "left out" in m]
    assert len(said) == 1 and "omega (no omegax omegay omegaz)" in said[0], said
    p = read_profiles(tmp_path / "all.csv")
    assert "omega_x" not in p.values and "sigma_zz" in p.values and "dsigma_zz" in p.values
    spinning = ("omega", "dmu", "spin_density", "erot", "temperature_rot", "contact_power",
                "wall_power", "lever_power")
    assert p.meta["left_out"] == {q: "no omegax omegay omegaz in the data" for q in spinning}
    # the couple stress, the forces' moments and the translational energy are there
    assert "mu_zx" in p.values and "lever_z" in p.values and "temperature" in p.values
    assert "mx" in p.meta["taken_as_zero"]
    code, _ = cli(capsys, *pour_args(pour, tmp_path / "few.csv", "--slabs", "z", "--range",
                                     0, 10, "--bins", 5, "--t-min", 30, "--quantities",
                                     "nu,sigma"))
    q = read_profiles(tmp_path / "few.csv")
    for name in ("nu", "sigma_zz", "sigma_xz"):
        assert np.array_equal(p.values[name], q.values[name])
    rows, cols = last_rows(pour / "atoms.dump")
    z, a, m = (rows[:, cols.index(c)] for c in ("z", "radius", "mass"))
    above = []
    for lo, hi in zip(p.cells.edges[:-1], p.cells.edges[1:]):
        cuts = lo + (np.arange(400) + 0.5) / 400 * (hi - lo)
        u = np.clip((cuts[:, None] - z[None, :]) / a[None, :], -1, 1)
        above.append(np.mean(((1 - u) ** 2 * (2 + u) / 4) @ m))      # g = 1
    carried = -p.values["sigma_zz"] * 64.0 / np.array(above)          # box 8 x 8
    assert np.all(np.abs(carried[1:3] - 1) < 0.01), carried           # the floor's slab: no
    assert abs(carried[0] - 1) > 0.1, carried                         # floor rows (wall/gran)
    assert abs(np.sum(p.values["nu"] * p.cells.volume) /
               np.sum(4 / 3 * np.pi * a ** 3) - 1) < 1e-3   # at rest; a sliver below z = 0


def test_asking_for_what_the_data_lack_is_refused_in_one_line(capsys, pour, tmp_path):
    refused(capsys, tmp_path, pour_args(pour, tmp_path / "p.csv", "--slabs", "z",
                                        "--quantities", "nu,omega"),
            "omega needs the atom column omegax", "--quantities")


def test_contacts_without_tangential_forces(capsys, caplog, pour, tmp_path):
    """A map without ftx fty ftz: the quantities that need them are left out (said),
    and asked for, refused; none is computed with a zero friction in their place."""
    code, err = cli(capsys, *pour_args(pour, tmp_path / "n.csv", "--slabs", "z",
                                       cmap=NO_FT))
    assert code == 0
    said = [m for m in caplog.messages if "left out" in m]
    assert "sigma (no ftx fty ftz)" in said[0] and "boundary (no ftx fty ftz)" in said[0]
    p = read_profiles(tmp_path / "n.csv")
    assert "sigma_zz" not in p.values and "F_zz" in p.values and "eps_zz" in p.values
    refused(capsys, tmp_path, pour_args(pour, tmp_path / "p.csv", "--slabs", "z",
                                        "--quantities", "sigma", cmap=NO_FT),
            "sigma needs the contact column ftx")


def test_a_dump_without_velocities_or_masses(capsys, caplog, pour, tmp_path):
    bare = drop_columns(pour / "atoms.dump", tmp_path / "bare.dump", {"vx", "vy", "vz", "mass"})
    code, err = cli(capsys, "average", "--atoms", bare, "--dt", 0.001, "--slabs", "z",
                    "--out", tmp_path / "b.csv", "--no-progress")
    assert code == 0, err
    p = read_profiles(tmp_path / "b.csv")
    assert set(p.values) == {"nu"}                       # no velocities, no masses
    said = [m for m in caplog.messages if "left out" in m][0]
    assert "v (no vx vy vz)" in said
    refused(capsys, tmp_path, ("average", "--atoms", bare, "--dt", 0.001, "--slabs", "z",
                               "--quantities", "v", "--out", tmp_path / "p.csv"),
            "v needs the atom column vx")


# -- 2. tilted boxes -----------------------------------------------------------------------

@pytest.mark.parametrize("dim, axis", [(3, "y"), (3, "z"), (2, "y")])
@pytest.mark.parametrize("scaled", ["no", "yes"])
def test_slabs_in_a_tilted_box_hold_every_particle_and_lammps_virial(capsys, tilted, tmp_path,
                                                                    dim, axis, scaled):
    """Slabs across an axis the tilt does not shift, in the box's own cell: sum nu V is
    the particles' volume to 1e-10 (images across the periodic faces, volumes of the
    real cell, not of its bounding box - a third larger at this tilt), and the summed
    stress trace is LAMMPS' pair virial of the same frame to the dump's precision."""
    d, pressure = tilted[dim, scaled]
    extra = ("--thickness", 1.0) if dim == 2 else ()
    code, err = cli(capsys, "average", "--atoms", d / "atoms.dump", "--contacts",
                    d / "contacts.dump", "--contact-columns", MAP3 if dim == 3 else MAP2,
                    "--dt", 0.0005, "--t-min", 3, "--slabs", axis, "--bins", 4,
                    "--out", tmp_path / "s.csv", "--no-progress", *extra)
    assert code == 0, err
    p = read_profiles(tmp_path / "s.csv")
    rows, cols = last_rows(d / "atoms.dump")
    a = rows[:, cols.index("radius")]
    volume = np.sum(4 / 3 * np.pi * a ** 3) if dim == 3 else np.sum(np.pi * a ** 2)
    assert p.n_frames == 1
    assert abs(np.sum(p.values["nu"] * p.cells.volume) / volume - 1) < 1e-10
    cell = 512.0 if dim == 3 else 80.0                     # lx ly lz (2D: lx ly, h = 1)
    assert abs(p.cells.volume.sum() - cell) < 1e-9
    trace = sum(np.sum(p.values[f"sigma_{c}{c}"] * p.cells.volume) for c in "xyz"[:dim])
    assert abs(trace / (-dim * pressure * cell) - 1) < PRINTED


def test_a_tilted_box_wraps_atoms_by_its_own_edge_vectors(capsys, tilted, tmp_path):
    """Atoms moved by the box's edge vector b = (xy, ly, 0) (as unwrapped or not yet
    re-neighboured coordinates are) are wrapped back: the same profiles."""
    d, _ = tilted[3, "no"]
    lines = (d / "atoms.dump").read_text().splitlines(keepends=True)
    head = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")][-1]
    for k in range(head + 1, len(lines), 3):
        c = lines[k].split()
        c[4], c[5] = repr(float(c[4]) + 4.0), repr(float(c[5]) + 8.0)    # + b
        lines[k] = " ".join(c) + "\n"
    moved = tmp_path / "moved.dump"
    moved.write_text("".join(lines))
    for name, atoms in (("a", d / "atoms.dump"), ("b", moved)):
        assert cli(capsys, "average", "--atoms", atoms, "--dt", 0.0005, "--t-min", 3,
                   "--slabs", "y", "--bins", 4, "--out", tmp_path / f"{name}.csv",
                   "--no-progress")[0] == 0
    a, b = (read_profiles(tmp_path / f"{n}.csv") for n in "ab")
    assert np.allclose(a.values["nu"], b.values["nu"], rtol=1e-12, atol=0)


@pytest.mark.parametrize("extra", [("--slabs", "x", "--bins", 4), ("--grid", 2, 2, 2),
                                   ("--grid", 2, 2, 2, "--x-range", 0, 8, "--y-range", 0, 8,
                                    "--z-range", 0, 8)])
def test_cells_of_a_tilted_box_hold_every_particle(capsys, tilted, tmp_path, extra):
    """Cells across the tilt's direction and grids, in the brick of the tilted box (its
    own lengths from its lower corner, which tiles space as the box does): sum nu V is
    the particles' volume to 1e-10 (each particle counted once, through the images of
    the sheared faces: a particle in the parallelepiped's corner beyond the brick is
    folded in), and the cells' volume is the box's."""
    d, _ = tilted[3, "no"]
    code, err = cli(capsys, "average", "--atoms", d / "atoms.dump", "--dt", 0.0005,
                    "--t-min", 3, "--out", tmp_path / "p.csv", "--no-progress", *extra)
    assert code == 0, err
    p = read_profiles(tmp_path / "p.csv")
    rows, cols = last_rows(d / "atoms.dump")
    a = rows[:, cols.index("radius")]
    assert abs(np.sum(p.values["nu"] * p.cells.volume) / np.sum(4 / 3 * np.pi * a ** 3)
               - 1) < 1e-10
    assert abs(p.cells.volume.sum() - 512.0) < 1e-9


def test_cells_beyond_a_tilted_box_are_refused(capsys, tilted, tmp_path):
    """A range over the tilted box's bounding box (x 0 12 at xy 4) would repeat the
    packing: refused in one line, naming the box's own span."""
    d, _ = tilted[3, "no"]
    refused(capsys, tmp_path, ("average", "--atoms", d / "atoms.dump", "--dt", 0.0005,
                               "--grid", 2, 2, 2, "--x-range", 0, 12, "--out",
                               tmp_path / "p.csv"), "--x-range 0 12",
            "periodic along x over 0 8")


def _tilted_by(path, xy: float) -> Path:
    """Two frames of 40 disks in a periodic unit square whose header says the box is
    tilted by ``xy`` (a box deformed from zero tilt writes 1e-14 at its first frame)."""
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 1, 40), rng.uniform(0, 1, 40)
    with open(path, "w") as f:
        for step in (0, 100):
            f.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n40\n"
                    f"ITEM: BOX BOUNDS xy xz yz pp pp pp\n0 1 {xy:g}\n0 1 0\n"
                    "-0.05 0.05 0\nITEM: ATOMS id type radius x y z vx vy vz\n")
            f.writelines(f"{i + 1} 1 0.03 {x[i]:.6f} {y[i]:.6f} 0 0.1 0 0\n"
                         for i in range(40))
    return path


@pytest.mark.parametrize("cells", [("--grid", 2, 2), ("--slabs", "x", "--bins", 4)])
def test_a_tilt_within_round_off_is_none(capsys, tmp_path, cells):
    """A tilt of 1.4e-14 (a sheared box's first frame) is no tilt: the fields are those
    of the same dump written untilted; a tilt of 1e-6 of the box (a sheared box a moment
    later) is one: its images across the y faces move by it, and the fields differ."""
    common = ("--thickness", 0.1, "--density", 1, "--dt", 1, *cells)
    out = {}
    for xy in (1.4e-14, 0.0, 1e-6):
        out[xy] = tmp_path / f"f{xy:g}.csv"
        code, err = cli(capsys, "average", "--atoms", _tilted_by(tmp_path / f"a{xy:g}", xy),
                        *common, "--out", out[xy])
        assert code == 0, err
    assert out[1.4e-14].read_text() == out[0.0].read_text()
    assert out[1e-6].read_text() != out[0.0].read_text()


# -- 3. every float option is finite -------------------------------------------------------

def float_options():
    """Every option of every command that takes floats."""
    parser = _parser()
    subs = next(a for a in parser._actions if a.dest == "command").choices
    return sorted({(cmd, a.option_strings[-1], a.nargs if isinstance(a.nargs, int) else 1)
                   for cmd, sub in subs.items() for a in sub._actions
                   if a.type is _finite})


@pytest.mark.parametrize("cmd, flag, n", float_options())
@pytest.mark.parametrize("word", ["nan", "inf", "NaN", "Infinity"])
def test_no_float_option_takes_nan_or_inf(capsys, tmp_path, cmd, flag, n, word):
    args = [cmd, flag, *([word] * n), "--out", tmp_path / "p.csv"]
    if cmd == "average":
        args += ["--atoms", tmp_path / "none.dump"]
    refused(capsys, tmp_path, args, flag, f"'{word}': give a finite number")


def test_the_float_options_are_found():
    found = {f for _, f, _ in float_options()}
    assert {"--gravity", "--dt", "--t-min", "--block-time", "--thickness", "--density",
            "--range", "--x-range", "--z-range", "--r-range", "--center", "--edges",
            "--area", "--length"} <= found


# -- 4. the outputs are one set ------------------------------------------------------------

ALL = ("", ".json", ".replicates.npz", ".nc", ".vtu")


def test_netcdf_and_vtk_into_directories_that_do_not_exist(capsys, pour, tmp_path):
    out = tmp_path / "a" / "b" / "p.csv"
    code, err = cli(capsys, *pour_args(pour, out, "--grid", 2, 2, 2, "--z-range", 0, 8,
                                       "--netcdf", "--vtk"))
    assert code == 0, err
    assert all(out.with_name(out.name + s).is_file() for s in ALL)
    assert [p.name for p in out.parent.iterdir() if p.name.startswith(".")] == []


def test_a_full_disk_is_one_line_and_leaves_nothing(pour, tmp_path):
    """A file-size limit (as a full disk): exit 2, one line naming the file, no output
    of the set and no directory it made."""
    out = tmp_path / "made" / "p.csv"

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))
    proc = subprocess.run([sys.executable, "-m", "granavg",
                           *map(str, pour_args(pour, out, "--grid", 4, 4, 4, "--z-range", 0,
                                               8, "--netcdf", "--vtk"))],
                          capture_output=True, text=True, preexec_fn=limit, timeout=300)
    errors = [ln for ln in proc.stderr.splitlines() if "error:" in ln]
    assert proc.returncode == 2 and len(errors) == 1, proc.stderr
    assert "file too large" in errors[0] and "nothing written" in errors[0]
    assert "Traceback" not in proc.stderr
    assert not out.parent.exists()


def test_a_signal_during_the_renames_leaves_the_whole_set(capsys, pour, tmp_path, monkeypatch):
    """SIGTERM right after the first output got its final name: the renames go on (the
    signal waits for them), every output exists, and the message says they are complete."""
    from granavg.io import output_set
    real, calls = os.replace, []

    def replace(src, dst):
        real(src, dst)
        calls.append(dst)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGTERM)
    monkeypatch.setattr(output_set.os, "replace", replace)
    out = tmp_path / "s.csv"
    code, err = cli(capsys, *pour_args(pour, out, "--grid", 2, 2, 2, "--z-range", 0, 8,
                                       "--netcdf", "--vtk"))
    assert code == 143 and len(calls) == len(ALL)
    assert all(out.with_name(out.name + s).is_file() for s in ALL)
    assert any("the outputs were complete before it" in ln for ln in err), err


def test_a_signal_before_the_renames_leaves_nothing(capsys, pour, tmp_path, monkeypatch):
    from granavg.io import field_files
    real = field_files.write_netcdf

    def write(profiles, path):
        real(profiles, path)
        os.kill(os.getpid(), signal.SIGTERM)
    monkeypatch.setattr(field_files, "write_netcdf", write)
    out = tmp_path / "s.csv"
    code, err = cli(capsys, *pour_args(pour, out, "--grid", 2, 2, 2, "--z-range", 0, 8,
                                       "--netcdf", "--vtk"))
    assert code == 143 and any("nothing written" in ln for ln in err)
    assert list(tmp_path.iterdir()) == []


# -- 5. signals and refusals with --workers ------------------------------------------------

@pytest.fixture(scope="module")
def long_series(pour, tmp_path_factory):
    """A series of 80 files of the pour's settled frames (its last frame, at later
    steps): long enough to be stopped by a signal with --workers (on 8 x 8 x 8 boxes
    about 10 s here; on 4 x 4 x 4 boxes 4.8 s, as long as the later signal's delay)."""
    d = tmp_path_factory.mktemp("series")
    last = "".join(frames(pour / "atoms.dump")[-1][2:])
    for f in range(80):
        with open(d / f"atoms.{f * 50000}.txt", "w") as fh:
            for k in range(50):
                fh.write(f"ITEM: TIMESTEP\n{f * 50000 + k * 1000}\n{last}")
    return d


def dask_average(series, out, *extra):
    return [sys.executable, "-m", "granavg", "average", "--atoms", str(series / "atoms.*.txt"),
            "--dt", "0.001", "--grid", "8", "8", "8", "--z-range", "0", "8", "--out",
            str(out), "--no-progress", "--workers", "2", *extra]


@pytest.mark.slow
@pytest.mark.parametrize("delay", [1.0, 4.0])
def test_sigterm_with_workers_is_one_line_and_quick(long_series, tmp_path, delay):
    proc = subprocess.Popen(dask_average(long_series, tmp_path / "p.csv"),
                            stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    assert proc.poll() is None, "finished before the signal: make the series longer"
    sent = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    took = time.monotonic() - sent
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "granavg: interrupted; nothing written", err
    for noise in ("Traceback", "Task exception", "distributed", "CancelledError", "AllExit"):
        assert noise not in err, err
    assert took < 6, took
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_a_workers_refusal_of_a_damaged_file_is_one_line(long_series, tmp_path):
    bad = tmp_path / "series"
    bad.mkdir()
    for f in long_series.iterdir():
        (bad / f.name).write_bytes(f.read_bytes())
    victim = sorted(bad.iterdir(), key=lambda p: int(p.name.split(".")[1]))[30]
    lines = victim.read_text().splitlines(keepends=True)
    lines[20] = lines[20].replace(lines[20].split()[4], "oops", 1)
    victim.write_text("".join(lines))
    proc = subprocess.run(dask_average(bad, tmp_path / "p.csv"), capture_output=True,
                          text=True, timeout=300)
    errors = [ln for ln in proc.stderr.splitlines() if "error:" in ln]
    assert proc.returncode == 2 and len(errors) == 1, proc.stderr
    assert f"{victim}:21:" in errors[0] and "'oops' is not a number" in errors[0]
    for noise in ("Traceback", "distributed", "Compute Failed"):
        assert noise not in proc.stderr, proc.stderr


# -- 6. messages that say why, name the option and the file --------------------------------

def test_an_empty_first_frame_does_not_make_a_pour_2d(capsys, pour, tmp_path):
    """The pour's first frame holds no sphere; the dimension comes from the first that
    does."""
    assert frames(pour / "atoms.dump")[0][3].strip() == "0"
    code, err = cli(capsys, *pour_args(pour, tmp_path / "d.csv", "--slabs", "z",
                                       contacts=False))
    assert code == 0, err
    assert read_profiles(tmp_path / "d.csv").meta["inputs"]["dim"] == 3


def test_the_dimension_is_told_from_the_first_rows_where_their_z_differ(tmp_path,
                                                                       monkeypatch):
    """A 3D dump is known as one from its first frame's first rows (their z differ), its
    rows not parsed for it (plain and gzip); where those rows share one z the whole
    frame is read, and a z that differs further on still makes it 3D."""
    import gzip

    from granavg.io import dump_columns, text_scan

    n = dump_columns.Z_SAMPLE + 50

    def dump(name, z):
        rows = "".join(f"{k + 1} {k * 0.01:g} 0.5 {z[k]:g} 0.004\n" for k in range(n))
        text = (f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS pp pp ff\n"
                f"0 11\n0 1\n0 1\nITEM: ATOMS id x y z radius\n{rows}")
        path = tmp_path / name
        if name.endswith(".gz"):
            path.write_bytes(gzip.compress(text.encode()))
        else:
            path.write_text(text)
        return path
    parsed = []
    rows = text_scan.TextScanner._rows
    monkeypatch.setattr(text_scan.TextScanner, "_rows",
                        lambda self, *a: parsed.append(1) or rows(self, *a))
    varied = np.random.default_rng(0).uniform(0.1, 0.9, n)
    for name in ("varied.dump", "varied.dump.gz"):
        assert dump_columns.dimension(dump(name, varied), {}) == (3, "z differs")
        assert parsed == [], name
    late = np.where(np.arange(n) < dump_columns.Z_SAMPLE, 0.0, 0.5)
    assert dump_columns.dimension(dump("late.dump", late), {}) == (3, "z differs")
    assert parsed
    parsed.clear()
    dim, why = dump_columns.dimension(dump("flat.dump", np.zeros(n)), {})
    assert dim == 2 and "has z = 0" in why and parsed


def test_2d_says_why_when_it_asks_for_the_thickness(capsys, pour, tilted, tmp_path):
    flat = drop_columns(pour / "atoms.dump", tmp_path / "flat.dump", {"z", "vz"})
    refused(capsys, tmp_path, ("average", "--atoms", flat, "--dt", 0.001, "--slabs", "y",
                               "--out", tmp_path / "p.csv"),
            "--thickness", "has no z column")
    d, _ = tilted[2, "no"]
    refused(capsys, tmp_path, ("average", "--atoms", d / "atoms.dump", "--dt", 0.001,
                               "--slabs", "y", "--out", tmp_path / "p.csv"),
            "--thickness", "has z = 0", "--dim 3")


def edit_row(src, dest, frame, row, column, value):
    """A copy of a real dump with one value replaced; the 1-based line of the edit."""
    lines = Path(src).read_text().splitlines(keepends=True)
    starts = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")]
    k = starts[frame] + 1 + row
    cells = lines[k].split()
    cells[lines[starts[frame]].split()[2:].index(column)] = value
    lines[k] = " ".join(cells) + "\n"
    Path(dest).write_text("".join(lines))
    return dest, k + 1


@pytest.mark.parametrize("value, needle", [("none", "'none' is not a number"),
                                           ("n/a", "'n/a' is not a number"),
                                           ("nan", "NaN or inf"), ("-inf", "NaN or inf")])
def test_words_are_not_read_as_nan(capsys, pour, tmp_path, value, needle):
    bad, line = edit_row(pour / "atoms.dump", tmp_path / "w.dump", 20, 5, "vx", value)
    refused(capsys, tmp_path, ("average", "--atoms", bad, "--dt", 0.001, "--slabs", "z",
                               "--out", tmp_path / "p.csv"), f"{bad}:{line}:", needle)


@pytest.mark.parametrize("value", ["9007199254740993", "12345678901234567890"])
def test_ids_beyond_2_to_the_53_are_refused_honestly(capsys, pour, tmp_path, value):
    bad, line = edit_row(pour / "atoms.dump", tmp_path / "i.dump", 20, 5, "id", value)
    refused(capsys, tmp_path, ("average", "--atoms", bad, "--dt", 0.001, "--slabs", "z",
                               "--out", tmp_path / "p.csv"), f"{bad}:{line}:", "2^53",
            "renumber")


@pytest.mark.parametrize("extra, needle", [
    (("--slabs", "z", "--range", 6, 2), "--range 6 2: the first must be below"),
    (("--grid", 2, 2, 2, "--x-range", 3, -3), "--x-range 3 -3"),
    (("--grid", 2, 2, 2, "--z-range", 5, 5), "--z-range 5 5"),
    (("--r-range", 4, 1), "--r-range 4 1"),
    (("--r-range", -1, 1), "--r-range -1 1: radii are >= 0"),
    (("--slabs", "z", "--dt", 0), "--dt 0: must be a finite number > 0"),
    (("--slabs", "z", "--dt", -0.5), "--dt -0.5"),
    (("--slabs", "z", "--area", 0), "--area 0"),
    (("--slabs", "z", "--layers", 2), "--layers does not apply to 3D slabs"),
    (("--slabs", "z", "--center", 0, 0), "--center does not apply to 3D slabs"),
    (("--slabs", "z", "--x-range", 0, 1), "--x-range does not apply to 3D slabs"),
    (("--grid", 2, 2, 2, "--range", 0, 1), "--range does not apply to a box grid"),
    (("--grid", 2, 2, 2, "--bins", 3), "--bins does not apply to a box grid"),
    (("--r-range", 0, 3, "--area", 2), "--area does not apply to cylindrical shells"),
    (("--grid", 2, 2, 2, "--sectors", 8), "--sectors 8: boxes have no direction"),
    (("--slabs", "z", "--sectors", 49), "--sectors 49: give auto, off or a number of "
                                        "sectors from 4 to 48"),
    (("--slabs", "z", "--atom-columns", "omega=vx"), "no atom column 'omega'"),
    (("--slabs", "z", "--vtk"), "--vtk: slabs3d are not a grid"),
    (("--slabs", "z", "--scheduler", "nonsense"), "--scheduler nonsense: cannot reach it"),
])
def test_options_are_named_and_those_that_do_not_apply_refused(capsys, pour, tmp_path, extra,
                                                               needle):
    refused(capsys, tmp_path, pour_args(pour, tmp_path / "p.csv", *extra, contacts=False),
            needle)


def test_a_contact_map_needs_a_contact_dump(capsys, pour, tmp_path):
    refused(capsys, tmp_path, ("average", "--atoms", pour / "atoms.dump", "--dt", 0.001,
                               "--slabs", "z", "--contact-columns", MAP3, "--out",
                               tmp_path / "p.csv"), "--contact-columns", "--contacts")


def test_the_sectors_help_says_the_bounds_the_check_applies():
    from granavg.engine.uncertainty import structure as replicas
    sub = next(a for a in _parser()._actions if a.dest == "command").choices["average"]
    text = next(a.help for a in sub._actions if a.dest == "sectors")
    assert f"from {replicas.MIN_REPLICAS} to {replicas.MAX_SECTORS}" in text


@pytest.fixture
def pour_series(pour, tmp_path):
    """The pour's atom dump as a series of one file per frame (dump atoms.*.txt)."""
    d = tmp_path / "series"
    d.mkdir()
    for f in frames(pour / "atoms.dump"):
        (d / f"atoms.{int(f[1])}.txt").write_text("".join(f))
    return d


def test_a_series_error_names_the_file_that_holds_the_line(capsys, pour_series, tmp_path):
    victim = pour_series / "atoms.30000.txt"
    bad, line = edit_row(victim, victim, 0, 3, "radius", "-1")
    refused(capsys, tmp_path, ("average", "--atoms", pour_series / "atoms.*.txt", "--dt",
                               0.001, "--slabs", "z", "--out", tmp_path / "p.csv"),
            f"{victim}:{line}:", "radius -1 is not positive")


def test_an_empty_file_in_a_series_is_warned_and_passed_over(capsys, caplog, pour_series,
                                                            tmp_path):
    args = ("average", "--atoms", pour_series / "atoms.*.txt", "--dt", 0.001, "--slabs", "z",
            "--no-progress")
    assert cli(capsys, *args, "--out", tmp_path / "a.csv")[0] == 0
    (pour_series / "atoms.30000.txt").write_text("")
    code, err = cli(capsys, *args, "--out", tmp_path / "b.csv")
    assert code == 0
    assert any("atoms.30000.txt: holds no complete frame" in m for m in caplog.messages)
    a, b = (read_profiles(tmp_path / f"{n}.csv") for n in "ab")
    assert b.n_frames == a.n_frames - 1
