"""3D LAMMPS dumps of a deck that is not granavg's, written as a user writes them:
tests/decks/pile_3d_si.lmp, a pile of ~750 spheres at rest on a floor under gravity (SI
units, periodic in x and y, default %g dumps, pair/local contacts with dz).

Checked against physics and against LAMMPS itself: the pile carries its weight through
the slab stress, -sigma_zz(z) A = g M_above(z) with M_above each sphere's mass split by
its volume above the cut (computed here without granavg); the summed stress trace over
boxes holding the pile is LAMMPS' summed per-atom pair virial; boxes covering the
periodic box hold every sphere's volume (images across the periodic faces); a dump.*
file series reads as the single dump; the CLI refuses 2D-only options in one line."""

import gzip
import os
import math

import numpy as np
import pytest

from granavg.cells import Boxes
from granavg.io.profiles_io import read_profiles

from .helpers import MAP3 as MAP, average_pile3d as average, frames, run_cli

SIDE, G = 0.016, 9.81
#: Relative error of a number printed with LAMMPS' default %g (6 digits), with margin.
PRINTED = 1e-4


@pytest.fixture(scope="module")
def pile(pile3d_soft_run):
    """The soft pile (k_n = 20 N/m: overlaps of 1-3% of a diameter near the floor)."""
    return pile3d_soft_run


def weight_above(rows, cols, edges, samples=400):
    """g M_above(z) averaged over each slab [e_k, e_k+1): each sphere's mass split by its
    volume above the cut (spherical caps), by quadrature over z."""
    z, a, m = rows[:, cols.index("z")], 0.5 * rows[:, cols.index("diameter")], \
        rows[:, cols.index("mass")]
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        cuts = lo + (np.arange(samples) + 0.5) / samples * (hi - lo)
        u = np.clip((cuts[:, None] - z[None, :]) / a[None, :], -1, 1)
        out.append(G * np.mean(((1 - u) ** 2 * (2 + u) / 4) @ m))
    return np.array(out)


def test_a_3d_pile_carries_its_weight(pile, tmp_path):
    """Slabs two diameters thick across z: in the bulk (above the floor's slab, below the
    free surface at ~22 mm) the contacts carry the weight above to 1%; Eq. 5's branch
    vector to the surfaces carries more, by about the overlap over d."""
    out, _ = pile
    args = ("--slabs", "z", "--range", 0, 0.024, "--bins", 6, "--gravity", 0, 0, -G)
    p = average(out, tmp_path / "c.csv", *args)
    paper = average(out, tmp_path / "p.csv", *args, "--branch", "paper")
    assert p.cells.kind == "slabs3d" and p.meta["inputs"]["dim"] == 3
    load = np.mean([weight_above(rows, cols, p.cells.edges)
                    for _, cols, rows in frames(out / "atoms.dump")], axis=0)
    ratio = -p.values["sigma_zz"] * SIDE * SIDE / load
    bulk = slice(1, 5)                                   # 4 to 20 mm
    assert np.all(np.abs(ratio[bulk] - 1) < 0.01), ratio
    excess = -paper.values["sigma_zz"][bulk] * SIDE * SIDE / load[bulk] - 1
    assert np.all(excess > 2 * np.abs(ratio[bulk] - 1)) and np.all(excess > 0.003), excess
    # the body force density is rho g, the frames' own masses
    assert np.allclose(p.values["body_z"], -G * p.values["rho"], rtol=1e-9)   # CSV: 10 digits
    assert np.allclose(p.values["body_x"], 0.0) and p.meta["units"].startswith("SI")
    # the floor's slab misses the floor's force: fix wall/gran leaves no contact rows
    assert ratio[0] < 0.9 and p.meta["boundary"].startswith("absent")


