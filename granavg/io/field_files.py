"""Fields as files for the tools of the 3D world: NetCDF and a VTK unstructured grid for
ParaView.

- :func:`write_netcdf`: :meth:`granavg.engine.fields.Fields.to_xarray` (one dimension
  per axis of the cells, each value and its ``<name>_sem`` with their ``units``, the
  cells' edges and volumes, the flags; the geometry, the unit system and how the errors
  were made in the attributes) as NetCDF 3, written by scipy, which granavg already
  needs; xarray and ParaView read it.
- :func:`write_vtk` (cells that fill a grid in space: their ``mesh()``): 2D grids and
  polar grids as quadrilaterals, boxes as hexahedra, cylindrical shells revolved into
  sectors so that they show as the cylinder they are; every value and error as cell
  data, vectors and tensors also as Cartesian 3- and 9-component arrays (``v``,
  ``sigma``, ...) for glyphs and tensor views.
- :func:`write_vtk_series`: fields in time as one ``.vtu`` per time in a folder and a
  ParaView collection (``.pvd``) that opens them as one animation, each at its time.

Nothing is converted: the units are the profiles' (the sidecar's ``columns``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from granavg.engine.channels import pairs


def write_netcdf(profiles, path) -> Path:
    """The fields as NetCDF, to ``path`` (the ``average`` command gives the
    temporary name of its :class:`~granavg.io.output_set.OutputSet`)."""
    path = Path(path)
    profiles.to_xarray().to_netcdf(path, engine="scipy")
    return path


def _cartesian(profiles, axes, angle=None):
    """Vectors and tensors of the profiles in Cartesian components: {name: (n, 3) or
    (n, 9)}; cylindrical (r, phi, z) ones rotated by the cells' angle."""
    n = profiles.cells.n
    out = {}
    R = None
    if axes[:2] == ("r", "phi"):
        c, s = np.cos(angle), np.sin(angle)
        R = np.zeros((len(angle), 3, 3))               # columns: e_r, e_phi, e_z
        R[:, 0, 0], R[:, 1, 0], R[:, 0, 1], R[:, 1, 1], R[:, 2, 2] = c, s, -s, c, 1.0
    vectors = {"v": "v_{}", "omega": "omega_{}", "boundary": "boundary_{}",
               "body": "body_{}"}
    for name, pattern in vectors.items():
        cols = [pattern.format(a) for a in axes]
        if all(c in profiles.values for c in cols):
            vec = np.zeros((n, 3))
            for k, c in enumerate(cols):
                vec[:, k] = profiles.values[c]
            out[name] = vec if R is None else np.einsum("nij,nj->ni", R, vec)
    for name in ("F", "sigma", "dsigma", "dsigma_fluct", "eps"):
        cols = [f"{name}_{c}" for c in pairs(axes)]
        if all(c in profiles.values for c in cols):
            d = len(axes)
            T = np.zeros((n, 3, 3))
            T[:, :d, :d] = np.column_stack([profiles.values[c] for c in cols]).reshape(n, d, d)
            if R is not None:
                T = np.einsum("nia,nab,njb->nij", R, T, R)
            out[name] = T.reshape(n, 9)
    return out


def vtk_cells(cells) -> None:
    """Refuse, before any work, cells that VTK output cannot draw (one line)."""
    cells.mesh()


def write_vtk(profiles, path) -> Path:
    """The cells as a VTK unstructured grid (``.vtu``) with every value as cell data
    (module docstring), to ``path``; grids, boxes and cylindrical shells."""
    import meshio

    g = profiles.cells
    points, cells, per_cell, angle = g.mesh()
    data = {"V": g.volume[per_cell]}
    # a mixture's species: each array once per species, "<name>/<species>" (the whole
    # mixture's without the suffix)
    parts = [(s, profiles.of(s)) for s in profiles.species] if profiles.species else \
        [(None, profiles)]
    for species, part in parts:
        tag = "" if species in (None, profiles.species[0] if profiles.species else None) \
            else f"/{species}"
        for name, value in part.values.items():
            data[name + tag] = np.asarray(value, float)[per_cell]
            data[f"{name}_sem{tag}"] = np.asarray(part.sem[name], float)[per_cell]
        if angle is None:
            cart = _cartesian(part, g.axes)
            data.update({k + tag: v[per_cell] for k, v in cart.items()})
        else:
            from types import SimpleNamespace
            expanded = SimpleNamespace(cells=SimpleNamespace(n=len(per_cell)),
                                       values={k: np.asarray(v)[per_cell]
                                               for k, v in part.values.items()})
            data.update({k + tag: v for k, v in _cartesian(expanded, g.axes, angle).items()})
    mesh = meshio.Mesh(points, cells, cell_data={k: [v] for k, v in data.items()})
    path = Path(path)
    mesh.write(path, file_format="vtu")
    return path


def write_vtk_series(profiles, pvd, folder, name: str) -> Path:
    """Fields in time as ParaView's time series: ``folder/t<j>.vtu`` per time
    (:func:`write_vtk`) and the collection ``pvd`` naming each with its time, the files
    as ``name/t<j>.vtu`` (the folder's final name, beside the collection)."""
    from xml.sax.saxutils import quoteattr

    folder = Path(folder)
    rows = []
    for j, t in enumerate(profiles.times):
        write_vtk(profiles.at(j), folder / f"t{j:05d}.vtu")
        rows.append(f'    <DataSet timestep="{float(t)!r}" part="0" '
                    f'file={quoteattr(f"{name}/t{j:05d}.vtu")}/>')
    Path(pvd).write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" '
                         'version="0.1" byte_order="LittleEndian">\n  <Collection>\n'
                         + "\n".join(rows) + "\n  </Collection>\n</VTKFile>\n")
    return Path(pvd)
