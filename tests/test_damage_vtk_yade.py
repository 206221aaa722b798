"""Damaged VTK particle files and Yade input, case by case (tests/damage.py):

- LIGGGHTS' ``dump custom/vtk`` of the mesh-floor pile (tests/decks/pile_liggghts.lig),
  legacy ``.vtk`` and XML ``.vtp``, both ASCII;
- Yade's export of a small pile (tests/decks/pile_yade.py, 300 spheres, 4 frames):
  VTKRecorder's spheres and pericell files (compressed XML) and VTKExporter's
  interactions (legacy ASCII);
- Yade in process (granavg.pipeline.yade.YadeAverage in Yade's own Python): a frame
  taken from a damaged scene.

A damaged file is refused in one line (exit 2) naming it, without a traceback or output;
harmless differences leave the numbers as they were; in process, a damaged scene raises
granavg's UserError with a one-line message instead of giving NaN fields."""

import json
import shutil

import numpy as np
import pytest

from .damage import (LegacyVtk, XmlVtk, accepted, average, drop_values, out_path, refused,
                     run_liggghts, run_yade, same_numbers, shared_run, yade_python)
from .helpers import DECKS

pytestmark = pytest.mark.slow


#: What a line about a cut file says, in one of these words.
CUT = ("cut", "damaged", "truncated", "incomplete", "ends")


# -- LIGGGHTS' dump custom/vtk -------------------------------------------------------------

@pytest.fixture(scope="module")
def liggghts(tmp_path_factory):
    if shutil.which("liggghts") is None:
        pytest.skip("liggghts not installed: apt-get install -y liggghts")
    return shared_run(tmp_path_factory, "damage_liggghts_mesh", run_liggghts)


def vtk_options(d, suffix, out):
    return ("--atoms", d / f"atoms_*.{suffix}", "--dt", 1e-5, "--units", "si", "--slabs",
            "z", "--range", 0, 0.048, "--bins", 8, "--out", out)


@pytest.fixture(scope="module")
def liggghts_clean(liggghts, tmp_path_factory):
    pytest.importorskip("vtk")
    d = tmp_path_factory.mktemp("damage_vtk_clean")
    return {s: accepted(average(*vtk_options(liggghts, s, d / f"{s}.csv")), d / f"{s}.csv")
            for s in ("vtk", "vtp")}


def _liggghts_copy(liggghts, tmp_path, suffix):
    d = tmp_path / "run"
    d.mkdir()
    for p in liggghts.glob(f"atoms_*.{suffix}"):
        shutil.copy(p, d / p.name)
    for p in liggghts.glob("atoms_boundingBox_*"):
        shutil.copy(p, d / p.name)
    return d


def _array(doc, name):
    """The values of the point array ``name`` (POINTS: the positions)."""
    if isinstance(doc, XmlVtk):
        return doc.values(name)
    head = doc.header("POINTS" if name == "Points" else rf"{name} \d+ \d+ ")
    return doc.values(head)