def test_the_summed_stress_is_lammps_virial(pile, tmp_path):
    """sum_k V_k tr sigma_k over boxes holding every sphere = LAMMPS' summed per-atom
    pair virial of the last frame, to the dump's printed precision (contact-point branch
    vectors: a pair's l_1 - l_2 is its centre distance, as in the virial). The boxes
    start below the floor: the spheres on it reach into it by their overlap with it."""
    out, virial = pile
    head, _, _ = frames(out / "atoms.dump")[-1]
    last = int(head[head.index("ITEM: TIMESTEP") + 1]) * 1e-5          # the deck's dt
    p = average(out, tmp_path / "b.csv", "--grid", 2, 2, 3, "--z-range", -0.002, 0.09,
                "--t-min", last - 1e-6, "--quantities", "nu,sigma")
    assert p.n_frames == 1 and p.cells.kind == "boxes"
    ours = np.sum(p.cells.volume * (p.values["sigma_xx"] + p.values["sigma_yy"] +
                                    p.values["sigma_zz"]))
    _, _, rows = frames(out / "contacts.dump")[-1]
    force = rows[:, 6]
    size = np.sum(np.abs(force * rows[:, 2]))
    assert abs(ours - virial) <= PRINTED * size, (ours, virial)
    assert abs(virial) > 0.3 * size                       # a compressed pile, not noise


def test_boxes_over_the_periodic_box_hold_every_sphere(pile, tmp_path):
    """The box is periodic in x and y: spheres across its faces reach into the cells at
    the other side (their images), so boxes spanning it hold all the spheres' volume;
    without the images the faces' cells would miss part of it."""
    out, _ = pile
    p = average(out, tmp_path / "g.csv", "--grid", 4, 4, 1, "--z-range", -0.002, 0.09,
                "--quantities", "nu")
    assert p.cells.periods[:2] == ((0.0, SIDE), (0.0, SIDE)) and p.cells.periods[2] is None
    _, cols, rows = frames(out / "atoms.dump")[0]
    a = 0.5 * rows[:, cols.index("diameter")]
    total = np.sum(4 / 3 * np.pi * a**3)
    assert np.sum(p.values["nu"] * p.cells.volume) == pytest.approx(total, rel=1e-5)
    plain = Boxes(p.cells.xedges, p.cells.yedges, p.cells.zedges)      # no images
    pos = tuple(rows[:, cols.index(c)] for c in "xyz")
    _, _, w = plain.weights(pos, a)
    part, _, w_all = p.cells.weights(pos, a)
    assert np.sum(w_all * 4 / 3 * np.pi * a[part] ** 3) == pytest.approx(total, rel=1e-12)
    assert w.sum() < len(a) - 1                           # spheres do cross the faces


def test_a_dump_series_reads_as_one_dump(pile3d_one, pile3d_series, tmp_path):
    """The deck with one file per frame (dump atoms.*.txt): the same profiles as the
    single dump of the same run."""
    one, many = pile3d_one, pile3d_series
    assert len(list(many.glob("atoms.*.txt"))) == 11
    args = ("--slabs", "z", "--range", 0, 0.024, "--bins", 6)
    a = average(one, tmp_path / "a.csv", *args)
    b = average(many, tmp_path / "b.csv", *args, atoms="atoms.*.txt",
                contacts="contacts.*.txt")
    assert a.n_frames == b.n_frames == 11
    for name in ("nu", "v_z", "sigma_zz", "F_zz", "omega_x"):
        assert np.array_equal(a.values[name], b.values[name]), name


@pytest.mark.parametrize("extra, message", [
    (("--thickness", 0.001, "--slabs", "z"), "--thickness is for 2D disks"),
    (("--slabs", "z", "--length", 0.01), "--length is for 2D disks"),
    (("--grid", 2, 2), "give NX NY NZ for a 3D dump"),
    (("--slabs", "z", "--gravity", 0, -9.81), "give 3 components for a 3D dump"),
    (("--r-range", 0, 0.01, "--layers", 0), "--layers 0"),
])
def test_2d_options_on_a_3d_dump_are_one_line(pile, tmp_path, extra, message):
    out, _ = pile
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", MAP, "--out",
                   tmp_path / "x.csv", "--no-progress", *map(str, extra))
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_the_dimension_comes_from_the_dump(pile2d, tmp_path):
    """A 2D dump (no z column, or every z alike) is 2D; --dim 3 on it is refused."""
    out = pile2d
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--dim", "3", "--slabs", "z",
                   "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "--dim 3 needs a z column" in proc.stderr
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--slabs", "y",
                   "--thickness", 1, "--out", tmp_path / "y.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    assert read_profiles(tmp_path / "y.csv").cells.kind == "slabs"
    assert math.isfinite(read_profiles(tmp_path / "y.csv").values["nu"][3])


