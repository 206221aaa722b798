"""A sheared periodic box (Lees-Edwards boundaries: lammps_inputs/shear_2d.lmp, fix
deform xy erate remap v): the images across its y faces sit at x + xy and move with
v_x + d(xy)/dt in every sum, exact cells and kernels alike.

The answers: the imposed rate (the velocity gradient at every node, the faces
included; the end slabs on the linear profile), an independent numpy sum over the
explicitly shifted images (to round-off), and the lattice of images by hand."""

from pathlib import Path

import numpy as np
import pytest

import granavg
from granavg.engine import gate as gate_module
from granavg.engine.cells.base import Shear, with_images
from granavg.io.reader import DumpReader
from granavg.sim.lammps_session import lammps_session

from .helpers import cli

DECK = Path(__file__).resolve().parents[1] / "lammps_inputs" / "shear_2d.lmp"
MAP = dict(kv.split("=") for kv in
           "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
           "ftx=c_pl[5],fty=c_pl[6]".split(","))
#: The deck's shear rate (1/s) and its disks' mean diameter (m).
RATE, D = 20.0, 0.002


def _run(out: Path, **variables) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    args = ["-log", str(out / "log.lammps"), "-screen", "none", "-var", "out", str(out)]
    for k, v in variables.items():
        args += ["-var", k, str(v)]
    with lammps_session(args) as lmp:
        lmp.file(str(DECK))
    return out


@pytest.fixture(scope="module")
def sheared(tmp_path_factory):
    """250 disks at area fraction 0.76 sheared at 20/s: 400 frames over a strain of 200,
    after a strain of 3 (about 25 s). Its slowest modes - velocity profiles one box long
    that live for a strain of about 15 - leave about 10% on a strain of 15 and 3% on 200."""
    return _run(tmp_path_factory.mktemp("shear"), n=250, phi=0.76, strain=200, frames=400)


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    """The deck's defaults shortened: 20 frames over a strain of 2 (the tilt flips twice)."""
    return _run(tmp_path_factory.mktemp("shear_short"), strain=2, frames=20, settle=1)


def _average(run, **kw):
    return granavg.average(run / "atoms.dump", contacts=run / "contacts.dump",
                           contact_map=MAP, **kw)


@pytest.mark.slow
def test_the_velocity_gradient_is_the_rate_at_every_node(sheared):
    """Lucy planes across y (w = 6 d, 12 nodes): d v_x / dy within 5% of the rate at every
    node, the two at the faces included. Images that do not move (v_x unshifted) put the
    nodes at the faces off by more than half the rate: the check can fail."""
    f = _average(sheared, cells={"slabs": "y", "bins": 12, "thickness": D}, kernel="lucy",
                 width=6 * D, quantities=["v", "gradv"])
    g = f.values["gradv_xy"] / RATE
    assert np.all(np.abs(g - 1) < 0.05), g
    assert np.all(f.sem["gradv_xy"] / RATE < 0.05)


@pytest.mark.slow
def test_images_that_do_not_move_are_wrong_at_the_faces(sheared, monkeypatch):
    """The same average with the tilt's rate taken as 0: the nodes within the kernel's
    reach of the y faces lose the rate (the defect of images copied unshifted)."""
    def still(self, frame, b):
        frame.shear = Shear(tuple(float(v) for v in b.tilt), (0.0, 0.0, 0.0))
    monkeypatch.setattr(gate_module.Gate, "_shear", still)
    f = _average(sheared, cells={"slabs": "y", "bins": 12, "thickness": D}, kernel="lucy",
                 width=6 * D, quantities=["v", "gradv"])
    g = f.values["gradv_xy"] / RATE
    assert abs(g[0] - 1) > 0.5 and abs(g[-1] - 1) > 0.5, g


