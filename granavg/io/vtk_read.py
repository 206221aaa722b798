"""Other engines' VTK files as numpy arrays, read by Kitware's own VTK library (the
``vtk`` extra): legacy ``.vtk`` (ASCII or binary, any dataset: LIGGGHTS' ``dump
custom/vtk`` writes POLYDATA) and XML (``.vtp``, ``.vtu``: LIGGGHTS' XML dumps, Yade's
``VTKRecorder``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from granavg.errors import UserError


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
        from vtkmodules.vtkCommonCore import vtkObject
        from vtkmodules.vtkIOLegacy import vtkGenericDataObjectReader
        from vtkmodules.vtkIOXML import vtkXMLGenericDataObjectReader
    except ImportError:
        raise UserError(f"reading {path} needs vtk: pip install 'granavg[vtk]'") from None

    path = Path(path)
    if not is_vtk(path):
        raise UserError(f"{path}: not a VTK file (no '# vtk DataFile' or '<VTKFile' at its "
                        "start); give the engine's VTK output, or name the format")
    vtkObject.GlobalWarningDisplayOff()
    legacy = open(path, "rb").read(14) == b"# vtk DataFile"
    reader = vtkGenericDataObjectReader() if legacy else vtkXMLGenericDataObjectReader()
    if legacy:                    # every SCALARS and VECTORS array, not only the first
        reader.ReadAllScalarsOn()
        reader.ReadAllVectorsOn()
    reader.SetFileName(str(path))
    reader.Update()
    data = reader.GetOutput()
    if data is None or not hasattr(data, "GetPoints") or data.GetPoints() is None:
        raise UserError(f"{path}: VTK finds no points in it (damaged, or not a point "
                        "dataset); give the engine's particle output")
    points = np.array(vtk_to_numpy(data.GetPoints().GetData()), dtype=float)
    lines = np.zeros((0, 2), int)
    if hasattr(data, "GetLines") and data.GetNumberOfLines():
        conn = vtk_to_numpy(data.GetLines().GetConnectivityArray())
        lines = np.asarray(conn, int).reshape(-1, 2)
    return VtkData(points, _arrays(data.GetPointData()), _arrays(data.GetCellData()), lines)
