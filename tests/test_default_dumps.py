"""Dumps as LAMMPS writes them by default, from a deck that is not granavg's
(tests/decks/pile_2d_lj.lmp: a 2D pile at rest, lj units, gran/hooke/history, a
fix wall/gran floor, pair/local + property/local contacts, no ``dump_modify format``).

With ``%g`` (6 significant digits) a normal formed as (dx, dy)/dist is off unit length by
up to ~1e-5, which granavg once refused as damage. Here the same dumps are averaged
through every contact format granavg reads, and the stress is held to LAMMPS' own summed
virial to the precision the dump can carry; the outputs are labelled with the dump's
units, never SI by default."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from granavg.io.profiles_io import read_profiles

from .helpers import PILE2D_MAP as MAP, frames, run_cli, run_pile2d

H = 1.0                         # disk height (sigma): the user's choice for a 2D run
#: A number printed with 6 significant digits is off by at most 5e-6 of itself; a
#: contact's term f.n (r1 + r2) multiplies three such numbers (the normal's length is
#: divided out), so a sum of terms is off by at most 1.5e-5 of the sum of their sizes.
PRINTED = 3 * 5e-6


@pytest.fixture(scope="module")
def pile(pile2d_run):
    """The deck with its defaults: (directory, LAMMPS' summed pair virial)."""
    return pile2d_run


def average(atoms, contacts, dest, *extra):
    args = ["average", "--atoms", atoms, "--thickness", H, "--out", dest, "--no-progress",
            "--slabs", "y", "--range", -1, 29, *extra]
    if contacts is not None:
        args[3:3] = ["--contacts", contacts]
    return run_cli(*args)


def test_lammps_default_precision_is_what_the_dump_holds(pile):
    """The premise: LAMMPS' default dump is %g, and |(dx, dy)| / dist - 1 is of the order
    of its rounding, above the 1e-6 once taken as damage and far below 1e-4."""
    out, _ = pile
    dev = max(np.max(np.abs(np.hypot(r[:, 3], r[:, 4]) / r[:, 2] - 1))
              for _, _, r in frames(out / "contacts.dump"))
    assert 1e-6 < dev < PRINTED
    rows = (out / "atoms.dump").read_text().rsplit("ITEM: ATOMS", 1)[1].split()[9:]
    digits = [len(re.sub(r"e.*|[-.]", "", t).lstrip("0")) for t in rows]
    assert max(digits) == 6                                  # %g: 6 significant digits


@pytest.mark.parametrize("branch", ["contact", "paper"])
def test_default_dumps_give_lammps_virial(pile, tmp_path, branch):
    """sum_k V_k tr sigma_k over slabs holding every disk = LAMMPS' summed per-atom pair
    virial of the same frame, to the dump's printed precision: directly with the
    contact-point branch vectors (a pair's l_1 - l_2 is its centre distance, as in the
    virial), plus overlap x f.n per contact with Eq. 5's vectors to the disks'
    surfaces. (Refused as 'not a unit vector' before default precision was read.)"""
    out, virial = pile
    proc = average(out / "atoms.dump", out / "contacts.dump", tmp_path / "s.csv",
                   "--contact-columns", MAP, "--bins", 10, "--t-min", 44.9,
                   "--quantities", "nu,sigma", "--branch", branch)
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(tmp_path / "s.csv")
    assert p.n_frames == 1 and p.meta["branch"] == branch    # the last frame only
    ours = np.sum(p.cells.volume * (p.values["sigma_xx"] + p.values["sigma_yy"]))
    _, _, atoms = frames(out / "atoms.dump")[-1]
    _, _, rows = frames(out / "contacts.dump")[-1]
    radius = dict(zip(atoms[:, 0].astype(int), 0.5 * atoms[:, 2]))
    r1 = np.array([radius[int(i)] for i in rows[:, 0]])
    r2 = np.array([radius[int(i)] for i in rows[:, 1]])
    dist, dx, dy, force, p1, p2 = rows[:, 2:8].T
    nx, ny = -dx / np.hypot(dx, dy), -dy / np.hypot(dx, dy)
    f_dot_n = (-force * nx + p1) * nx + (-force * ny + p2) * ny
    touching = force != 0
    correction = np.sum(((r1 + r2 - dist) * f_dot_n)[touching])
    size = np.sum(np.abs(f_dot_n * (r1 + r2))[touching])
    assert touching.sum() > 300 and (~touching).sum() > 0    # neighbour rows were there
    expected, other = (virial, virial + correction) if branch == "contact" else \
        (virial + correction, virial)
    assert abs(ours - expected) <= PRINTED * size, (ours, expected)
    assert abs(ours - other) > PRINTED * size                # the difference is resolved


def write_frames(path, frames_, columns, rows_of, fmt="%g"):
    """A dump with the given frames' headers, new column names and rows."""
    with open(path, "w") as fh:
        for head, _, rows in frames_:
            item = "ITEM: ENTRIES" if any("ENTRIES" in h for h in head) else "ITEM: ATOMS"
            new = rows_of(rows)
            head = [h if not h[0].isdigit() or k != head.index("ITEM: NUMBER OF ENTRIES") + 1
                    else str(len(new)) for k, h in enumerate(head)] \
                if "ITEM: NUMBER OF ENTRIES" in head else head
            fh.write("\n".join(head) + f"\n{item} {' '.join(columns)}\n")
            fh.write("".join(" ".join(fmt % v for v in r) + "\n" for r in new))


def test_every_contact_format_reads_default_precision(pile, tmp_path):
    """The same contacts as pair/local columns, as the deck's raw columns (fnx fny) and in
    granavg's own format (nx ny overlap), all printed with %g: the same profiles to
    the printed precision."""
    out, _ = pile
    cf = frames(out / "contacts.dump")
    atoms_by_frame = [dict(zip(a[:, 0].astype(int), 0.5 * a[:, 2]))
                      for _, _, a in frames(out / "atoms.dump")]
    raw = tmp_path / "raw.dump"
    write_frames(raw, cf, ["id1", "id2", "dx", "dy", "dist", "fnx", "fny", "ftx", "fty"],
                 lambda r: np.column_stack([r[:, 0], r[:, 1], r[:, 3], r[:, 4], r[:, 2],
                                            r[:, 5] * r[:, 3] / r[:, 2],
                                            r[:, 5] * r[:, 4] / r[:, 2], r[:, 6], r[:, 7]]))
    own = tmp_path / "own.dump"
    frame_no = iter(range(len(cf)))

    def granavg_rows(r):
        radius = atoms_by_frame[next(frame_no)]
        r = r[r[:, 5] != 0]
        n = -r[:, 3:5] / r[:, 2:3]
        ov = np.array([radius[int(a)] + radius[int(b)] for a, b in r[:, :2]]) - r[:, 2]
        return np.column_stack([r[:, 0], r[:, 1], np.zeros(len(r)), -r[:, 5] * n[:, 0],
                                -r[:, 5] * n[:, 1], r[:, 6], r[:, 7], n, ov])
    write_frames(own, cf, ["id1", "id2", "wall", "fnx", "fny", "ftx", "fty", "nx", "ny",
                           "overlap"], granavg_rows)
    results = {}
    for name, contacts, extra in (("map", out / "contacts.dump", ["--contact-columns", MAP]),
                                  ("raw", raw, []), ("own", own, [])):
        proc = average(out / "atoms.dump", contacts, tmp_path / f"{name}.csv", "--bins", 6,
                       "--quantities", "coordination,F,sigma,eps", *extra)
        assert proc.returncode == 0, (name, proc.stderr)
        results[name] = read_profiles(tmp_path / f"{name}.csv")
    ref = results["map"]
    for name in ("raw", "own"):
        for q in ("coordination", "F_xx", "F_yy", "sigma_yy", "sigma_xy", "eps_yy"):
            scale = np.nanmax(np.abs(ref.values[q]))
            assert np.allclose(results[name].values[q], ref.values[q], rtol=1e-4,
                               atol=1e-4 * scale, equal_nan=True), (name, q)


def sidecar(path):
    return json.loads(Path(str(path) + ".json").read_text())


@pytest.mark.slow
def test_units_are_the_dumps_never_si_by_default(pile, tmp_path):
    """No ITEM: UNITS: labelled 'unstated' (dimensions only); --units lj names them;
    a dump that says lj is lj, and --units si against it is refused naming its line."""
    out, _ = pile
    args = (out / "atoms.dump", None)
    proc = average(*args, tmp_path / "a.csv", "--bins", 4)
    assert proc.returncode == 0, proc.stderr
    meta = sidecar(tmp_path / "a.csv")
    assert meta["units"].startswith("unstated") and "SI" not in meta["units"]
    assert meta["columns"]["v_y"] == "length/time" and meta["columns"]["y"] == "length"
    assert "thickness_m" not in meta["inputs"] and "h_m" not in meta["geometry"]
    proc = average(*args, tmp_path / "b.csv", "--bins", 4, "--units", "lj")
    assert proc.returncode == 0, proc.stderr
    meta = sidecar(tmp_path / "b.csv")
    assert meta["units"].startswith("lj") and meta["columns"]["dsigma_yy"] == "epsilon/sigma^3"
    assert meta["columns"]["rho"] == "m/sigma^3" and meta["columns"]["V"] == "sigma^3"

    said = tmp_path / "said"
    run_pile2d(said, units_header="yes")
    text = (said / "atoms.dump").read_text()
    assert text.startswith("ITEM: UNITS\nlj\n") and text.count("ITEM: UNITS") == 1
    proc = average(said / "atoms.dump", None, tmp_path / "c.csv", "--bins", 4)
    assert proc.returncode == 0, proc.stderr
    assert sidecar(tmp_path / "c.csv")["units"].startswith("lj")
    proc = average(said / "atoms.dump", None, tmp_path / "d.csv", "--bins", 4, "--units", "si")
    assert proc.returncode == 2
    assert f"{said / 'atoms.dump'}:2:" in proc.stderr and "units lj" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "d.csv").exists()
    proc = average(said / "atoms.dump", None, tmp_path / "e.csv", "--bins", 4, "--units", "furlong")
    assert proc.returncode == 2 and "furlong" in proc.stderr and "lj" in proc.stderr