@pytest.mark.slow
def test_the_end_slabs_lie_on_the_linear_profile(sheared):
    """Exact slabs across y: v_x of the two end slabs (whose disks straddle the faces)
    on the line through the inner slabs within 2 errors, whose slope is the rate within
    2 errors (from the replicates: the slabs' errors are correlated)."""
    f = _average(sheared, cells={"slabs": "y", "bins": 12, "thickness": D},
                 quantities=["v"])
    y = 0.5 * (f.cells.edges[1:] + f.cells.edges[:-1])
    v, e = f.values["v_x"], f.sem["v_x"]
    inner = slice(1, -1)
    w = 1 / e[inner] ** 2
    A = np.column_stack([np.ones(10), y[inner]])
    cov = np.linalg.inv(A.T @ (A * w[:, None]))
    c = cov @ A.T @ (w * v[inner])
    line = c[0] + c[1] * y
    assert np.all(np.abs(v[[0, -1]] - line[[0, -1]]) < 2 * np.hypot(e[[0, -1]], np.sqrt(
        cov[0, 0] + 2 * cov[0, 1] * y[[0, -1]] + cov[1, 1] * y[[0, -1]] ** 2))), \
        (v - line) / e
    # the slope's error from the replicates (the slabs' errors are correlated: the
    # flow's slowest modes span the box)
    reps = f.replicates
    slopes = [np.polyfit(y[inner], r[inner], 1)[0] for r in reps.values["v_x"]]
    slope = np.polyfit(y[inner], v[inner], 1)[0]
    assert abs(slope - RATE) < 2 * reps.error(slopes), (slope, reps.error(slopes))


def _lucy(r, c):
    q = np.minimum(np.abs(r) / c, 1.0)
    return (1 + 3 * q) * (1 - q) ** 3


def _lucy_slope(r, c):
    """d/dr of the Lucy polynomial at distance r."""
    q = np.minimum(np.abs(r) / c, 1.0)
    return -12 * q * (1 - q) ** 2 / c


@pytest.mark.slow
def test_a_grid_equals_a_numpy_sum_over_the_shifted_images(short):
    """A Lucy grid (2D kernel, 5 x 6 nodes) against numpy: every disk and its 8 images
    at x + i lx + j xy, y + j ly, moving with v_x + j d(xy)/dt (the tilt's change between
    frames, taken across its flips), summed per frame and averaged: v and d v_x / dy
    agree to 1e-9 at every node; the frames' tilts flip by lx twice."""
    c = 4 * D
    f = _average(short, cells={"grid": (5, 6), "thickness": D}, kernel="lucy", width=c,
                 quantities=["v", "gradv"])
    heads = list(DumpReader(short / "atoms.dump"))
    xs = f.to_pandas()
    nodes = np.column_stack([xs["x"], xs["y"]])
    tilts = np.array([h.tilt[0] for h in heads])
    times = np.array([h.time for h in heads])
    sums = []
    for k, h in enumerate(heads):
        a = h.as_dict()
        (_, _), (ylo, yhi), _ = h.box
        lx = (h.box[0][1] - max(0.0, tilts[k])) - (h.box[0][0] - min(0.0, tilts[k]))
        ly = yhi - ylo
        j0, j1 = (k - 1, k) if k else (0, 1)
        step = tilts[j1] - tilts[j0]
        rate = (step - lx * np.round(step / lx)) / (times[j1] - times[j0])
        s = np.zeros((4, len(nodes)))
        for i in (-1, 0, 1):
            for j in (-1, 0, 1):
                x = a["x"] + i * lx + j * tilts[k]
                y = a["y"] + j * ly
                v = a["vx"] + j * rate
                dx, dy = nodes[:, 0:1] - x, nodes[:, 1:2] - y
                r = np.hypot(dx, dy)
                w = _lucy(r, c)
                dw = _lucy_slope(r, c) * np.divide(dy, r, out=np.zeros_like(r), where=r > 0)
                s += np.array([w @ a["mass"], w @ (a["mass"] * v), dw @ a["mass"],
                               dw @ (a["mass"] * v)])
        sums.append(s)
    rho, mom, drho, dmom = np.mean(sums, axis=0)
    assert np.sum(np.abs(np.diff(tilts)) > 0.25 * lx) == 2
    assert np.allclose(f.values["v_x"], mom / rho, rtol=0, atol=1e-9 * RATE * ly)
    grad = (dmom * rho - mom * drho) / rho ** 2
    assert np.allclose(f.values["gradv_xy"], grad, rtol=0, atol=1e-9 * RATE)


