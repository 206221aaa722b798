"""One way to build an average: every route - a run directory, anyone's dumps, in situ
while LAMMPS runs, dask workers, frames in memory through the API - goes through the
engine's averager and its checks. A kernel narrower than half the smallest particle
radius (its fields would resolve single particles) is refused in one line with exit
code 2 on each, before any frame is averaged; and the units the quantities declare are
the sidecar's and the NetCDF's."""

import json

import numpy as np
import pytest

import granavg
from granavg.errors import ParameterError

from .conftest import SMALL_CELL, run_cli

RUN = granavg.examples.couette_2d.run
PILE = granavg.examples.pile_3d
MAP3 = ",".join(f"{k}={v}" for k, v in PILE.contact_map.items())
NARROW = ("--kernel", "lucy", "--width", 1e-5)


def refused_in_one_line(proc):
    lines = proc.stderr.strip().splitlines()
    return proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr and \
        "--width 1e-05: below half the smallest particle radius" in lines[0]


@pytest.mark.parametrize("route", ["run", "run on dask", "dumps"])
def test_a_width_below_the_particles_is_refused_on_every_averaging_route(route, tmp_path):
    args = {"run": [RUN, "--t-min", 1],
            "run on dask": [RUN, "--t-min", 1, "--workers", 2],
            "dumps": ["--atoms", PILE.atoms, "--contacts", PILE.contacts,
                      "--contact-columns", MAP3, "--slabs", "z", "--bins", 6]}[route]
    proc = run_cli("average", *args, *NARROW, "--out", tmp_path / "p.csv", "--no-progress")
    assert refused_in_one_line(proc), proc.stderr
    assert not list(tmp_path.iterdir())


def test_a_width_below_the_disks_is_refused_before_an_in_situ_run_starts(tmp_path):
    sets = [a for s in SMALL_CELL for a in ("--set", s)]
    proc = run_cli("simulate", "--preset", "paper-hooke", *sets, "--average", 4, *NARROW,
                   "--out", tmp_path / "run", "--no-progress")
    assert refused_in_one_line(proc), proc.stderr
    assert not (tmp_path / "run").exists()
    proc = run_cli("simulate", "--preset", "paper-hooke", *sets, "--kernel", "lucy",
                   "--width", 0.008, "--out", tmp_path / "run", "--no-progress")
    assert proc.returncode == 2 and "--average N" in proc.stderr


def test_frames_in_memory_are_refused_the_same_through_the_api():
    from granavg.io.formats import open_frames
    from granavg.cells import Slabs3D

    frames = list(open_frames(PILE.atoms))
    cells = Slabs3D(np.linspace(0.0, 0.024, 7), "z", 0.016 ** 2)
    with pytest.raises(ParameterError, match="below half the smallest particle radius"):
        granavg.average(frames, cells=cells, kernel="lucy", width=1e-5)
    fields = granavg.average(frames, cells=cells, quantities=["nu"])
    assert fields.n_frames == 3 and fields.units["nu"] == "1"


@pytest.mark.slow
def test_the_units_of_the_gradients_follow_from_their_dimensions(tmp_path):
    """An SI run with a kernel: the sidecar and the NetCDF say 1/s for gradv, D and W,
    Pa/m for divsigma and divdsigma (they were guessed as 1)."""
    out = tmp_path / "k.csv"
    proc = run_cli("average", RUN, "--t-min", 1, "--bins", 6, "--kernel", "lucy", "--width",
                   0.008, "--netcdf", "--out", out, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    units = json.loads(out.with_name("k.csv.json").read_text())["columns"]
    import xarray as xr
    ds = xr.open_dataset(out.with_name("k.csv.nc"))
    for prefix, unit in (("gradv_", "1/s"), ("D_", "1/s"), ("W_", "1/s"),
                         ("divsigma_", "Pa/m"), ("divdsigma_", "Pa/m")):
        cols = [c for c in units if c.startswith(prefix)]
        assert cols and all(units[c] == unit for c in cols), prefix
        assert all(ds[c].attrs["units"] == unit for c in cols), prefix
    ds.close()
