"""The balance of forces, checked with physics: a pile at rest carries its weight
through the slab stress; the paper's branch vector misses a pair's force by exactly the
overlap ratio; body and boundary force densities close the momentum balance.

The pile is tests/decks/pile_2d_lj.lmp (LAMMPS' own run, lj units, default dump
formatting, gravity 1), with springs soft enough (k_n = 200) for overlaps of up to 8% of
a diameter: across any horizontal cut the contacts carry the weight above,
-sigma_yy(y) W h = g M_above(y), frame by frame, in static equilibrium. The slab
average of the disks' smeared stress equals the slab average of that cut stress only
where the slabs are wide against a disk (two diameters here); slabs one diameter wide
scatter by 1-2% with the layering."""

import numpy as np
import pytest

from granavg.engine import average
from granavg.cells import Slabs
from granavg.io.frames import Frame
from granavg.io.profiles_io import read_profiles

from .helpers import PILE2D_MAP as MAP, frames, run_cli, run_pile2d, small_cell_args

W, H = 20.0, 1.0                       # the deck's box width (periodic) and disk height


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    out = tmp_path_factory.mktemp("pile_balance")
    run_pile2d(out, kn=200.0)
    return out


@pytest.fixture(scope="module")
def pile_on_disks(tmp_path_factory):
    """The same soft pile (k_n = 200) on its floor of fixed type-2 disks."""
    out = tmp_path_factory.mktemp("pile_balance_on_disks")
    run_pile2d(out, floor="disks", kn=200.0)
    return out


def weight_above(atoms, edges, g=1.0, samples=400):
    """g M_above(y) averaged over each slab [e_k, e_k+1): each disk's mass split by its
    area above the cut (circular segments), by quadrature over y (independent of
    granavg)."""
    a, y, m = 0.5 * atoms[:, 2], atoms[:, 5], atoms[:, 3]
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        cuts = lo + (np.arange(samples) + 0.5) / samples * (hi - lo)
        u = np.clip((cuts[:, None] - y[None, :]) / a[None, :], -1, 1)
        share = (np.arccos(u) - u * np.sqrt(1 - u * u)) / np.pi     # area above / area
        out.append(g * np.mean(share @ m))
    return np.array(out)


def slab_profiles(pile, dest, *extra):
    proc = run_cli("average", "--atoms", pile / "atoms.dump", "--contacts",
                   pile / "contacts.dump", "--contact-columns", MAP, "--thickness", H,
                   "--slabs", "y", "--range", 0, 14, "--bins", 7, "--gravity", 0, -1,
                   "--out", dest, "--no-progress", *extra)
    assert proc.returncode == 0, proc.stderr
    return read_profiles(dest)


def test_a_pile_at_rest_carries_its_weight(pile, tmp_path):
    """Contact branch (the default): within 1% in every bulk slab (2 <= y <= 8: above
    the floor's layer, well below the free surface at y ~ 11; measured 0.25-0.4%). The
    paper's branch vector carries more than the weight, by about the mean overlap over
    d (measured +1.7 to +2.3%)."""
    p = slab_profiles(pile, tmp_path / "c.csv")
    paper = slab_profiles(pile, tmp_path / "p.csv", "--branch", "paper")
    edges = p.cells.edges
    load = np.mean([weight_above(a, edges) for _, _, a in frames(pile / "atoms.dump")], axis=0)
    carried = -p.values["sigma_yy"] * W * H
    bulk = (p.cells.coordinates()["y"] >= 2) & (p.cells.coordinates()["y"] <= 8)
    assert bulk.sum() == 3
    ratio = carried[bulk] / load[bulk]
    assert np.all(np.abs(ratio - 1) < 0.01), ratio
    excess = (-paper.values["sigma_yy"] * W * H)[bulk] / load[bulk] - 1
    assert np.all(excess > 0.01) and np.all(excess > 2 * np.abs(ratio - 1)), (excess, ratio)
    assert p.meta["branch"] == "contact" and paper.meta["branch"] == "paper"
    # the body force density is rho g, the frames' own masses (g = (0, -1))
    assert np.allclose(p.values["body_y"], -p.values["rho"], rtol=1e-12, atol=0)
    assert np.allclose(p.values["body_x"], 0.0)
    assert p.meta["columns"]["body_y"] == "force/length^3"


def pair(a1, a2, dist, f):
    """A frame of two disks on the x axis pressed together by a normal force f."""
    atoms = {"x": np.array([0.0, dist]), "y": np.zeros(2), "radius": np.array([a1, a2]),
             "id": np.array([1.0, 2.0])}
    c = {"id1": np.array([1.0]), "id2": np.array([2.0]), "wall": np.zeros(1),
         "fnx": np.array([-f]), "fny": np.zeros(1), "ftx": np.zeros(1), "fty": np.zeros(1),
         "nx": np.ones(1), "ny": np.zeros(1), "overlap": np.array([a1 + a2 - dist])}
    return Frame(0, 0.0, atoms, c)


