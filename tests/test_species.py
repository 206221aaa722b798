"""Mixtures (granavg.engine.species): partial fields per species that add up to the
mixture's, the force between species that each species' balance needs, the one-species
selection that is the mixture bit for bit, outputs with a species axis, refusals.

Real piles at rest of our own decks, dumped with the per-atom forces (m a) and 17 digits
(``precise yes``): tests/decks/pile_3d_si.lmp with ``bidisperse yes`` (odd ids large,
type 2: d = 2.4 mm, the others 1.6 mm; periodic in x and y) on its floor of fixed type-3
spheres (``floor spheres``), split by type; tests/decks/pile_2d_lj.lmp on its floor of wall disks (diameters
0.8-1.2), split by size at radius 0.5."""

import numpy as np
import pytest

import granavg
from granavg.analysis.balance import balance

from .helpers import MAP3, PILE2D_MAP, run_cli, run_pile2d, run_pile3d

pytestmark = pytest.mark.slow

G = 9.81
MAP3D = dict(kv.split("=") for kv in MAP3.split(","))
MAP2D = dict(kv.split("=") for kv in PILE2D_MAP.split(","))


@pytest.fixture(scope="module")
def bidisperse(tmp_path_factory):
    out = tmp_path_factory.mktemp("bidisperse") / "pile"
    run_pile3d(out, bidisperse="yes", precise="yes", floor="spheres")
    return out


@pytest.fixture(scope="module")
def pile2d_precise(tmp_path_factory):
    out = tmp_path_factory.mktemp("pile2d_precise")
    run_pile2d(out, floor="disks", precise="yes")
    return out


def _pile3d(pile, cells, **extra):
    return granavg.average(pile / "atoms.dump", contacts=pile / "contacts.dump",
                           contact_map=MAP3D, gravity=(0, 0, -G), wall_types=[3],
                           cells=cells, species="type", **extra)


def _pile2d(pile, cells, **extra):
    return granavg.average(pile / "atoms.dump", contacts=pile / "contacts.dump",
                           contact_map=MAP2D, gravity=(0, -1), wall_types=[2], cells=cells,
                           species="radius:0.5", **extra)


SLABS3D = {"slabs": "z", "range": (0.0, 0.03), "bins": 15}
GRID3D = {"grid": (8, 8, 12), "z_range": (0.004, 0.016)}
SLABS2D = {"slabs": "y", "range": (-1.0, 30.0), "bins": 31, "thickness": 1.0}
GRID2D = {"grid": (10, 12), "x_range": (0, 20), "y_range": (2, 14), "thickness": 1.0}


def _sum_of_species(f, name):
    return sum(np.asarray(f.of(s).values[name]) for s in f.species[1:])


def _rel(a, b):
    return float(np.nanmax(np.abs(a - b)) / np.nanmax(np.abs(b)))


