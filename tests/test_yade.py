"""Yade as a source of granavg (granavg.io.yade in process, granavg.io.yade_vtk from its
VTK export), on a real Yade pile at rest (tests/decks/pile_yade.py, run once).

Yade runs in its own Python (Debian's, the launcher's shebang): the module fixture builds
a venv of it with its system packages (Yade, its numpy) and granavg's wheel, the
dependencies pinned to that numpy."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

if shutil.which("yade") is None:
    pytest.skip("yade not installed: apt-get install -y python3-yade yade",
                allow_module_level=True)

import granavg  # noqa: E402
from granavg.engine.cells import Space, from_options  # noqa: E402
from granavg.io.frames import Frame  # noqa: E402
from granavg.io.profiles_io import read_profiles  # noqa: E402

from .helpers import DECKS, run_cli  # noqa: E402

pytestmark = pytest.mark.slow

#: The fields compared between in process and the export, by family (a vector's or
#: tensor's components share their family's scale).
COMPARED = ("nu", "rho", "v", "omega", "coordination", "sigma", "dsigma", "F", "eps",
            "body", "boundary", "ekin")
#: In process and export differ by the export's precision: VTKRecorder's positions are
#: single floats (6e-8 of the cell), VTKExporter prints 6 digits (5e-6 of each force,
#: normal and overlap); 1e-5 of each family's largest value holds them (1.8e-7 measured).
AGREE = 1e-5


def _interpreter(launcher: str) -> str:
    """The Python the yade launcher runs (its shebang)."""
    with open(launcher) as fh:
        return fh.readline()[2:].strip()


@pytest.fixture(scope="module")
def yade_python(tmp_path_factory, wheel) -> Path:
    """A venv of Yade's own Python with its system packages and granavg (about 10 s
    beside the wheel)."""
    system = _interpreter(os.path.realpath(shutil.which("yade")))
    venv = tmp_path_factory.mktemp("yade_venv") / "venv"
    subprocess.run([system, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = venv / "bin" / "python"
    probe = subprocess.run([str(python), "-c", "import sys, numpy; print(numpy.__version__,"
                            " f'cp{sys.version_info[0]}{sys.version_info[1]}')"],
                           capture_output=True, text=True, check=True)
    numpy_version, tag = probe.stdout.split()
    pins = venv / "numpy.txt"
    pins.write_text(f"numpy=={numpy_version}\n")             # Yade's numpy stays
    source = str(wheel) if f"-{tag}-" in wheel.name else str(Path(__file__).parent.parent)
    install = subprocess.run([str(python), "-m", "pip", "install", "-q", "-c", str(pins),
                              source], capture_output=True, text=True, timeout=600)
    assert install.returncode == 0, install.stderr[-3000:]
    return python


@pytest.fixture(scope="module")
def pile(tmp_path_factory, yade_python) -> Path:
    """tests/decks/pile_yade.py run once: its output directory (about 35 s)."""
    out = tmp_path_factory.mktemp("pile_yade")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.run([str(yade_python), os.path.realpath(shutil.which("yade")), "-n",
                           "-x", str(DECKS / "pile_yade.py"), str(out)], cwd=out, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and (out / "run.json").exists(), proc.stderr[-3000:]
    return out


def _run(pile) -> dict:
    return json.loads((pile / "run.json").read_text())


def _frames(pile) -> list:
    """The frames the deck averaged in process, from frames.npz."""
    z = np.load(pile / "frames.npz")
    out = []
    for k, (step, t) in enumerate(zip(z["steps"], z["times"])):
        part = {side: {name.split("_", 1)[1]: z[name] for name in z.files
                       if name.startswith(f"{side}{k}_")} for side in ("atoms", "contacts")}
        out.append(Frame(int(step), float(t), part["atoms"], part["contacts"]))
    return out


def _carried(fields, atoms, g):
    """-sigma_zz times the cross-section over the weight of the spheres' parts above
    each slab's cuts (spherical caps), per slab."""
    above = []
    for lo, hi in zip(fields.cells.edges[:-1], fields.cells.edges[1:]):
        cuts = lo + (np.arange(400) + 0.5) / 400 * (hi - lo)
        u = np.clip((cuts[:, None] - atoms["z"][None, :]) / atoms["radius"][None, :], -1, 1)
        above.append(np.mean(((1 - u) ** 2 * (2 + u) / 4) @ atoms["mass"]) * g)
    return -fields.values["sigma_zz"] * fields.cells.area / np.array(above)