@pytest.mark.parametrize("a1, a2, dist", [(1.0, 1.0, 1.9), (0.5, 1.2, 1.6), (1.0, 0.4, 1.39)])
def test_the_paper_branch_misses_a_pair_by_the_overlap_ratio(a1, a2, dist):
    """sum_k V_k tr sigma_k = -f (a1 + a2) with Eq. 5 as printed, -f r_12 with the
    contact point: their ratio is 1 + delta / r_12 exactly, for any two radii."""
    cells = Slabs(np.array([-5.0, 5.0]), 1.0, "x", 10.0)
    got = {}
    for branch in ("paper", "contact"):
        p = average([pair(a1, a2, dist, 2.0)], cells, quantities=["sigma"], branch=branch)
        got[branch] = float(p.cells.volume[0] * (p.values["sigma_xx"][0] +
                                                 p.values["sigma_yy"][0]))
    assert got["contact"] == pytest.approx(-2.0 * dist, rel=1e-14)
    assert got["paper"] == pytest.approx(-2.0 * (a1 + a2), rel=1e-14)
    assert got["paper"] / got["contact"] == pytest.approx(1 + (a1 + a2 - dist) / dist,
                                                          rel=1e-14)


@pytest.fixture(scope="module")
def plated(tmp_path_factory):
    """The small Couette cell sheared with base-plate friction (a real LAMMPS run),
    averaged over 8 rings from R_i to R_o."""
    out = tmp_path_factory.mktemp("plated")
    proc = run_cli(*small_cell_args(out / "run", "mu_base=0.03", "t_end=6"))
    assert proc.returncode == 0, proc.stderr
    proc = run_cli("average", out / "run", "--bins", 8, "--t-min", 2, "--out",
                   out / "p8.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.slow
def test_the_couette_walls_balance_with_the_boundary_and_plate_forces(plated):
    """Without the force densities the wall rings miss by about the whole wall stress
    (measured 1.05 of the stress scale); with the walls' boundary force density (at the
    contact points) and the base plate's body force every ring closes within 0.1 and 2
    errors (measured at most 0.022); the plate's friction is seen where the shear is."""
    from granavg.analysis.balance import balance

    p = read_profiles(plated / "p8.csv")
    assert p.meta["body_forces"][0]["base_plate"]["mu_base"] == 0.03
    bare = balance(p, terms=(), closed=True)
    full = balance(p, closed=True)
    no_plate = balance(p, terms=("boundary",), closed=True)
    assert full["terms"] == ["body", "boundary"]
    assert np.all(np.abs(bare["residual"][:, [0, -1]]).max(axis=0) > 0.5)
    assert np.all(np.abs(full["residual"]) < 0.1)
    assert np.all(np.abs(full["residual"]) < 0.1 - 2 * full["residual_err"])
    # the plate: the inner wall ring's balance is better with it
    assert np.abs(full["residual"][:, 0]).max() < np.abs(no_plate["residual"][:, 0]).max()
    # the cell's torques: the packing holds the turning inner ring back and drags the
    # outer one along; the plate takes up the difference
    ts = p.timeseries[p.timeseries.t_s >= 2]
    assert ts.torque_in_Nm.mean() < 0 < ts.torque_out_Nm.mean() < -ts.torque_in_Nm.mean()


@pytest.mark.slow
def test_analyze_runs_on_slab_profiles_of_plain_dumps(pile_on_disks, tmp_path):
    """`granavg analyze` on a slab profile of anyone's dumps (no run manifest): the
    fields, the balance figure and a summary; the pile on its floor of wall disks, cells
    from the floor's top, closes in every slab with gravity and the floor's boundary
    force, and misses at the floor without them."""
    pile = pile_on_disks
    proc = run_cli("average", "--atoms", pile / "atoms.dump", "--contacts",
                   pile / "contacts.dump", "--contact-columns", MAP, "--thickness", H,
                   "--slabs", "y", "--range", 1, 15, "--bins", 7, "--gravity", 0, -1,
                   "--wall-types", 2, "--out", tmp_path / "s.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli("analyze", tmp_path / "s.csv", "--closed", "--out", tmp_path / "rep")
    assert proc.returncode == 0, proc.stderr
    import json
    s = json.loads((tmp_path / "rep" / "summary.json").read_text())
    b = s["profiles"][0]["balance"]
    assert b["terms"] == ["body", "boundary"]
    assert b["max_abs_residual"] < 0.1 < 1.0 < b["max_abs_residual_without_forces"]
    assert (tmp_path / "rep" / "report.html").exists()
    assert (tmp_path / "rep" / "figures" / "balance0.png").stat().st_size > 1000


def test_walls_without_contact_rows_are_said_to_be_missing(pile, tmp_path):
    """The pile on a fix wall/gran floor: no wall contact in the dumps, so the sidecar
    says the boundary term is absent, and the floor's slab misses by about the weight."""
    p = slab_profiles(pile, tmp_path / "w.csv")
    assert p.meta["boundary"].startswith("absent")
    assert np.all(p.values["boundary_y"] == 0)


def test_a_grid_over_the_pile_balances_its_interior_cells(pile_on_disks, tmp_path):
    """A grid of 5 x 7 cells (4 x 2 diameters) over the pile on its floor of wall disks:
    the interior cells (the edges are the periodic sides and the free top) balance with
    gravity to a median |residual| of a tenth of what they miss without it (measured
    0.064 against 0.67; single cells scatter with the frozen force chains of one
    packing, up to 0.4)."""
    from granavg.analysis.balance import balance

    pile = pile_on_disks
    proc = run_cli("average", "--atoms", pile / "atoms.dump", "--contacts",
                   pile / "contacts.dump", "--contact-columns", MAP, "--thickness", H,
                   "--grid", 5, 7, "--x-range", 0, 20, "--y-range", 1, 15, "--gravity", 0, -1,
                   "--wall-types", 2, "--out", tmp_path / "g.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(tmp_path / "g.csv")
    with_b, without = balance(p)["residual"][1], balance(p, terms=())["residual"][1]
    inner = np.isfinite(with_b)
    assert inner.sum() == 3 * 5                                # interior cells only
    assert np.median(np.abs(with_b[inner])) < 0.25 * np.median(np.abs(without[inner]))


def test_a_subset_of_quantities_gives_the_same_stress_and_boundary(small_run, tmp_path):
    """`--quantities sigma` reads the overlaps its branch vectors need (the same sigma
    as with every quantity), `--quantities boundary` alone works, and `--quantities nu,v`
    (docs/scene.md: what leaving the rest out changes) gives the same nu and v."""
    args = ("average", small_run, "--bins", 6, "--t-min", 1, "--no-progress")
    for name, extra in (("all", ()), ("sigma", ("--quantities", "sigma")),
                        ("boundary", ("--quantities", "boundary")),
                        ("nuv", ("--quantities", "nu,v"))):
        proc = run_cli(*args, *extra, "--out", tmp_path / f"{name}.csv")
        assert proc.returncode == 0, proc.stderr
    full, sig, bnd, nuv = (read_profiles(tmp_path / f"{n}.csv")
                           for n in ("all", "sigma", "boundary", "nuv"))
    for k in ("nu", "v_r", "v_phi"):
        np.testing.assert_array_equal(nuv.values[k], full.values[k])
        np.testing.assert_array_equal(nuv.sem[k], full.sem[k])
    assert "sigma_rr" not in nuv.values
    np.testing.assert_array_equal(sig.values["sigma_rr"], full.values["sigma_rr"])
    np.testing.assert_array_equal(bnd.values["boundary_r"], full.values["boundary_r"])
    assert np.abs(full.values["boundary_r"][[0, -1]]).min() > 0     # both walls push


def test_mistakes_with_force_densities_are_one_line(pile, tmp_path, small_run):
    base = ("average", "--atoms", pile / "atoms.dump", "--thickness", H, "--slabs", "y",
            "--out", tmp_path / "x.csv")
    atoms_only = pile / "no_mass.dump"                     # the dump without its masses
    lines = (pile / "atoms.dump").read_text().replace(" mass ", " m ")
    atoms_only.write_text(lines)
    proc = run_cli("average", "--atoms", atoms_only, "--thickness", H, "--slabs", "y",
                   "--gravity", 0, -1, "--out", tmp_path / "x.csv")
    assert proc.returncode == 2 and "--density" in proc.stderr and "Traceback" not in proc.stderr
    proc = run_cli(*base, "--gravity", 0, -1, "--units", "real")
    assert proc.returncode == 2 and "force unit" in proc.stderr
    proc = run_cli("average", small_run, "--center", 0, 0, "--out", tmp_path / "y.csv")
    assert proc.returncode == 2 and "--center is for plain LAMMPS dumps" in proc.stderr
    proc = run_cli(*base, "--units", "real")
    assert proc.returncode == 0, proc.stderr
    import json
    cols = json.loads((tmp_path / "x.csv.json").read_text())["columns"]
    assert cols["dsigma_yy"] == "g/mol (Angstrom/fs)^2/Angstrom^3"
