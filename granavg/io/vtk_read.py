"""Other engines' VTK files as numpy arrays, read by Kitware's own VTK library (the
``vtk`` extra): legacy ``.vtk`` (ASCII or binary, any dataset: LIGGGHTS' ``dump
custom/vtk`` writes POLYDATA) and XML (``.vtp``, ``.vtu``: LIGGGHTS' XML dumps, Yade's
``VTKRecorder``).
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from granavg.errors import UserError

#: VTK's message window is one for the process: one file read at a time catches its own.
_READING = threading.Lock()


@dataclass
class VtkData:
    """One VTK file's points and arrays.

    Attributes
    ----------
    points : ndarray, shape (n, 3)
        As doubles (a file of ``float`` points: each exactly its float32 value).
    point_data, cell_data : dict of str -> ndarray, shape (n,) or (n, k)
    lines : ndarray of int, shape (m, 2)
        The two points of each line cell (Yade's interactions), empty where none.
    """

    points: np.ndarray
    point_data: dict = field(default_factory=dict)
    cell_data: dict = field(default_factory=dict)
    lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))


def _arrays(data) -> dict:
    from vtkmodules.util.numpy_support import vtk_to_numpy
    out = {}
    for k in range(data.GetNumberOfArrays()):
        a = data.GetArray(k)
        if a is not None:
            out[data.GetArrayName(k)] = np.array(vtk_to_numpy(a))
    return out


def is_vtk(path) -> bool:
    """Whether the file starts as a legacy VTK file or a VTK XML file."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(256)
    except OSError:
        return False
    return head.startswith(b"# vtk DataFile") or (b"<VTKFile" in head)


def read_vtk(path) -> VtkData:
    """The points, point and cell arrays and line cells of one VTK file (legacy or XML).

    Raises
    ------
    UserError
        The file is not one VTK can read (one line naming it).
    """
    try:
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import (vtkLogger, vtkOutputWindow,
                                              vtkStringOutputWindow)
        from vtkmodules.vtkIOLegacy import vtkGenericDataObjectReader
        from vtkmodules.vtkIOXML import vtkXMLGenericDataObjectReader
    except ImportError:
        raise UserError(f"reading {path} needs vtk: pip install 'granavg[vtk]'") from None

    path = Path(path)
    if not is_vtk(path):
        raise UserError(f"{path}: not a VTK file (no '# vtk DataFile' or '<VTKFile' at its "
                        "start); give the engine's VTK output, or name the format")
    legacy = open(path, "rb").read(14) == b"# vtk DataFile"
    reader = vtkGenericDataObjectReader() if legacy else vtkXMLGenericDataObjectReader()
    if legacy:                    # every SCALARS and VECTORS array, not only the first
        reader.ReadAllScalarsOn()
        reader.ReadAllVectorsOn()
    reader.SetFileName(str(path))
    with _READING:                # VTK's messages, caught: a cut file reads without raising
        messages = vtkStringOutputWindow()
        vtkOutputWindow.SetInstance(messages)
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
        reader.Update()
        said = messages.GetOutput()
    failed = _errors(said)
    if failed:
        what = failed[0]
        raise UserError(f"{path}: VTK cannot read it whole ({what}); the file is cut or "
                        "damaged: write it again, or remove it from the series")
    data = reader.GetOutput()
    if data is None or not hasattr(data, "GetPoints") or data.GetPoints() is None:
        raise UserError(f"{path}: VTK finds no points in it (damaged, or not a point "
                        "dataset); give the engine's particle output")
    points = np.array(vtk_to_numpy(data.GetPoints().GetData()), dtype=float)
    lines = np.zeros((0, 2), int)
    if hasattr(data, "GetLines") and data.GetNumberOfLines():
        conn = vtk_to_numpy(data.GetLines().GetConnectivityArray())
        lines = np.asarray(conn, int).reshape(-1, 2)
    out = VtkData(points, _arrays(data.GetPointData()), _arrays(data.GetCellData()), lines)
    _lengths(path, out, data.GetNumberOfCells())
    return out


def component(path, arrays: dict, name: str, k: int | None) -> np.ndarray:
    """The values of the scalar array ``name`` (``k`` None) or component ``k`` of the
    vector array ``name``, as doubles; refuses an array of another shape (a vector has
    3 components) in one line."""
    a = np.asarray(arrays[name])
    have, want = (1 if a.ndim == 1 else a.shape[1]), (1 if k is None else 3)
    if a.ndim > 2 or have != want:
        raise UserError(f"{path}: the array {name} has {have} components where "
                        f"{'a scalar has 1' if k is None else 'a vector has 3'}; the file "
                        "is damaged: write it again")
    return np.asarray(a if k is None or a.ndim == 1 else a[:, k], float)


def _lengths(path, data: VtkData, cells: int) -> None:
    """Refuse an array whose length is not its points' (or cells') number."""
    for kind, arrays, n in (("point", data.point_data, len(data.points)),
                            ("cell", data.cell_data, cells)):
        for name, a in arrays.items():
            if len(a) != n:
                raise UserError(f"{path}: the {kind} array {name} has {len(a)} values for "
                                f"{n} {kind}s; the file is damaged: write it again")


def _errors(said: str) -> list:
    """VTK's error messages in its output window's text: blocks of ``ERROR: In FILE,
    line N`` then ``vtkClass (0x...): what``, or one line ``vtkClass (0x...): Error ...``;
    each message's text (without the class and the file name)."""
    out = []
    for block in re.split(r"\n\s*\n", said):
        lines = [ln for ln in block.strip().splitlines() if ln.strip()]
        if not lines:
            continue
        if lines[0].startswith("ERROR"):
            text = " ".join(lines[1:]) or lines[0]
        elif any(ln.startswith("vtk") and "rror" in ln for ln in lines):
            text = next(ln for ln in lines if ln.startswith("vtk") and "rror" in ln)
        else:
            continue
        out.append(" ".join(text.split("): ", 1)[-1].split(" for file")[0].split())
                   .rstrip("."))
    return out