@pytest.mark.slow
def test_exact_cells_hold_every_disk_and_the_flux_is_refused(short, capsys, tmp_path):
    """An exact grid of the box's brick holds every disk once at every frame (sum of
    nu V = the disks' area x h to 1e-12); fields of the displacements between frames are
    refused in one line where asked for, and left out of "all the data allow"."""
    f = _average(short, cells={"grid": (4, 4), "thickness": D}, quantities=["nu"],
                 density=2500.0)
    h = DumpReader(short / "atoms.dump")
    a = next(iter(h)).as_dict()["diameter"] / 2
    assert abs(np.sum(f.values["nu"] * f.cells.volume) / (np.pi * D * np.sum(a ** 2)) - 1) \
        < 1e-12
    common = ["average", "--atoms", short / "atoms.dump", "--thickness", D, "--grid", 4, 4,
              "--kernel", "lucy", "--width", 4 * D, "--time-kernel", "gauss",
              "--time-width", 0.01, "--times", 0.04, 0.06, 0.01, "--no-progress"]
    code, err = cli(capsys, *common, "--quantities", "continuity", "--out", tmp_path / "c.csv")
    errors = [ln for ln in err if "error:" in ln]
    assert code == 2 and len(errors) == 1 and "sheared" in errors[0], err
    code, err = cli(capsys, *common, "--out", tmp_path / "a.csv")
    assert code == 0, err
    assert "continuity_v" in (tmp_path / "a.csv").read_text().splitlines()[0]
    assert "mass_flux" not in (tmp_path / "a.csv").read_text().splitlines()[0]
    assert ",continuity," not in (tmp_path / "a.csv").read_text().splitlines()[0]


def test_the_images_of_a_sheared_box_by_hand():
    """Disks in a 2D box of 10 x 8 tilted by xy = 3 at rate 0.5: the one at (8.5, 0.3)
    has its image across the y face at (8.5 + 3, 8.3), folded back along x to (1.5, 8.3),
    moving with v_x + 0.5 in a row of its own after the particles'; the one at (9.8, 4)
    its image across the x face at -0.2, unshifted, in its own row."""
    pos = (np.array([8.5, 5.0, 9.8]), np.array([0.3, 4.0, 4.0]))
    img = with_images(pos, np.full(3, 0.5), ((0.0, 10.0), (0.0, 8.0)),
                      Shear((3.0, 0.0, 0.0), (0.5, 0.0, 0.0)))
    got = {(round(float(x), 9), round(float(y), 9)): (int(i), int(r))
           for x, y, i, r in zip(*img.pos, img.index, img.row)}
    assert got == {(8.5, 0.3): (0, 0), (5.0, 4.0): (1, 1), (9.8, 4.0): (2, 2),
                   (1.5, 8.3): (0, 3), (-0.2, 4.0): (2, 2)}
    assert len(img.moving) == 1
    dv, particles = img.moving[0]
    assert np.allclose(dv, [0.5, 0.0]) and list(particles) == [0]
    q = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    atoms = {"vx": np.array([1.0, 2.0, 3.0]), "vy": np.zeros(3)}
    ext = img.extend(q, atoms, lambda at: np.column_stack([at["vx"], at["vy"]]))
    assert np.allclose(ext, [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [1.5, 0.0]])


def test_the_tilts_rate_across_a_flip():
    """Frames whose tilt flips from 0.48 lx to -0.48 lx (LAMMPS' flip yes past lx/2):
    the rate is the change less the flip, 0.04 lx per interval of 0.1."""
    from types import SimpleNamespace

    from granavg.io.box import Box

    g = gate_module.Gate(2)
    frames = []
    for step, xy in ((1, 4.6), (2, 4.8), (3, -4.8)):
        box = Box((0.0, 0.0, -0.5), (10.0, 8.0, 0.5), (xy, 0.0, 0.0), (True,) * 3)
        frames.append(SimpleNamespace(time=0.1 * step, box=box))
        g._shear(frames[-1], box)
    assert np.allclose(frames[1].shear.rate, (2.0, 0.0, 0.0))
    assert np.allclose(frames[2].shear.rate, (4.0, 0.0, 0.0))


@pytest.mark.slow
def test_workers_give_the_serial_fields(short):
    """Dask workers (chunks of frames, each taking its first frame's tilt rate from the
    frame after) give the serial fields of a sheared box exactly: the rate is
    constant."""
    kw = dict(cells={"grid": (5, 6), "thickness": D}, kernel="lucy", width=4 * D,
              quantities=["v", "gradv", "dsigma_fluct"])
    serial = _average(short, **kw)
    parallel = _average(short, workers=2, **kw)
    assert len(parallel.meta["dask"]["chunks"]) > 1
    for name, value in serial.values.items():
        assert np.array_equal(value, parallel.values[name], equal_nan=True), name
