"""A new engine's format with its own option is one file: a toy format outside granavg's
tree (installed as a package that names it under the entry-point group
``granavg.formats``) appears in ``granavg average --help`` with its flag, in
``--format``'s list, and as a keyword of ``granavg.average``, and its option reaches
the format: CSV tables whose lengths are in units of ``toy_length``."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

#: The whole plug-in: one file.
TOY = '''
"""Toy format: granavg's CSV tables (granavg.io.csv_frames), lengths in units of L."""

from granavg.engine.plugins import Option
from granavg.io.csv_frames import CsvFrames
from granavg.io.formats import Format

LENGTH = Option("toy_length", "the toy format's length unit L, in m", unit="m",
                metavar="L")


class ToyFrames(CsvFrames):
    format_name = "toy"

    def __init__(self, atoms, contacts=None, *, toy_length=1.0):
        super().__init__(atoms, contacts)
        self.scale = float(toy_length)

    def describe(self):
        return {**super().describe(), "toy_length": self.scale}

    def box(self):
        return tuple((lo * self.scale, hi * self.scale) for lo, hi in super().box())

    def __iter__(self):
        for frame in super().__iter__():
            for k in ("x", "y", "radius"):
                frame.atoms[k] = frame.atoms[k] * self.scale
            yield frame


FORMAT = Format("toy", "toy tables: CSV in units of L", lambda path: path.suffix == ".toy",
                ToyFrames, (LENGTH,))
'''


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    """The plug-in's file and the metadata of its installation (what pip writes)."""
    d = tmp_path_factory.mktemp("plugin")
    (d / "toy_format.py").write_text(TOY)
    info = d / "toy_format-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-format\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[granavg.formats]\ntoy = toy_format:FORMAT\n")
    rows = ["step,time,x,y,radius,vx,vy,id"]
    for step in range(3):
        rows += [f"{step},{0.1 * step},{0.2 + 0.5 * k},0.5,0.05,1.0,0.0,{k + 1}"
                 for k in range(2)]
    (d / "atoms.toy").write_text("\n".join(rows) + "\n")
    return d


def run(plugin, *args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(plugin), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          cwd=plugin)


def test_its_flag_and_name_are_in_the_help(plugin):
    proc = run(plugin, "-m", "granavg", "average", "--help")
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.split())
    assert "--toy-length L the toy format's length unit L, in m" in text
    assert "(csv, lammps, liggghts, toy, vtk, yade-vtk;" in text


def test_its_option_reaches_the_format_from_the_cli_and_the_api(plugin, tmp_path):
    """The same table with L = 1 and L = 2: the positions twice as far, the density in
    a cell of twice the size a quarter (2D, per unit thickness)."""
    out = {}
    for scale in (1, 2):
        path = tmp_path / f"cli{scale}.csv"
        proc = run(plugin, "-m", "granavg", "average", "--atoms", plugin / "atoms.toy",
                   "--toy-length", str(scale), "--density", "1000", "--slabs", "x",
                   "--range", "0", str(scale), "--bins", "2", "--thickness", "0.01",
                   "--quantities", "nu,rho", "--out", path, "--no-progress")
        assert proc.returncode == 0, proc.stderr
        out[scale] = json.loads(path.with_name(path.name + ".json").read_text())
    assert out[2]["inputs"]["toy_length"] == 2.0 and out[1]["inputs"]["format"] == "toy"
    code = textwrap.dedent(f"""
        import granavg, json
        from granavg.cells import Slabs
        import numpy as np
        f = granavg.average("{plugin / 'atoms.toy'}", toy_length=2.0, density=1000.0,
                            cells={{"slabs": "x", "range": (0, 2), "bins": 2,
                                    "thickness": 0.01}}, quantities=["nu"])
        g = granavg.average("{plugin / 'atoms.toy'}", toy_length=1.0, density=1000.0,
                            cells={{"slabs": "x", "range": (0, 1), "bins": 2,
                                    "thickness": 0.01}}, quantities=["nu"])
        print(json.dumps([list(f.values["nu"]), list(g.values["nu"])]))
    """)
    proc = run(plugin, "-c", code)
    assert proc.returncode == 0, proc.stderr
    twice, once = json.loads(proc.stdout.splitlines()[-1])
    assert np.allclose(twice, once, rtol=1e-12) and min(once) > 0     # nu: dimensionless


def test_another_format_refuses_its_option_in_one_line(plugin, tmp_path):
    (tmp_path / "a.csv").write_text((plugin / "atoms.toy").read_text())
    proc = run(plugin, "-m", "granavg", "average", "--atoms", tmp_path / "a.csv",
               "--toy-length", "2", "--slabs", "x", "--bins", "2", "--thickness", "0.01",
               "--out", tmp_path / "o.csv")
    assert proc.returncode == 2 and "takes no --toy-length option (it takes: --units)" in proc.stderr, proc.stderr
