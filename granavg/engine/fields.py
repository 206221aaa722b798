"""The one data model of an average: :class:`Fields`, values and their errors on the
cells' named axes (xarray's labelled arrays in spirit), with the units each quantity
declares. Every output - the table (CSV, Parquet), NetCDF, VTK, the figures and the
report - is written from it, and the Python API returns it.

>>> import granavg
>>> fields = granavg.average(granavg.examples.couette_2d.run, cells={"bins": 8}, t_min=1.0)
>>> fields.dims, fields.units["sigma_rr"]
(('r',), 'Pa')
>>> fields.to_xarray()["v_phi"]                                  # doctest: +SKIP
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from granavg.engine.quantities import column_units
from granavg.engine.uncertainty.blocking import Replicates
from granavg.engine.unit_system import SI, UnitSystem

if TYPE_CHECKING:
    import pandas as pd

    from granavg.engine.cells.base import Cells


@dataclass
class Fields:
    """Time-averaged fields over cells and their standard errors, in the frames' units
    (SI for granavg's runs).

    Attributes
    ----------
    cells : Cells
        The cells (:mod:`granavg.cells`); their axes are the fields' dimensions
        (:attr:`dims`).
    values, sem : dict of name -> ndarray, shape (n_cells,)
        Values and standard errors (blocking analysis with the cells' sectors for one
        run, between realisations for an ensemble), in cell order.
    flags : ndarray of str, shape (n_cells,)
        Per cell, ';'-joined: ``empty``, ``no_contacts``, ``singular_fabric``,
        ``sem_lower_bound``, ``few_replicas``, ``one_block``.
    n_frames : int
    meta : dict
        The JSON sidecar (``meta["errors"]`` says how the errors were made and where
        they are only lower bounds).
    replicates : Replicates, optional
        Fields on parts of the data (jackknife blocks, sectors, or one per
        realisation): the errors of derived numbers (fits, maxima) come from them.
    n_runs : ndarray, optional
        Realisations with a finite value per cell (ensembles only), shape (n_cells,).
    series : dict of name -> ndarray, shape (n_frames_read,), optional
        The state of every frame read (:mod:`granavg.engine.stationarity`), as columns;
        :attr:`timeseries` gives it as a DataFrame.
    """

    cells: Cells
    values: dict
    sem: dict
    flags: np.ndarray
    n_frames: int
    meta: dict = field(default_factory=dict)
    replicates: Replicates | None = None
    n_runs: np.ndarray | None = None
    series: dict | None = None

    # -- the axes --------------------------------------------------------------------
    @property
    def dims(self) -> tuple:
        """The named dimensions of every field: the cells' axes (``("r",)`` for rings,
        ``("x", "y", "z")`` for boxes, ``("r", "z")`` for cylindrical shells)."""
        return self.cells.grid()[0]

    @property
    def shape(self) -> tuple:
        """The fields' shape along :attr:`dims`."""
        return tuple(self.cells.grid()[1])

    # -- units -----------------------------------------------------------------------
    @property
    def unit_system(self) -> UnitSystem:
        """The units the fields are in (the sidecar's ``unit_system``; SI where it
        does not say)."""
        system = (self.meta or {}).get("unit_system")
        return UnitSystem(**system) if system else SI

    @property
    def units(self) -> dict:
        """The unit of every column of :meth:`to_columns` but the flags, from each
        quantity's declared dimension in :attr:`unit_system`."""
        names = [c for c in self.to_columns() if c != "flags"]
        return column_units(names, self.unit_system, self.cells.coordinate_units())

    # -- the time series ---------------------------------------------------------------
    @property
    def timeseries(self) -> pd.DataFrame | None:
        """:attr:`series` as a new DataFrame (None without one); set from a DataFrame or
        from columns. pandas is imported here, not by the engine's own path."""
        if self.series is None:
            return None
        import pandas as pd
        return pd.DataFrame(self.series)

    @timeseries.setter
    def timeseries(self, table) -> None:
        self.series = None if table is None else columns_of(table)

    # -- as tables and arrays -------------------------------------------------------------
    def to_columns(self) -> dict:
        """One row per cell, as columns: its coordinates (r_lo, r_hi, r for rings), V,
        n_frames, [n_runs,] each value and ``<name>_sem``, flags."""
        cols = {**self.cells.coordinates(), "V": self.cells.volume,
                "n_frames": np.full(self.cells.n, self.n_frames)}
        if self.n_runs is not None:
            cols["n_runs"] = self.n_runs
        for name, v in self.values.items():
            cols[name], cols[f"{name}_sem"] = v, self.sem[name]
        cols["flags"] = self.flags
        return cols

    def to_pandas(self) -> pd.DataFrame:
        """:meth:`to_columns` as a DataFrame, one row per cell (the table ``granavg
        average`` writes)."""
        import pandas as pd
        return pd.DataFrame(self.to_columns())

    def to_xarray(self):
        """The fields as an :class:`xarray.Dataset` on :attr:`dims`: every value and its
        ``<name>_sem`` with its ``units``; the cells' centres and edges as coordinates,
        their volumes ``V``, the flags; the geometry, the unit system and how the errors
        were made in the attributes (JSON text). Needs xarray (``granavg[netcdf]``)."""
        import xarray as xr

        dims, shape, edges = self.cells.grid()
        units, system = self.units, self.unit_system
        coords = {}
        for d, e in zip(dims, edges):
            coords[d] = (d, 0.5 * (e[1:] + e[:-1]), {"units": units[d],
                                                     "long_name": f"cell centre, {d}"})
            coords[f"{d}_edges"] = (f"{d}_edge", np.asarray(e, float),
                                    {"units": units[d], "long_name": f"cell edges, {d}"})
        data = {"V": (dims, self.cells.volume.reshape(shape),
                      {"units": units["V"], "long_name": "cell volume"})}
        for name, value in self.values.items():
            for key, arr in ((name, value), (f"{name}_sem", self.sem[name])):
                data[key] = (dims, np.asarray(arr, float).reshape(shape),
                             {"units": units[key]})
        data["flags"] = (dims, np.asarray(self.flags, dtype=str).reshape(shape))
        if self.n_runs is not None:
            data["n_runs"] = (dims, np.asarray(self.n_runs).reshape(shape))
        meta = self.meta or {}
        attrs = {"title": "granavg profiles", "units": str(meta.get("units", system.label)),
                 "n_frames": int(self.n_frames),
                 "geometry": json.dumps(self.cells.describe()),
                 "unit_system": json.dumps(system.describe()),
                 "errors": json.dumps(meta.get("errors", {}), default=str),
                 "granavg_version": str(meta.get("granavg_version", ""))}
        return xr.Dataset(data, coords=coords, attrs=attrs)

    # -- a figure ------------------------------------------------------------------------
    def plot(self, name: str, ax=None):
        """Draw one field: against position with its error bars where the cells lie
        along one axis (rings, slabs, shells of one layer), else as a map of the first
        plane the cells draw (a 2D grid or polar grid whole, the middle layer of
        boxes). Returns the axes.

        Parameters
        ----------
        name : str
            A value column (``nu``, ``v_phi``, ``sigma_zz``, ...).
        ax : matplotlib Axes, optional
            Where to draw (default: a new figure).
        """
        import matplotlib.pyplot as plt

        if name not in self.values:
            raise KeyError(f"{name!r} is not among the fields ({', '.join(self.values)})")
        unit = self.units[name]
        label = f"{name} ({'-' if unit == '1' else unit})"
        if ax is None:
            _, ax = plt.subplots(figsize=(4.8, 3.4), constrained_layout=True)
        line = self.cells.position()
        if line is not None:
            where, x = line
            ax.errorbar(x, self.values[name], yerr=self.sem[name], marker="o", ms=3,
                        label=name)
            ax.set(xlabel=f"{where} ({self.units[where]})", ylabel=label)
            return ax
        title, (hx, he), (vx, ve), cut = self.cells.planes()[0]
        mesh = ax.pcolormesh(he, ve, cut(np.asarray(self.values[name], float)),
                             cmap="viridis", shading="flat")
        ax.figure.colorbar(mesh, ax=ax, label=label)
        ax.set(xlabel=f"{hx} ({self.units[hx]})", ylabel=f"{vx} ({self.units[vx]})",
               title=title)
        ax.set_aspect("equal")
        return ax


def columns_of(table) -> dict:
    """A table's columns, name -> 1-D ndarray: of a DataFrame, or of a mapping of
    columns (returned as arrays)."""
    return {str(name): np.asarray(table[name]) for name in table}
