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
    times : ndarray, shape (n_times,), optional
        Fields in time (:mod:`granavg.engine.timing`: windows, or fields smoothed in
        time): the times of the fields (the windows' middles). Then every value, error
        and flag has shape (n_times, n_cells), ``n_frames`` is per time, ``replicates``
        a list per time, and :meth:`at` gives one time's fields.
    time_edges : ndarray, shape (n_times + 1,), optional
        The windows' edges (windows only).
    species : tuple of str, optional
        A mixture's fields (:mod:`granavg.engine.species`): one per species and the whole
        mixture (``all``). Then every value, error and flag has a first axis of these
        (before the time axis), ``n_frames`` and ``replicates`` are per species, and
        :meth:`of` gives one species' fields.
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
    times: np.ndarray | None = None
    time_edges: np.ndarray | None = None
    species: tuple | None = None

    # -- the axes --------------------------------------------------------------------
    @property
    def dims(self) -> tuple:
        """The named dimensions of every field: ``time`` for fields in time, then the
        cells' axes (``("r",)`` for rings, ``("x", "y", "z")`` for boxes, ``("r", "z")``
        for cylindrical shells)."""
        own = tuple(self.cells.grid()[0])
        own = ("time", *own) if self.in_time else own
        return ("species", *own) if self.species is not None else own

    @property
    def shape(self) -> tuple:
        """The fields' shape along :attr:`dims`."""
        own = tuple(self.cells.grid()[1])
        own = (len(self.times), *own) if self.in_time else own
        return (len(self.species), *own) if self.species is not None else own

    @property
    def frames_averaged(self) -> int:
        """The frames averaged: :attr:`n_frames`, or for fields in time every frame that
        fell in some time (``meta["frames"]["n"]``)."""
        if not self.in_time and self.species is None:
            return int(self.n_frames)
        return int((self.meta.get("frames") or {}).get("n", np.max(self.n_frames)))

    @property
    def in_time(self) -> bool:
        """Whether the fields have a time axis (:attr:`times`)."""
        return self.times is not None

    # -- fields in time ----------------------------------------------------------------
    @classmethod
    def stack(cls, fields, times, edges=None, meta=None) -> "Fields":
        """Fields in time from one :class:`Fields` per time (the same cells and
        columns), at ``times`` (windows: with their ``edges``); ``meta`` the sidecar
        (default the first's)."""
        first = fields[0]
        runs = None if first.n_runs is None else np.stack([f.n_runs for f in fields])
        reps = [f.replicates for f in fields]
        return cls(first.cells, {n: np.stack([f.values[n] for f in fields])
                                 for n in first.values},
                   {n: np.stack([f.sem[n] for f in fields]) for n in first.sem},
                   np.stack([f.flags for f in fields]),
                   np.array([f.n_frames for f in fields]), dict(meta or first.meta),
                   reps if any(r is not None for r in reps) else None, runs, first.series,
                   np.asarray(times, float),
                   None if edges is None else np.asarray(edges, float))

    def at(self, j: int) -> "Fields":
        """The fields at the ``j``-th time (a :class:`Fields` without a time axis; its
        ``meta["time"]["t"]`` says which)."""
        if not self.in_time:
            raise ValueError("these fields have no time axis")
        if self.species is not None:
            return Fields.of_species({n: self.of(n).at(j) for n in self.species}, self.meta)
        meta = dict(self.meta or {})
        meta["time"] = {**meta.get("time", {}), "t": float(self.times[j])}
        if self.time_edges is not None:
            meta["time"]["window"] = [float(self.time_edges[j]), float(self.time_edges[j + 1])]
        return Fields(self.cells, {n: v[j] for n, v in self.values.items()},
                      {n: v[j] for n, v in self.sem.items()}, self.flags[j],
                      int(self.n_frames[j]), meta,
                      self.replicates[j] if self.replicates is not None else None,
                      None if self.n_runs is None else self.n_runs[j], self.series)

    # -- species of a mixture ----------------------------------------------------------
    @classmethod
    def of_species(cls, parts: dict, meta: dict | None = None) -> "Fields":
        """A mixture's fields from one :class:`Fields` per species (the same cells,
        columns and time axis), in the order given; ``meta`` the sidecar (default the
        first's)."""
        names = tuple(parts)
        each = list(parts.values())
        first = each[0]
        runs = None if first.n_runs is None else np.stack([f.n_runs for f in each])
        reps = [f.replicates for f in each]
        return cls(first.cells, {n: np.stack([f.values[n] for f in each]) for n in first.values},
                   {n: np.stack([f.sem[n] for f in each]) for n in first.sem},
                   np.stack([f.flags for f in each]),
                   np.array([f.n_frames for f in each]), dict(meta or first.meta),
                   reps if any(r is not None for r in reps) else None, runs, first.series,
                   first.times, first.time_edges, names)

    def of(self, name: str) -> "Fields":
        """One species' fields (``all``: the whole mixture's), without the species axis."""
        if self.species is None:
            raise ValueError("these fields have no species axis (average with species=)")
        if name not in self.species:
            raise KeyError(f"{name!r} is not a species of these fields "
                           f"({', '.join(self.species)})")
        k = self.species.index(name)
        meta = dict(self.meta or {})
        meta["species"] = {**meta.get("species", {}), "of": name}
        frames = self.n_frames[k]
        return Fields(self.cells, {n: v[k] for n, v in self.values.items()},
                      {n: v[k] for n, v in self.sem.items()}, self.flags[k],
                      int(frames) if np.ndim(frames) == 0 else frames, meta,
                      self.replicates[k] if self.replicates is not None else None,
                      None if self.n_runs is None else self.n_runs[k], self.series,
                      self.times, self.time_edges)

    def nearest(self, t: float) -> int:
        """The index of the time nearest ``t``."""
        return int(np.argmin(np.abs(np.asarray(self.times) - float(t))))

    def _time_columns(self) -> dict:
        """Each row's time (and window edges), one row per time and cell."""
        n = self.cells.n
        cols = {"t": np.repeat(self.times, n)}
        if self.time_edges is not None:
            cols["t_lo"] = np.repeat(self.time_edges[:-1], n)
            cols["t_hi"] = np.repeat(self.time_edges[1:], n)
        return cols

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
        quantity's declared dimension in :attr:`unit_system`; columns that no quantity
        declares (derived fields, :mod:`granavg.analysis.rheology`) from the sidecar's
        ``dimensions`` (name -> dimension, e.g. ``"{stress}"``), errors as their values."""
        names = [c for c in self.to_columns() if c not in ("flags", "species")]
        derived = (self.meta or {}).get("dimensions") or {}
        own = {**self.cells.coordinate_units(),
               **{c: "{time}" for c in ("t", "t_lo", "t_hi")},
               **{c: derived[c.removesuffix("_sem")] for c in names
                  if c.removesuffix("_sem") in derived}}
        if self.species is not None or (self.meta or {}).get("species"):   # c, seg_*
            for c in names:
                base = c[:-4] if c.endswith("_sem") else c
                if base == "c" or base.startswith("seg_"):
                    own[c] = "1" if base == "c" else "{length}/{time}"
                elif base.startswith("dsigma_mix_"):
                    own[c] = "{momentum_flux}"
        return column_units(names, self.unit_system, own)

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
        n_frames, [n_runs,] each value and ``<name>_sem``, flags. Fields in time: one
        row per time and cell, the time first (``t``; windows also ``t_lo``,
        ``t_hi``)."""
        if self.species is not None:
            parts = [self.of(n).to_columns() for n in self.species]
            rows = len(next(iter(parts[0].values())))
            return {"species": np.repeat(np.array(self.species, dtype=object), rows),
                    **{k: np.concatenate([p[k] for p in parts]) for k in parts[0]}}
        if self.in_time:
            parts = [self.at(j).to_columns() for j in range(len(self.times))]
            return {**self._time_columns(),
                    **{k: np.concatenate([p[k] for p in parts]) for k in parts[0]}}
        cols = {**self.cells.coordinates(), "V": self.cells.volume,
                "n_frames": np.full(self.cells.n, self.n_frames)}
        if self.n_runs is not None:
            cols["n_runs"] = self.n_runs
        for name, v in self.values.items():
            cols[name], cols[f"{name}_sem"] = v, self.sem[name]
        cols["flags"] = self.flags
        return cols

    def to_pandas(self) -> pd.DataFrame:
        """:meth:`to_columns` as a DataFrame, one row per cell (and time) (the table
        ``granavg average`` writes)."""
        import pandas as pd
        return pd.DataFrame(self.to_columns())

    def to_xarray(self):
        """The fields as an :class:`xarray.Dataset` on :attr:`dims`: every value and its
        ``<name>_sem`` with its ``units``; the cells' centres and edges as coordinates,
        their volumes ``V``, the flags; the geometry, the unit system and how the errors
        were made in the attributes (JSON text). Needs xarray (``granavg[netcdf]``)."""
        import xarray as xr

        if self.species is not None:
            each = [self.of(n).to_xarray() for n in self.species]
            fields = [k for k in each[0].data_vars if k != "V"]
            ds = xr.concat(each, dim="species", data_vars=fields, coords="minimal",
                           compat="override", combine_attrs="override")
            ds = ds.assign_coords(species=("species", list(self.species)))
            ds.attrs["species"] = json.dumps((self.meta or {}).get("species", {}))
            return ds
        dims, shape, edges = self.cells.grid()
        units, system = self.units, self.unit_system
        coords = {}
        for d, e in zip(dims, edges):
            coords[d] = (d, 0.5 * (e[1:] + e[:-1]), {"units": units[d],
                                                     "long_name": f"cell centre, {d}"})
            coords[f"{d}_edges"] = (f"{d}_edge", np.asarray(e, float),
                                    {"units": units[d], "long_name": f"cell edges, {d}"})
        field_dims, field_shape = tuple(dims), tuple(shape)
        if self.in_time:
            t_unit = self.unit_system.unit("{time}")
            coords["time"] = ("time", np.asarray(self.times, float),
                              {"units": t_unit, "long_name": "time of the fields"})
            if self.time_edges is not None:
                coords["time_edges"] = ("time_edge", self.time_edges,
                                        {"units": t_unit, "long_name": "windows' edges"})
            field_dims, field_shape = ("time", *dims), (len(self.times), *shape)
        data = {"V": (dims, self.cells.volume.reshape(shape),
                      {"units": units["V"], "long_name": "cell volume"})}
        for name, value in self.values.items():
            for key, arr in ((name, value), (f"{name}_sem", self.sem[name])):
                data[key] = (field_dims, np.asarray(arr, float).reshape(field_shape),
                             {"units": units[key]})
        data["flags"] = (field_dims, np.asarray(self.flags, dtype=str).reshape(field_shape))
        if self.n_runs is not None:
            data["n_runs"] = (field_dims, np.asarray(self.n_runs).reshape(field_shape))
        meta = self.meta or {}
        attrs = {"title": "granavg profiles", "units": str(meta.get("units", system.label)),
                 "n_frames": int(np.sum(self.n_frames)) if not self.in_time else
                 int(meta.get("frames", {}).get("n", np.max(self.n_frames))),
                 "geometry": json.dumps(self.cells.describe()),
                 "unit_system": json.dumps(system.describe()),
                 "errors": json.dumps(meta.get("errors", {}), default=str),
                 "granavg_version": str(meta.get("granavg_version", ""))}
        if self.in_time:
            data["n_frames"] = ("time", np.asarray(self.n_frames),
                                {"long_name": "frames weighed at each time"})
            attrs["time"] = json.dumps(meta.get("time", {}), default=str)
        return xr.Dataset(data, coords=coords, attrs=attrs)

    # -- a figure ------------------------------------------------------------------------
    def plot(self, name: str, ax=None, time: float | None = None,
             species: str | None = None):
        """Draw one field: against position with its error bars where the cells lie
        along one axis (rings, slabs, shells of one layer), else as a map of the first
        plane the cells draw (a 2D grid or polar grid whole, the middle layer of
        boxes). Fields in time: at the time nearest ``time``, or, without one, as a
        space-time map (a kymograph: position against time) where the cells lie along
        one axis. Returns the axes.

        Parameters
        ----------
        name : str
            A value column (``nu``, ``v_phi``, ``sigma_zz``, ...).
        ax : matplotlib Axes, optional
            Where to draw (default: a new figure).
        time : float, optional
            Fields in time: draw the fields at this time.
        species : str, optional
            A mixture's fields: this species' (default: along one axis, every species
            on one axes; else the whole mixture's).
        """
        import matplotlib.pyplot as plt

        if self.species is not None:
            line = self.cells.position() is not None and not (self.in_time and time is None)
            if species is not None or not line:
                return self.of(species or self.species[0]).plot(name, ax, time)
            for n in self.species:
                ax = self.of(n).plot(name, ax, time)
                ax.containers[-1].set_label(n)
            ax.legend(title="species")
            return ax
        if name not in self.values:
            raise KeyError(f"{name!r} is not among the fields ({', '.join(self.values)})")
        if self.in_time and time is not None:
            j = self.nearest(time)
            ax = self.at(j).plot(name, ax)
            when = f"t = {self.times[j]:.4g} {self.unit_system.unit('{time}')}"
            ax.set_title(f"{ax.get_title()}, {when}" if ax.get_title() else when)
            return ax
        if not self.in_time and time is not None:
            raise ValueError("these fields have no time axis: leave out time")
        unit = self.units[name]
        label = f"{name} ({'-' if unit == '1' else unit})"
        if ax is None:
            _, ax = plt.subplots(figsize=(4.8, 3.4), constrained_layout=True)
        line = self.cells.position()
        if self.in_time:
            if line is None:
                raise ValueError(f"{self.cells.kind} do not lie along one axis: give a time "
                                 "to draw the fields at")
            return self._kymograph(name, ax, line[0], label)
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


    def _kymograph(self, name, ax, where, label):
        """The field against position and time (cell edges across, time edges up)."""
        dims, _, edges = self.cells.grid()
        x = np.asarray(edges[list(dims).index(where)], float) if where in dims else \
            _edges_of(self.cells.position()[1])
        t = self.time_edges if self.time_edges is not None else _edges_of(self.times)
        mesh = ax.pcolormesh(x, t, np.asarray(self.values[name], float), cmap="viridis",
                             shading="flat")
        ax.figure.colorbar(mesh, ax=ax, label=label)
        t_unit = self.unit_system.unit("{time}")
        ax.set(xlabel=f"{where} ({self.units[where]})", ylabel=f"t ({t_unit})")
        return ax


def _edges_of(centres) -> np.ndarray:
    """Edges halfway between centres (the ends half a step out)."""
    c = np.asarray(centres, float)
    if len(c) == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.r_[c[0] - (mid[0] - c[0]), mid, c[-1] + (c[-1] - mid[-1])]


def columns_of(table) -> dict:
    """A table's columns, name -> 1-D ndarray: of a DataFrame, or of a mapping of
    columns (returned as arrays)."""
    return {str(name): np.asarray(table[name]) for name in table}