def damaged(pile, tmp_path, which, edit):
    """A copy of one of the pile's dumps with one value of the second frame changed by
    ``edit(cells) -> cells``; returns (atoms, contacts, 1-based line of the change)."""
    out, _ = pile
    src = out / f"{which}.dump"
    lines = src.read_text().splitlines(keepends=True)
    heads = [k for k, ln in enumerate(lines) if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES"))]
    k = heads[1] + 1
    while which == "contacts" and float(lines[k].split()[5]) == 0:   # a row with a force
        k += 1
    lines[k] = " ".join(edit(lines[k].split())) + "\n"
    dest = tmp_path / f"{which}.dump"
    dest.write_text("".join(lines))
    files = {"atoms": out / "atoms.dump", "contacts": out / "contacts.dump", which: dest}
    return files["atoms"], files["contacts"], k + 1


@pytest.mark.parametrize("what, edit, needle", [
    ("dist off by 1e-3", lambda c: c[:2] + [repr(float(c[2]) * 1.001)] + c[3:], "dist"),
    ("atom id 336.7", lambda c: c[:1] + ["336.7"] + c[2:], "id2 336.7 is not an integer"),
])
def test_rows_that_are_really_inconsistent_are_refused(pile, tmp_path, what, edit, needle):
    atoms, contacts, line = damaged(pile, tmp_path, "contacts", edit)
    proc = average(atoms, contacts, tmp_path / "p.csv", "--contact-columns", MAP)
    assert proc.returncode == 2, proc.stderr
    assert f"{contacts}:{line}:" in proc.stderr and needle in proc.stderr, proc.stderr
    assert proc.stderr.count("error:") == 1 and "Traceback" not in proc.stderr
    assert not (tmp_path / "p.csv").exists()


def test_an_atom_id_that_is_not_an_integer_names_its_line(pile, tmp_path):
    atoms, _, line = damaged(pile, tmp_path, "atoms", lambda c: ["336.7"] + c[1:])
    proc = average(atoms, None, tmp_path / "p.csv")
    assert proc.returncode == 2
    assert f"{atoms}:{line}: id 336.7 is not an integer" in proc.stderr, proc.stderr


def test_a_force_between_disks_apart_names_the_radius_column(pile, tmp_path):
    """A disk whose diameter is 10% too small: its contacts carry forces across a gap
    that rounding cannot explain."""
    out, _ = pile
    _, _, rows = frames(out / "contacts.dump")[1]
    victim = str(int(rows[rows[:, 5] != 0][0, 0]))          # a disk carrying a force
    lines = (out / "atoms.dump").read_text().splitlines(keepends=True)
    heads = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")]
    k = next(i for i in range(heads[1] + 1, len(lines)) if lines[i].split()[0] == victim)
    cells = lines[k].split()
    lines[k] = " ".join(cells[:2] + [repr(float(cells[2]) * 0.9)] + cells[3:]) + "\n"
    atoms = tmp_path / "atoms.dump"
    atoms.write_text("".join(lines))
    proc = average(atoms, out / "contacts.dump", tmp_path / "p.csv", "--contact-columns", MAP)
    assert proc.returncode == 2, proc.stderr
    assert "carry a normal force but are" in proc.stderr and "diameter" in proc.stderr
    assert f"{out / 'contacts.dump'}:" in proc.stderr and victim in proc.stderr


def test_wall_atoms_of_a_default_dump(pile2d_on_disks, tmp_path):
    """The same pile on a row of fixed type-2 disks (wall atoms whose contacts are in the
    pair/local dump): accepted with --wall-types 2; the packing's area is that of the
    type-1 disks alone, and the disks resting on the floor count its contacts."""
    out = pile2d_on_disks
    proc = average(out / "atoms.dump", out / "contacts.dump", tmp_path / "w.csv",
                   "--contact-columns", MAP, "--bins", 30, "--wall-types", 2,
                   "--quantities", "nu,coordination,sigma")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(tmp_path / "w.csv")
    _, _, atoms = frames(out / "atoms.dump")[-1]
    mobile = atoms[:, 1] == 1
    assert (~mobile).sum() == 20
    area = np.pi * H * np.sum((0.5 * atoms[mobile, 2]) ** 2)
    # time-averaged over frames of a pile at rest: the same disks in every frame
    assert np.sum(p.values["nu"] * p.cells.volume) == pytest.approx(area, rel=1e-9)
    assert p.values["coordination"][1] > 2.5               # the layer on the floor disks


def test_slabs_of_a_pile_get_segment_replicas_and_the_weight_time_errors(pile, tmp_path):
    """Slabs across y split into segments along x (the box's width) for errors that
    count the frozen structure; sigma_yy, the weight a layer carries, is fixed by the
    balance in a whole slab and keeps errors from time alone."""
    out, _ = pile
    proc = average(out / "atoms.dump", out / "contacts.dump", tmp_path / "s.csv",
                   "--contact-columns", MAP, "--bins", 6, "--quantities", "nu,sigma")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(tmp_path / "s.csv")
    err = p.meta["errors"]
    assert err["kind"] == "time+structure" and err["sectors"]["axis"] == "x"
    assert p.cells.span is not None and p.replicates.kind == "structure"
    assert set(err["sectors"]["time_only"]) == {"sigma_xy", "sigma_yx", "sigma_yy"}
    off = tmp_path / "t.csv"
    proc = average(out / "atoms.dump", out / "contacts.dump", off, "--contact-columns", MAP,
                   "--bins", 6, "--quantities", "nu,sigma", "--sectors", "off")
    assert proc.returncode == 0, proc.stderr
    t = read_profiles(off)
    assert t.meta["errors"]["kind"] == "time" and t.replicates.kind == "jackknife"
    assert np.array_equal(t.sem["sigma_yy"], p.sem["sigma_yy"], equal_nan=True)
    assert np.allclose(t.values["nu"], p.values["nu"], rtol=1e-12)