@pytest.mark.parametrize("which", ["3d", "2d"])
def test_partial_fields_add_up_to_the_mixture_with_exact_weights(bidisperse, pile2d_precise,
                                                                which):
    """Every additive field: densities to 1e-12 (measured 3e-16), the contact stress
    split at the contact points, fabric, kinetic stress, boundary force to 1e-12
    (measured 3e-16); the forces between species cancel in the sum (measured 9e-18 of
    one species')."""
    f = _pile3d(bidisperse, SLABS3D) if which == "3d" else _pile2d(pile2d_precise, SLABS2D)
    assert f.species[0] == "all" and len(f.species) == 3
    axes = f.cells.axes
    for name in ("rho", "nu", *[f"sigma_{i}{j}" for i in axes for j in axes],
                 f"F_{axes[-1]}{axes[-1]}", f"dsigma_{axes[-1]}{axes[-1]}",
                 f"body_{axes[-1]}"):
        assert _rel(_sum_of_species(f, name), np.asarray(f.of("all").values[name])) < 1e-12, name
    inter = f"f_inter_{axes[-1]}"
    one = np.nanmax(np.abs(f.of(f.species[1]).values[inter]))
    assert one > 0
    assert np.nanmax(np.abs(_sum_of_species(f, inter))) < 1e-12 * one
    assert np.all(f.of("all").values[inter] == 0)
    c = _sum_of_species(f, "c")
    full = np.asarray(f.of("all").values["nu"]) > 0
    assert np.allclose(c[full], 1.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("which", ["3d", "2d"])
def test_each_species_carries_its_weight_with_the_force_between_species(
        bidisperse, pile2d_precise, which):
    """In the cells' form with exact weights: the net force on each species over the
    cells, sum V (b + t + f_inter), is its inertia sum V m a (LAMMPS' per-atom forces)
    to 1e-6 of its weight (measured 1.6e-8 in 3D, 8e-8 in 2D); without the force between
    species it misses by a tenth to a half of its weight (measured 0.36 and 0.11 in 3D,
    0.50 and 0.29 in 2D)."""
    f = _pile3d(bidisperse, SLABS3D) if which == "3d" else _pile2d(pile2d_precise, SLABS2D)
    V = f.cells.volume
    up = f.cells.axes[-1]
    for s in f.species:
        p = f.of(s)
        weight = abs(np.nansum(V * p.values[f"body_{up}"]))
        net = [abs(np.nansum(V * (sum(p.values.get(f"{t}_{a}", 0.0)
                                      for t in ("body", "boundary", "f_inter"))
                                  - p.values[f"ma_{a}"])))
               for a in f.cells.axes]
        without = abs(np.nansum(V * sum(p.values.get(f"{t}_{up}", 0.0)
                                        for t in ("body", "boundary"))))
        assert max(net) < 1e-6 * weight, (s, net, weight)
        if s != "all":
            assert without > 0.05 * weight, (s, without, weight)


@pytest.mark.parametrize("which", ["3d", "2d"])
def test_each_species_balances_at_every_bulk_node_with_lucy(bidisperse, pile2d_precise,
                                                            which):
    """With a Lucy kernel, frame by frame: div sigma_s + b_s + t_s + f_inter,s = m a_s
    (the species' inertia from LAMMPS' per-atom forces) at the nodes where the species'
    weight is at least 30% of its largest, to 1e-4 of rho_s g (measured at most 2.1e-6 in
    3D, 1.1e-5 in 2D: LAMMPS' dumped dashpot, docs/time.md); without f_inter the median
    node misses by more than the species' weight (measured 9.1 and 1.2 rho_s g in 3D, 3.5
    and 1.7 in 2D). The partial stresses add up to the mixture's to 1e-10 (measured
    2e-16: with %g dumps 8e-6, the two sides' contact points differing by the rounding)."""
    f = _pile3d(bidisperse, GRID3D, kernel="lucy", width=0.002) if which == "3d" else \
        _pile2d(pile2d_precise, GRID2D, kernel="lucy", width=1.5)
    axes = f.cells.axes
    up = axes[-1]
    for s in f.species:
        p = f.of(s)
        res = np.stack([p.values[f"divsigma_{a}"] + p.values[f"body_{a}"]
                        + p.values.get(f"boundary_{a}", 0.0) + p.values[f"f_inter_{a}"]
                        - p.values[f"ma_{a}"] for a in axes])
        inter = np.stack([p.values[f"f_inter_{a}"] for a in axes])
        g = np.abs(p.values[f"body_{up}"])
        bulk = g >= 0.3 * np.nanmax(g)
        assert bulk.sum() > 50
        rel = np.linalg.norm(res, axis=0)[bulk] / g[bulk]
        assert rel.max() < 1e-4, (s, rel.max())
        if s != "all":
            miss = np.linalg.norm(res - inter, axis=0)[bulk] / g[bulk]
            assert np.median(miss) > 1.0, (s, np.median(miss))
    for name in ("sigma_" + up + up, "sigma_" + axes[0] + up, "rho"):
        assert _rel(_sum_of_species(f, name), np.asarray(f.of("all").values[name])) < 1e-10


def test_one_species_is_the_mixture_bit_for_bit():
    run = granavg.examples.couette_2d.run
    plain = granavg.average(run, cells={"bins": 8}, t_min=1.0)
    split = granavg.average(run, cells={"bins": 8}, t_min=1.0, species="every=1,2")
    assert split.species == ("all", "every")
    for part in ("all", "every"):
        f = split.of(part)
        for k in plain.values:
            assert np.array_equal(f.values[k], plain.values[k], equal_nan=True), (part, k)
            assert np.array_equal(f.sem[k], plain.sem[k], equal_nan=True), (part, k)
    two = granavg.average(run, cells={"bins": 8}, t_min=1.0, species="type")
    for k in plain.values:
        assert np.array_equal(two.of("all").values[k], plain.values[k], equal_nan=True), k


def test_outputs_carry_the_species_axis(bidisperse, tmp_path):
    proc = run_cli("average", "--atoms", bidisperse / "atoms.dump", "--contacts",
                   bidisperse / "contacts.dump", "--contact-columns", MAP3, "--gravity", 0, 0,
                   -G, "--wall-types", 3, "--slabs", "z", "--range", 0, 0.03, "--bins", 6,
                   "--species", "type",
                   "--out", tmp_path / "s.csv", "--netcdf", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    table = granavg.read(tmp_path / "s.csv")
    direct = _pile3d(bidisperse, {"slabs": "z", "range": (0.0, 0.03), "bins": 6})
    assert table.species == direct.species == ("all", "type1", "type2")
    assert table.dims == ("species", "z") and table.values["nu"].shape == (3, 6)
    assert np.allclose(table.values["rho"], direct.values["rho"], rtol=1e-9, atol=0)
    assert table.units["f_inter_z"] == "N/m^3" and table.units["c"] == "1"
    import pandas as pd
    rows = pd.read_csv(tmp_path / "s.csv")
    assert list(rows["species"].unique()) == ["all", "type1", "type2"]
    import xarray as xr
    with xr.open_dataset(tmp_path / "s.csv.nc") as ds:
        assert ds["sigma_zz"].dims == ("species", "z")
        assert list(ds["species"].values) == ["all", "type1", "type2"]
    report = run_cli("analyze", tmp_path / "s.csv", "--out", tmp_path / "r", "--no-figures")
    assert report.returncode == 0, report.stderr
    text = (tmp_path / "r" / "report.html").read_text()
    assert "[type1]" in text and "[type2]" in text and "f_inter" in text


@pytest.mark.parametrize("spec, message", [
    ("small=1 large=3", "names type 3, which no particle of the data has"),
    ("small=1,2 large=2", "type 2 is in both small and large"),
    ("radius", "more than 8 distinct radii"),
    ("bogus", "give type, radius, radius:E1,E2,... or named groups"),
])
def test_bad_species_are_one_line(bidisperse, pile2d_precise, tmp_path, spec, message):
    pile = pile2d_precise if spec == "radius" else bidisperse
    cmap, extra = (PILE2D_MAP, ["--wall-types", 2, "--thickness", 1]) if spec == "radius" \
        else (MAP3, ["--wall-types", 3])
    proc = run_cli("average", "--atoms", pile / "atoms.dump", "--contacts",
                   pile / "contacts.dump", "--contact-columns", cmap, *extra, "--slabs",
                   "z" if pile == bidisperse else "y", "--bins", 4, "--species", spec,
                   "--out", tmp_path / "x.csv", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("granavg: error")]
    assert len(errors) == 1 and message in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr and not list(tmp_path.iterdir())


def test_species_on_dask_workers_equal_the_serial_pass(bidisperse, tmp_path):
    """Anyone's dumps on two dask workers: the species the first frame fixed go to every
    worker, whose accumulators merge exactly (the same values as one process)."""
    pytest.importorskip("distributed")
    cells = {"slabs": "z", "range": (0.0, 0.03), "bins": 6}
    serial = _pile3d(bidisperse, cells)
    parallel = _pile3d(bidisperse, cells, workers=2)
    assert parallel.species == serial.species
    for k in serial.values:
        assert np.allclose(parallel.values[k], serial.values[k], rtol=1e-12, atol=0,
                           equal_nan=True), k


def test_species_of_run_directories_on_workers_is_refused_in_one_line(tmp_path):
    proc = run_cli("average", granavg.examples.couette_2d.run, "--bins", 4, "--species",
                   "type", "--workers", 2, "--out", tmp_path / "x.csv", "--no-progress")
    assert proc.returncode == 2 and "--species on run directories averages in one process" \
        in proc.stderr, proc.stderr


def test_kinetic_stresses_about_each_velocity_and_fields_in_time():
    """dsigma_mix (about the mixture's velocity) summed over the species is the
    mixture's kinetic stress about its own velocity (an identity: measured 4e-16); a
    mixture in time has both axes, species first, and its partial densities add up at
    every time."""
    run = granavg.examples.couette_2d.run
    f = granavg.average(run, cells={"bins": 8}, t_min=1.0, species="type")
    whole = f.of("all")
    for ij in ("rr", "rphi", "phiphi"):
        assert _rel(_sum_of_species(f, "dsigma_mix_" + ij),
                    np.asarray(whole.values["dsigma_fluct_" + ij])) < 1e-12
        assert np.array_equal(whole.values["dsigma_mix_" + ij], whole.values["dsigma_fluct_" + ij])
    assert f.units["dsigma_mix_rr"] == "Pa" and f.units["seg_r"] == "m/s"
    w = granavg.average(run, cells={"bins": 8}, t_min=1.0, windows=0.5, species="type")
    assert w.dims == ("species", "time", "r") and w.shape == (3, 4, 8)
    assert w.at(1).dims == ("species", "r") and w.of("type2").dims == ("time", "r")
    assert _rel(_sum_of_species(w, "rho"), np.asarray(w.of("all").values["rho"])) < 1e-12
    table = w.to_pandas()
    assert list(table.columns[:2]) == ["species", "t"] and len(table) == 3 * 4 * 8


def test_the_mixture_is_judged_with_errors_and_reported(tmp_path):
    """The 2D Couette example (290 disks of two types), split by type: the large disks'
    share in the band (r - R_i < 2 s) and beyond, with errors from the replicates, a
    verdict that follows from them, each species' band; ``analyze`` with a species
    table as third input adds the section where the band is fitted, and says why not
    where it is not (this short run's 16 rings: no decay above the noise)."""
    from granavg.analysis.segregation import SIGNIFICANCE, segregation

    run = granavg.examples.couette_2d.run
    f = granavg.average(run, cells={"bins": 8}, t_min=1.0, species="type")
    scene = f.meta["run_manifest"]["scene"]
    m = segregation(f, scene["R_i"], scene["d_s"], scene["Omega"], 0.006)
    err = m["errors"]["excess"]
    assert np.isfinite(err) and err > 0 and m["band_rings"] == 2
    expected = "segregates" if m["excess"] > SIGNIFICANCE * err else "depleted" \
        if m["excess"] < -SIGNIFICANCE * err else "no segregation resolved"
    assert m["verdict"] == expected == m["claim"]["verdict"]
    V, nu = f.cells.volume, f.of("all").values["nu"]
    nu_l = f.of("type2").values["nu"]
    assert m["c_band"] == pytest.approx(np.sum((V * nu_l)[:2]) / np.sum((V * nu)[:2]), rel=1e-12)
    for n, extra in ((8, ()), (16, ()), (8, ("--species", "type"))):
        name = f"p{n}{'s' if extra else ''}.csv"
        proc = run_cli("average", run, "--bins", n, "--t-min", 1.0, *extra,
                       "--out", tmp_path / name, "--no-progress")
        assert proc.returncode == 0, proc.stderr
    proc = run_cli("analyze", tmp_path / "p8.csv", tmp_path / "p16.csv", tmp_path / "p8s.csv",
                   "--out", tmp_path / "r", "--no-figures")
    assert proc.returncode == 0, proc.stderr
    assert "the mixture's section is left out: the shear band is not fitted" in proc.stderr
    assert (tmp_path / "r" / "report.html").exists()


def test_vtk_holds_every_species(bidisperse, tmp_path):
    meshio = pytest.importorskip("meshio")
    proc = run_cli("average", "--atoms", bidisperse / "atoms.dump", "--contacts",
                   bidisperse / "contacts.dump", "--contact-columns", MAP3, "--wall-types", 3,
                   "--grid", 2, 2, 3,
                   "--z-range", 0, 0.012, "--species", "type", "--vtk",
                   "--out", tmp_path / "g.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    mesh = meshio.read(tmp_path / "g.csv.vtu")
    data = {k: v[0] for k, v in mesh.cell_data.items()}
    table = granavg.read(tmp_path / "g.csv")
    for name, tag in (("all", ""), ("type1", "/type1"), ("type2", "/type2")):
        assert np.allclose(np.sort(data["nu" + tag]), np.sort(table.of(name).values["nu"]),
                           rtol=1e-12)
    assert np.allclose(data["nu/type1"] + data["nu/type2"], data["nu"], rtol=1e-12)


def test_each_contact_between_species_is_counted_once_from_each_side():
    """coordination_inter: the small disks' contacts with large ones and the large disks'
    with small ones, summed over one ring holding every disk (each type of one size),
    are the same count: the frames' mean number of small-large contacts (104.375 on the
    2D Couette example's 8 frames, to round-off); one species has none."""
    from granavg.cells import Rings

    run = granavg.examples.couette_2d.run
    plain = granavg.average(run, cells={"bins": 8}, t_min=1.0)
    scene = plain.meta["run_manifest"]["scene"]
    ring = Rings.count(1, scene["R_i"] - 0.02, scene["R_o"] + 0.02, h=scene["h"])
    f = granavg.average(run, cells=ring, t_min=1.0, species="type",
                        quantities=["nu", "coordination", "coordination_inter", "F", "F_inter"])
    count = {}
    for s, d in (("type1", scene["d_s"]), ("type2", scene["d_l"])):
        p = f.of(s)
        disk = np.pi * scene["h"] * (d / 2) ** 2
        count[s] = float(np.sum(p.values["coordination_inter"] * p.values["nu"] * f.cells.volume)
                         / disk)
        assert 0 < p.values["coordination_inter"][0] < p.values["coordination"][0]
        assert 0 < p.values["F_inter_rr"][0] < p.values["F_rr"][0]
    assert count["type1"] == pytest.approx(count["type2"], rel=1e-12)
    assert count["type1"] == pytest.approx(104.375, rel=1e-12)
    one = granavg.average(run, cells={"bins": 8}, t_min=1.0, species="every=1,2")
    assert np.all(one.of("every").values["coordination_inter"] == 0)