#: Slabs of 4 mm (1.67 large diameters) from the floor: the floor's and the one below
#: the free surface (the pile is 26 mm high) are left out.
BULK = slice(1, 5)


def test_the_pile_averaged_in_process_carries_its_weight(pile):
    fields = read_profiles(pile / "inprocess.csv")
    carried = _carried(fields, _frames(pile)[-1].atoms, 9.81)
    assert fields.cells.n == 6 and np.all(np.abs(carried[BULK] - 1) < 0.01), carried
    assert fields.meta["inputs"]["format"] == "yade" and fields.frames_averaged == 10


def test_the_vtk_export_averaged_by_the_cli_carries_it_too(pile, tmp_path):
    run = _run(pile)
    proc = run_cli("average", "--atoms", pile / "vtk" / "pile-spheres.*.vtu", "--contacts",
                   pile / "vtk" / "pile-intrs-*.vtk", "--format", "yade-vtk", "--dt",
                   run["dt"], "--gravity", *run["gravity"], "--slabs", "z", "--range", 0,
                   0.024, "--bins", 6, "--out", tmp_path / "export.csv", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    fields = read_profiles(tmp_path / "export.csv")
    carried = _carried(fields, _frames(pile)[-1].atoms, 9.81)
    assert np.all(np.abs(carried[BULK] - 1) < 0.01), carried
    assert fields.cells.area == pytest.approx(0.016 ** 2)        # the periodic cell's


def test_in_process_equals_the_export_and_the_frames_averaged_again(pile):
    run = _run(pile)
    inprocess = read_profiles(pile / "inprocess.csv")
    export = granavg.average(atoms=pile / "vtk" / "pile-spheres.*.vtu",
                             contacts=pile / "vtk" / "pile-intrs-*.vtk", fmt="yade-vtk",
                             dt=run["dt"], gravity=tuple(run["gravity"]), cells=run["cells"])
    cell = [(0.0, s) for s in run["cell"]]
    cells = from_options(Space(3, lambda: cell, lambda: (True,) * 3), **run["cells"])
    again = granavg.average(_frames(pile), cells=cells)
    assert set(export.values) == set(inprocess.values) == set(again.values)
    for family in COMPARED:
        names = [k for k in inprocess.values if k == family or
                 (k.startswith(family + "_") and len(k) - len(family) <= 3)]
        assert names, family
        scale = max(np.abs(inprocess.values[k]).max() for k in names)
        worst = max(np.abs(export.values[k] - inprocess.values[k]).max() for k in names)
        assert worst <= AGREE * scale, (family, worst / scale)
        for k in names:
            np.testing.assert_allclose(again.values[k], inprocess.values[k], rtol=1e-9,
                                       atol=1e-12 * scale)


def test_each_sphere_balances_its_weight_with_yade_conventions(pile):
    """The contact columns' forces on each sphere sum to Yade's own (O.forces.f) and,
    at rest, to minus its weight; a wall pushes the spheres on it up, along a normal
    from the sphere to the wall (down)."""
    frame = _frames(pile)[-1]
    atoms, c = frame.atoms, frame.contacts
    row = {int(i): r for r, i in enumerate(atoms["id"])}
    f = np.column_stack([c[f"fn{x}"] + c[f"ft{x}"] for x in "xyz"])
    total = np.zeros((len(row), 3))
    np.add.at(total, [row[int(i)] for i in c["id1"]], f)
    pair = c["wall"] == 0
    np.add.at(total, [row[int(i)] for i in c["id2"][pair]], -f[pair])
    yade = np.load(pile / "frames.npz")["yade_force"]
    assert np.abs(total - yade).max() < 1e-12 * np.abs(yade).max()
    weight = atoms["mass"] * 9.81
    residual = np.linalg.norm(total + np.outer(weight, [0, 0, -1]), axis=1) / weight
    assert residual.max() < 1e-4, residual.max()
    wall = c["wall"] == 1
    assert wall.sum() > 10 and np.all(c["fnz"][wall] > 0) and np.all(c["nz"][wall] < -0.9)
    normal = np.column_stack([c[f"n{x}"] for x in "xyz"])
    assert np.all(np.sum(f * normal, axis=1) < 0)             # repulsive: against n
    assert np.all(c["overlap"] > 0)
