"""A 3D Couette cell of our own (tests/decks/couette_3d_si.lmp: ~480 spheres between a
turning inner cylinder and a fixed outer one, both of wall spheres, periodic along the
axis; SI units, default dumps) averaged over cylindrical shells: a shear band at the
inner wall, and the balance of torques - the torque the inner wall puts in passes
unchanged through every shell, r^2 (sigma_phir - dsigma_phir) = the wall's torque /
(2 pi L) - and of forces per shell, closed by the walls' boundary force density."""

from pathlib import Path

import numpy as np
import pytest

from granavg.analysis.balance import balance
from granavg.io.profiles_io import read_profiles
from granavg.sim.lammps_session import lammps_session

from .helpers import MAP3 as MAP, run_cli

DECK = Path(__file__).parent / "decks" / "couette_3d_si.lmp"
R_I, R_O, L = 0.008, 0.018, 0.006

#: Every test here reads the 3D Couette cell's run (several seconds of LAMMPS).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def shells(tmp_path_factory):
    out = tmp_path_factory.mktemp("couette3d")
    with lammps_session(["-log", str(out / "log.lammps"), "-var", "out", str(out)]) as lmp:
        lmp.file(str(DECK))
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", MAP, "--wall-types", 2, 3,
                   "--r-range", R_I, R_O, "--bins", 5, "--out", out / "shells.csv",
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    return read_profiles(out / "shells.csv")


def test_the_shells_show_a_shear_band_at_the_inner_wall(shells):
    p = shells
    assert p.cells.kind == "shells" and p.cells.periods[2] == (0.0, L)
    v, sem = p.values["v_phi"], p.sem["v_phi"]
    assert v[0] > 3 * v[1] > 0 and np.all(np.abs(v[2:]) < np.abs(v[1]))   # it decays
    assert np.all(np.abs(p.values["v_r"]) < 3 * p.sem["v_r"] + 1e-6)        # no mean radial flow
    assert np.all((p.values["nu"] > 0.5) & (p.values["nu"] < 0.7))
    assert p.meta["errors"]["kind"] == "time+structure"
    assert p.meta["errors"]["sectors"]["axis"] == "phi"
    assert np.all(sem > 0)


def test_the_torque_of_the_inner_wall_passes_through_every_shell(shells):
    """Steady and axisymmetric, the tangential balance is d(r^2 T_phir)/dr = 0: the same
    torque through every cylinder. The wall's torque is its contacts' tangential force at
    the wall's surface, R_i times the summed boundary force density of the cells it acts
    on. Measured: every shell within 11%, their mean within 0.1%; taking the wall's force
    at the first shell's centre instead of its surface is 12.5% off."""
    p = shells
    r = p.cells.centre_r
    T = p.values["sigma_phir"] - p.values["dsigma_phir"]
    wall_force = np.sum((p.values["boundary_phi"] * p.cells.volume)[r < 0.5 * (R_I + R_O)])
    torque = wall_force * R_I / (2 * np.pi * L)
    ratio = -r**2 * T / torque
    assert np.all(np.abs(ratio - 1) < 0.15), ratio
    assert abs(np.mean(ratio) - 1) < 0.03, ratio
    at_centre = wall_force * r[0] / (2 * np.pi * L)
    assert abs(np.mean(-r**2 * T / at_centre) - 1) > 0.03              # the test can tell


def test_every_shell_balances_with_the_walls_boundary_force(shells):
    full = balance(shells, closed=True)
    bare = balance(shells, terms=(), closed=True)
    assert full["terms"] == ["boundary"] and full["residual"].shape == (3, 5)
    assert np.all(np.abs(full["residual"]) < 0.1), full["residual"]
    assert np.abs(bare["residual"][:, [0, -1]]).max() > 1.0            # the walls' shells


def test_the_shells_round_trip_through_netcdf_and_vtk(shells, tmp_path):
    """The CLI's --netcdf and --vtk on the shells: xarray reads back every value and
    error on the (r, z) grid with units; meshio reads back the revolved cylinder, whose
    Cartesian velocity is v_phi e_phi (+ v_r e_r) at each sector."""
    import meshio
    import xarray as xr

    out = Path(shells.meta["files"]["atoms"]).parent
    dest = tmp_path / "s.csv"
    proc = run_cli("average", "--atoms", out / "atoms.dump", "--contacts",
                   out / "contacts.dump", "--contact-columns", MAP, "--wall-types", 2, 3,
                   "--r-range", R_I, R_O, "--bins", 5, "--layers", 2, "--out", dest,
                   "--netcdf", "--vtk", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    p = read_profiles(dest)
    ds = xr.open_dataset(tmp_path / "s.csv.nc", engine="scipy")
    assert ds["v_phi"].dims == ("r", "z") and ds["v_phi"].shape == (5, 2)
    assert np.allclose(ds["v_phi"].values.ravel(), p.values["v_phi"], rtol=1e-9, atol=0)
    assert np.allclose(ds["sigma_phir_sem"].values.ravel(), p.sem["sigma_phir"], rtol=1e-9)
    assert ds["sigma_rr"].attrs["units"] == "Pa" and ds["r"].attrs["units"] == "m"
    assert np.allclose(ds["r_edges"].values, p.cells.edges)
    assert '"shells"' in ds.attrs["geometry"]
    mesh = meshio.read(tmp_path / "s.csv.vtu")
    hexes = mesh.cells_dict["hexahedron"]
    assert len(hexes) == 5 * 2 * 48
    centre = mesh.points[hexes].mean(axis=1)
    v = mesh.cell_data_dict["v"]["hexahedron"]
    phi = np.arctan2(centre[:, 1], centre[:, 0])
    e_phi = np.column_stack([-np.sin(phi), np.cos(phi)])
    ring = np.clip(np.searchsorted(p.cells.edges, np.hypot(centre[:, 0], centre[:, 1])) - 1,
                   0, 4)
    layer = (centre[:, 2] > 0.003).astype(int)
    k = ring * 2 + layer
    # v . e_phi = v_phi at the sector's middle (the cell centre lies off it by < 0.1%)
    assert np.allclose(np.sum(v[:, :2] * e_phi, axis=1), p.values["v_phi"][k],
                       rtol=2e-3, atol=1e-9)
    assert np.allclose(mesh.cell_data_dict["nu"]["hexahedron"], p.values["nu"][k])