def test_the_piles_slabs_balance_with_gravity(pile, tmp_path):
    """Slabs one diameter thick inside the pile (2-18 mm): each interior slab's contacts
    and weight balance to 2% of the stress scale (measured below 1%); without the body
    force they miss by its whole weight."""
    from granavg.analysis.balance import balance

    out, _ = pile
    p = average(out, tmp_path / "s.csv", "--slabs", "z", "--range", 0.002, 0.018, "--bins", 8,
                "--gravity", 0, 0, -G)
    full, bare = balance(p), balance(p, terms=())
    inner = slice(1, -1)                               # the edge slabs' outer flux is unknown
    assert np.all(np.isnan(full["residual"][:, [0, -1]]))
    assert np.all(np.abs(full["residual"][:, inner]) < 0.02), full["residual"]
    assert np.all(np.abs(bare["residual"][2, inner]) > 0.05), bare["residual"]


@pytest.mark.slow
def test_dask_workers_average_a_series_and_a_plain_dump_as_one_process_does(pile3d_one,
                                                                           pile3d_series,
                                                                           tmp_path):
    """`--workers 2` on the deck's dump.* series and on its single uncompressed dumps:
    the chunks (whole time blocks) merge into the serial profiles bit for bit."""
    args = ("--slabs", "z", "--range", 0, 0.024, "--bins", 6)
    for name, files in (("many", dict(atoms="atoms.*.txt", contacts="contacts.*.txt")),
                        ("one", {})):
        run = pile3d_series if files else pile3d_one
        serial = average(run, tmp_path / f"{name}-s.csv", *args, **files)
        parallel = average(run, tmp_path / f"{name}-p.csv", *args, "--workers", 2, **files)
        assert len(parallel.meta["dask"]["chunks"]) > 1
        assert parallel.n_frames == serial.n_frames == 11
        for q in serial.values:
            assert np.array_equal(serial.values[q], parallel.values[q], equal_nan=True), q
            assert np.array_equal(serial.sem[q], parallel.sem[q], equal_nan=True), q
        assert np.array_equal(serial.flags, parallel.flags)


def test_dask_workers_refuse_a_single_gzip_dump_in_one_line(pile, tmp_path):
    """One gzip file is one stream: a cluster cannot split it. A cluster asked for
    (GRANAVG_COST_MODEL=off, as with --scheduler) is refused in one line; by
    default --workers says so in one line and averages in this process."""
    out, _ = pile
    gz = tmp_path / "atoms.dump.gz"
    gz.write_bytes(gzip.compress((out / "atoms.dump").read_bytes()))
    args = ["average", "--atoms", gz, "--slabs", "z", "--workers", "2", "--no-progress"]
    proc = run_cli(*args, "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "one gzip file is one stream" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()
    auto = run_cli(*args, "--out", tmp_path / "y.csv",
                   env=dict(os.environ, GRANAVG_COST_MODEL="on"))
    one = run_cli(*args[:-3], "--no-progress", "--out", tmp_path / "z.csv")
    assert auto.returncode == one.returncode == 0, auto.stderr
    said = [l for l in auto.stderr.splitlines() if "averaging in this process" in l]
    assert len(said) == 1 and "one gzip stream" in said[0], auto.stderr
    assert (tmp_path / "y.csv").read_bytes() == (tmp_path / "z.csv").read_bytes()