def _cut(doc, suffix):
    where = _array(doc, "v")
    k = where[len(where) // 2][0]
    doc.lines = doc.lines[:k] + [doc.lines[k][:len(doc.lines[k]) // 2]]


def _radius_short(doc, suffix):
    where = _array(doc, "radius")
    drop_values(doc, where[-10:])
    if suffix == "vtk":                      # the header says as many as it holds
        head = doc.header(r"radius \d+ \d+ ")
        n = len(where) - 10
        doc.lines[head] = f"radius 1 {n} double\n"


def _nan(name):
    def damage(doc, suffix):                  # the eleventh point's z (vz)
        doc.set_value(_array(doc, name)[32], "nan")
    return damage


@pytest.mark.parametrize("suffix", ["vtk", "vtp"])
@pytest.mark.parametrize("damage, needles", [
    (_cut, (CUT,)),
    (_radius_short, ("radius",)),
    (_nan("Points"), (("NaN", "nan"),)),
    (_nan("v"), (("NaN", "nan"),)),
], ids=["cut-mid-array", "radius-array-short", "nan-position", "nan-velocity"])
def test_a_damaged_liggghts_vtk_file_is_refused_naming_it(liggghts, liggghts_clean,
                                                          tmp_path, suffix, damage, needles):
    d = _liggghts_copy(liggghts, tmp_path, suffix)
    bad = d / f"atoms_46000.{suffix}"
    doc = XmlVtk(bad) if suffix == "vtp" else LegacyVtk(bad)
    damage(doc, suffix)
    doc.write()
    out = out_path(tmp_path)
    refused(average(*vtk_options(d, suffix, out)), out, str(bad), *needles,
            clean=liggghts_clean[suffix])


# -- Yade's export -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def yade(tmp_path_factory):
    """(python, environment) of Yade with this checkout's granavg."""
    if shutil.which("yade") is None:
        pytest.skip("yade not installed: apt-get install -y python3-yade yade")
    return yade_python(tmp_path_factory)


@pytest.fixture(scope="module")
def yade_pile(tmp_path_factory, yade):
    """tests/decks/pile_yade.py with 300 spheres and 4 frames (about 30 s)."""
    def build(d):
        proc = run_yade(*yade, DECKS / "pile_yade.py", d, "n=300", "frames=4", cwd=d)
        assert proc.returncode == 0 and (d / "run.json").exists(), proc.stderr[-3000:]
    return shared_run(tmp_path_factory, "damage_yade_pile", build)


def yade_options(vtk, out, dt):
    return ("--atoms", vtk / "pile-spheres.*.vtu", "--contacts", vtk / "pile-intrs-*.vtk",
            "--format", "yade-vtk", "--dt", dt, "--gravity", 0, 0, -9.81, "--slabs", "z",
            "--range", 0, 0.012, "--bins", 4, "--out", out)


@pytest.fixture(scope="module")
def yade_clean(yade_pile, tmp_path_factory):
    pytest.importorskip("vtk")
    out = tmp_path_factory.mktemp("damage_yade_clean") / "p.csv"
    return accepted(average(*yade_options(yade_pile / "vtk", out, _dt(yade_pile))), out)


def _dt(pile):
    return json.loads((pile / "run.json").read_text())["dt"]


def _steps(vtk):
    return sorted(int(p.name.split(".")[1]) for p in vtk.glob("pile-spheres.*.vtu"))


def _rewrite_spheres(path, edit):
    """Yade's spheres file read by VTK, ``edit(points, arrays)`` (numpy, in place or a
    dict entry replaced), written back as VTKRecorder writes it (appended, zlib)."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader, vtkXMLUnstructuredGridWriter

    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
    r.Update()
    grid = r.GetOutput()
    pd = grid.GetPointData()
    points = vtk_to_numpy(grid.GetPoints().GetData()).copy()
    arrays = {pd.GetArrayName(k): vtk_to_numpy(pd.GetArray(k)).copy()
              for k in range(pd.GetNumberOfArrays())}
    edit(points, arrays)
    grid.GetPoints().SetData(numpy_to_vtk(points, deep=1))
    for name, a in arrays.items():
        pd.RemoveArray(name)
        v = numpy_to_vtk(a, deep=1)
        v.SetName(name)
        pd.AddArray(v)
    w = vtkXMLUnstructuredGridWriter()
    w.SetFileName(str(path))
    w.SetInputData(grid)
    w.SetCompressorTypeToZLib()
    w.SetDataModeToAppended()
    w.Write()


def _spheres_cut(vtk, step):
    p = vtk / f"pile-spheres.{step}.vtu"
    raw = p.read_bytes()
    p.write_bytes(raw[:int(0.6 * len(raw))])
    return p, ()


def _spheres_edit(edit, needles):
    def damage(vtk, step):
        p = vtk / f"pile-spheres.{step}.vtu"
        _rewrite_spheres(p, edit)
        return p, needles
    return damage


def _short_radii(points, arrays):
    arrays["radii"] = arrays["radii"][:-10]


def _nan_point(points, arrays):
    points[5, 2] = np.nan


def _nan_velocity(points, arrays):
    arrays["linVelVec"][5, 0] = np.nan


def _moved(points, arrays):
    """The spheres as a later step of a flowing pile would have them: each moved by a
    tenth of its radius."""
    rng = np.random.default_rng(5)
    points += 0.1 * arrays["radii"][:, None] * rng.standard_normal(points.shape)


def _renumbered(points, arrays):
    """The spheres of another run of the same size: the same ids, in another order."""
    arrays["id"] = np.random.default_rng(6).permutation(arrays["id"])


def _intrs(vtk, step):
    return vtk / f"pile-intrs-{step:08d}.vtk"


def _normal_long(vtk, step):
    p = _intrs(vtk, step)
    doc = LegacyVtk(p)
    where = doc.values(doc.header("VECTORS normal "))
    for w in where[9:12]:                                     # the fourth contact's
        doc.set_value(w, repr(1.1 * doc.get_value(w)))
    doc.write()
    return p, ("unit",)


def _nan_force(vtk, step):
    p = _intrs(vtk, step)
    doc = LegacyVtk(p)
    doc.set_value(doc.values(doc.header("VECTORS normalForce "))[9], "nan")
    doc.write()
    return p, (("NaN", "nan"),)


def _id_damaged(new):
    """The fourth interaction's id2 replaced by ``new(doc, old)``."""
    def damage(vtk, step):
        p = _intrs(vtk, step)
        doc = LegacyVtk(p)
        ids = doc.values(doc.header("SCALARS id2 "), skip=1)
        spheres = doc.values(doc.header("SCALARS id1 "), skip=1)
        doc.set_value(ids[3], new([doc.get_value(w) for w in spheres + ids],
                                  doc.get_value(ids[3])))
        doc.write()
        return p, ("id", "body")
    return damage


def _no_pericell(vtk, step):
    first = _steps(vtk)[0]
    p = vtk / f"pile-pericell.{first}.vtu"
    p.unlink()
    return p.parent, ("pericell",)


@pytest.mark.parametrize("damage", [
    lambda vtk, step: (_spheres_cut(vtk, step)[0], (CUT,)),
    _spheres_edit(_short_radii, ("radi",)),
    _spheres_edit(_nan_point, (("NaN", "nan"),)),
    _spheres_edit(_nan_velocity, (("NaN", "nan"),)),
    _no_pericell,
    _normal_long,
    _nan_force,
    _spheres_edit(_moved, ("different steps",)),
    _spheres_edit(_renumbered, ("different steps",)),
    _id_damaged(lambda ids, old: 99999),
    _id_damaged(lambda ids, old: next(int(i) for i in ids if i not in (old, 0))),
], ids=["spheres-cut-mid-array", "radii-array-short", "nan-position", "nan-velocity",
        "pericell-missing", "contact-normal-not-unit", "nan-contact-force",
        "spheres-of-another-step", "spheres-of-another-run", "id-not-among-spheres",
        "id-of-another-sphere"])
def test_a_damaged_yade_export_is_refused_naming_the_file(yade_pile, yade_clean, tmp_path,
                                                          damage):
    """The second frame's file damaged (pericell-missing: the first frame's pericell file,
    the others there); the line names the file (pericell: its folder at least)."""
    vtk = shutil.copytree(yade_pile / "vtk", tmp_path / "vtk")
    bad, needles = damage(vtk, _steps(vtk)[1])
    out = out_path(tmp_path)
    refused(average(*yade_options(vtk, out, _dt(yade_pile))), out, str(bad), *needles,
            clean=yade_clean)


def test_a_yade_export_in_a_folder_named_spheres_averages_as_anywhere(yade_pile, yade_clean,
                                                                      tmp_path):
    """The pericell file is found by its own name, not by replacing 'spheres' anywhere
    in the path: the same numbers as in the clean folder."""
    vtk = shutil.copytree(yade_pile / "vtk", tmp_path / "spheres_run" / "vtk_spheres")
    out = out_path(tmp_path)
    same_numbers(average(*yade_options(vtk, out, _dt(yade_pile))), out, yade_clean)


# -- Yade in process -----------------------------------------------------------------------

#: A small periodic pile in Yade, settled and saved; then, per case, a YadeAverage fed a
#: clean frame and a damaged one (or, after loading the saved scene, a frame at once),
#: and what happened written to OUT/results.json.
SCRIPT = r'''
import json
import sys
import traceback

import numpy as np
from yade import utils
from yade.wrapper import (Bo1_Box_Aabb, Bo1_Sphere_Aabb, ForceResetter, FrictMat,
                          Ig2_Box_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom,
                          InsertionSortCollider, InteractionLoop,
                          Ip2_FrictMat_FrictMat_FrictPhys, Law2_ScGeom_FrictPhys_CundallStrack,
                          NewtonIntegrator, Omega)

from granavg.errors import UserError
from granavg.pipeline.yade import YadeAverage

OUT = sys.argv[1]
SAVED = OUT + "/scene.yade.gz"
CELLS = {"slabs": "z", "range": (0.0, 0.006), "bins": 3}
O = Omega()
O.periodic = True
O.cell.setBox(0.016, 0.016, 0.1)
O.materials.append(FrictMat(young=1e6, poisson=0.3, density=2500, frictionAngle=0.5))
O.bodies.append(utils.box((0.008, 0.008, -1e-3), (0.008, 0.008, 1e-3), fixed=True))
rng = np.random.default_rng(1)
for k in range(60):
    layer, cell = divmod(k, 16)
    i, j = divmod(cell, 4)
    O.bodies.append(utils.sphere(((i + 0.5) * 0.004, (j + 0.5) * 0.004,
                                  1.3e-3 + layer * 0.0025),
                                 1e-3 if rng.random() < 0.5 else 1.2e-3))
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()],
                                   allowBiggerThanPeriod=True),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                             [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.5)]
O.dt = 0.5 * utils.PWaveTimeStep()
O.run(20000, True)
O.save(SAVED)
SPHERE = 20                                     # a body id of a sphere


def nan_velocity():
    O.bodies[SPHERE].state.vel = (float("nan"), 0, 0)


def negative_radius():
    O.bodies[SPHERE].shape.radius = -O.bodies[SPHERE].shape.radius


def case(damage, fresh_load=False):
    O.load(SAVED)
    if not fresh_load:
        O.step()
    average = YadeAverage(CELLS)
    result = {"raised": None, "user_error": False, "message": None, "nan_cells": None}
    try:
        if not fresh_load:
            average.add()
            O.run(100, True)
        if damage:
            damage()
        average.add()
        O.run(100, True)
        average.add()
        fields = average.conclude()
        result["nan_cells"] = {k: int(np.sum(~np.isfinite(v))) for k, v in fields.values.items()}
        result["values"] = {k: [float(x) for x in np.ravel(v)] for k, v in fields.values.items()}
    except Exception as exc:
        result.update(raised=type(exc).__module__ + "." + type(exc).__name__,
                      user_error=isinstance(exc, UserError), message=str(exc),
                      traceback=traceback.format_exc()[-1500:])
    return result


results = {"clean": case(None), "nan-velocity": case(nan_velocity),
           "negative-radius": case(negative_radius),
           "add-right-after-load": case(None, fresh_load=True), "sphere": SPHERE}
with open(OUT + "/results.json", "w") as fh:
    json.dump(results, fh, indent=1)
'''


@pytest.fixture(scope="module")
def inprocess(yade, tmp_path_factory):
    d = tmp_path_factory.mktemp("damage_yade_inprocess")
    (d / "damage.py").write_text(SCRIPT)
    proc = run_yade(*yade, d / "damage.py", d, cwd=d)
    assert proc.returncode == 0 and (d / "results.json").exists(), proc.stderr[-3000:]
    results = json.loads((d / "results.json").read_text())
    assert results["clean"]["raised"] is None, results["clean"]
    return results


@pytest.mark.parametrize("case, needles", [
    ("nan-velocity", (("NaN", "nan"), "body {sphere}")),
    ("negative-radius", ("radius", "body {sphere}")),
    ("add-right-after-load", (("penetration", "O.step", "step"),)),
], ids=["nan-velocity", "negative-radius", "add-right-after-load"])
def test_a_damaged_yade_scene_raises_one_line_instead_of_nan_fields(inprocess, case, needles):
    got, clean = inprocess[case], inprocess["clean"]
    if got["raised"] is None:
        more = {k: n - clean["nan_cells"].get(k, 0) for k, n in got["nan_cells"].items()
                if n != clean["nan_cells"].get(k, 0)}
        worst, name = 0.0, None
        for k, v in got["values"].items():
            a, b = np.array(v), np.array(clean["values"].get(k, v))
            both = np.isfinite(a) & np.isfinite(b)
            scale = np.max(np.abs(b[both]), initial=0.0)
            off = np.max(np.abs(a - b)[both], initial=0.0) / scale if scale > 0 else 0.0
            if off > worst:
                worst, name = off, k
        raise AssertionError(f"DEFECT silent wrong: no error; non-finite cells beyond the "
                             f"clean run's: {dict(list(more.items())[:8])} "
                             f"({len(more)} fields); largest difference elsewhere "
                             f"{worst:.3g} of the largest value, in {name}")
    assert got["user_error"], f"DEFECT traceback: {got['raised']}: {got['message']}"
    message = got["message"]
    assert "\n" not in message.strip(), f"WEAK message: several lines: {message!r}"
    needles = [tuple(x.format(sphere=inprocess["sphere"]) for x in n) if isinstance(n, tuple)
               else n.format(sphere=inprocess["sphere"]) for n in needles]
    missing = [n for n in needles if not (any(x in message for x in n) if isinstance(n, tuple)
                                          else n in message)]
    assert not missing, f"WEAK message: lacks {missing}: {message}"
    print(f"observed: UserError: {message}")
