"""Fields as NetCDF (xarray) and VTK (meshio): written and read back, on boxes, a 2D
grid and slabs, with the cells where they belong."""

import meshio
import numpy as np
import pytest
import xarray as xr

from granavg.engine import average
from granavg.cells import Boxes, Grid, Slabs3D
from granavg.errors import UserError
from granavg.io.field_files import write_netcdf, write_vtk
from granavg.io.frames import Frame

from .helpers import CUBIC_RHO_P as RHO_P, cubic_crystal


@pytest.fixture(scope="module")
def boxes():
    frame = cubic_crystal()
    atoms = dict(frame.atoms)
    atoms["vx"] = 0.1 * atoms["z"]                    # a shear flow along x, varying in z
    frames = [Frame(k, float(k), atoms, frame.contacts) for k in range(3)]
    cells = Boxes(np.linspace(-0.012, 0.012, 4), np.linspace(-0.012, 0.012, 3),
                  np.linspace(-0.012, 0.012, 5))
    return average(frames, cells, density=RHO_P, sectors=None)


def test_boxes_round_trip_through_netcdf(boxes, tmp_path):
    write_netcdf(boxes, tmp_path / "b.nc")
    ds = xr.open_dataset(tmp_path / "b.nc", engine="scipy")
    assert ds["nu"].dims == ("x", "y", "z") and ds["nu"].shape == (3, 2, 4)
    for name in ("nu", "v_x", "sigma_zz", "F_xy", "eps_yy"):
        assert np.array_equal(ds[name].values.ravel(), boxes.values[name])
        assert np.array_equal(ds[f"{name}_sem"].values.ravel(), boxes.sem[name], equal_nan=True)
    # cell k = (i ny + j) nz + l sits at x_i, y_j, z_l
    i, j, l = 2, 1, 3
    k = (i * 2 + j) * 4 + l
    assert ds["v_x"].values[i, j, l] == boxes.values["v_x"][k]
    assert ds["z"].values[l] == pytest.approx(0.5 * (boxes.cells.zedges[l] + boxes.cells.zedges[l + 1]))
    assert ds["v_x"].attrs["units"] == "m/s" and ds["V"].attrs["units"] == "m^3"
    assert not (tmp_path / ".b.nc.tmp").exists() and len(list(tmp_path.iterdir())) == 1


def test_boxes_round_trip_through_vtk(boxes, tmp_path):
    write_vtk(boxes, tmp_path / "b.vtu")
    mesh = meshio.read(tmp_path / "b.vtu")
    hexes = mesh.cells_dict["hexahedron"]
    assert len(hexes) == boxes.cells.n
    centre = mesh.points[hexes].mean(axis=1)
    cells = boxes.cells.cell_of(tuple(centre.T))
    assert np.array_equal(cells, np.arange(boxes.cells.n))       # the k-th hexahedron is cell k
    volume = np.prod(mesh.points[hexes].max(axis=1) - mesh.points[hexes].min(axis=1), axis=1)
    assert np.allclose(volume, boxes.cells.volume, rtol=1e-12)
    data = mesh.cell_data_dict
    assert np.array_equal(data["v"]["hexahedron"][:, 0], boxes.values["v_x"])
    sigma = data["sigma"]["hexahedron"].reshape(-1, 3, 3)
    assert np.array_equal(sigma[:, 2, 1], boxes.values["sigma_zy"])
    assert np.array_equal(data["sigma_zy_sem"]["hexahedron"], boxes.sem["sigma_zy"])


def test_a_2d_grid_is_quadrilaterals_and_slabs_have_no_vtk(tmp_path):
    rng = np.random.default_rng(2)
    atoms = {"x": rng.uniform(0, 1, 400), "y": rng.uniform(0, 1, 400),
             "radius": np.full(400, 0.01), "vx": np.ones(400), "vy": np.zeros(400)}
    frames = [Frame(k, float(k), atoms, None) for k in range(2)]
    grid = average(frames, Grid(np.linspace(0, 1, 5), np.linspace(0, 1, 4), 0.01),
                   density=1000.0, quantities=["nu", "v"])
    write_vtk(grid, tmp_path / "g.vtu")
    mesh = meshio.read(tmp_path / "g.vtu")
    quads = mesh.cells_dict["quad"]
    assert len(quads) == 12 and np.all(mesh.points[:, 2] == 0)
    centre = mesh.points[quads].mean(axis=1)
    assert np.array_equal(grid.cells.cell_of((centre[:, 0], centre[:, 1])), np.arange(12))
    assert np.allclose(mesh.cell_data_dict["v"]["quad"][:, 0], 1.0)
    spheres = {**atoms, "z": rng.uniform(0, 1, 400)}
    slabs = average([Frame(k, float(k), spheres, None) for k in range(2)],
                    Slabs3D(np.linspace(0, 1, 4), "z", 1.0), quantities=["nu"], sectors=None)
    assert slabs.to_xarray()["nu"].dims == ("z",)
    with pytest.raises(UserError, match="VTK output is for grids"):
        write_vtk(slabs, tmp_path / "s.vtu")
    assert not (tmp_path / "s.vtu").exists()
