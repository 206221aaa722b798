"""One typed description of an average, built from a run's manifest or from a user's
options, with every default computed here and nowhere else.

- :class:`RunAverage`: a granavg run (SI units): rings from R_i to R_o (default
  :data:`DEFAULT_BINS`), t_min the scene's discarded transient (:func:`discard_time`),
  base time blocks of one dump interval (at most :data:`~granavg.engine.average.MAX_BLOCKS`),
  the per-frame state of the Couette cell;
- :class:`DumpAverage`: anyone's dumps (their own units): rings about a centre, slabs or a
  grid, from the options and, where they say nothing, the dump's box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from granavg import __version__
from granavg.engine.average import MAX_BLOCKS, CellAverage
from granavg.engine.body_forces import add_body_forces, base_plate
from granavg.engine.cells3d import Boxes, Shells, Slabs3D
from granavg.engine.geometry import Grid, Rings, Slabs
from granavg.engine.timeseries import TimeSeries
from granavg.pipeline.prefetch import Prefetched
from granavg.engine.units import SI
from granavg.errors import UserError
from granavg.io import validate
from granavg.io.frames import Frame

#: Equal rings (or slabs) when neither a count nor edges are given.
DEFAULT_BINS = 20
#: Inner-ring rotations discarded by manifests older than ``derived.t_discard_s``.
OLD_DISCARD_ROTATIONS = 2.0


def discard_time(manifest: dict) -> float:
    """The run's default start of the averages, s: the scene's discarded transient as
    the run recorded it (``derived.t_discard_s``), else ``discard_rotations`` x 2 pi /
    Omega of its scene."""
    derived, scene = manifest["derived"], manifest["scene"]
    if "t_discard_s" in derived:
        return float(derived["t_discard_s"])
    return scene.get("discard_rotations", OLD_DISCARD_ROTATIONS) * 2 * math.pi / scene["Omega"]


def scene_body_forces(manifest: dict) -> list:
    """The body force terms of a run's scene: its base-plate friction (where mu_base > 0;
    the deck's law, :func:`~granavg.engine.body_forces.base_plate`)."""
    scene = manifest["scene"]
    if scene.get("mu_base", 0.0) > 0:
        return [base_plate(scene["mu_base"], scene["v_base"])]
    return []


class WithBodyForces:
    """A frame source whose frames carry the body forces of ``terms`` (atoms' ``bx by
    [bz]``), masses from the ``cells``' particle volumes; every other attribute is the
    source's."""

    def __init__(self, source, terms, cells, rho_p: float | None):
        self.source, self.terms, self.cells, self.rho_p = source, list(terms), cells, rho_p

    def frame(self, f) -> Frame:
        if not self.terms:
            return f
        return Frame(f.timestep, f.time, add_body_forces(
            f.atoms, self.terms, self.cells.particle_volume, self.rho_p), f.contacts)

    def __iter__(self):
        return (self.frame(f) for f in self.source)

    def __getattr__(self, name):
        return getattr(self.source, name)


def equal_edges(lo: float, hi: float, bins: int | None) -> np.ndarray:
    """Edges of ``bins`` (default :data:`DEFAULT_BINS`) equal cells from lo to hi."""
    return np.linspace(lo, hi, (DEFAULT_BINS if bins is None else bins) + 1)


@dataclass
class RunAverage:
    """An average of a granavg run: its rings, quantities, window and time blocks.

    Attributes
    ----------
    manifest : dict
        The run's manifest (its scene: geometry, h, rho_p, Omega, d_s).
    geometry : Rings
    groups : list of str
        Quantity groups (:data:`granavg.engine.quantities.QUANTITIES`).
    t_min, block_time : float
        Start of the average and base block length, s.
    """

    manifest: dict
    geometry: Rings
    groups: list
    t_min: float
    block_time: float
    files: dict = field(default_factory=dict)
    branch: str = "contact"
    body_forces: list = field(default_factory=list)
    sectors: object = "auto"

    @classmethod
    def of(cls, manifest: dict, groups, *, bins=None, edges=None, t_min=None,
           block_time=None, branch="contact", sectors="auto") -> "RunAverage":
        """The average of the run ``manifest`` describes, options resolved."""
        scene, derived = manifest["scene"], manifest["derived"]
        validate.ring_options(bins, edges)
        rings = Rings(np.asarray(edges, float), scene["h"]) if edges is not None else \
            Rings(equal_edges(scene["R_i"], scene["R_o"], bins), scene["h"])
        t_min = discard_time(manifest) if t_min is None else float(t_min)
        block_time = block_time or max(derived["dump_interval_s"],
                                       (derived["t_end_s"] - t_min) / MAX_BLOCKS)
        return cls(manifest, rings, list(groups), t_min, block_time, branch=branch,
                   body_forces=scene_body_forces(manifest), sectors=sectors)

    @property
    def meta(self) -> dict:
        """The sidecar's description of this average."""
        return {"granavg_version": __version__, "units": SI.label,
                "unit_system": SI.describe(), "quantities": list(self.groups),
                "rings": {"edges_m": list(self.geometry.edges), "h_m": self.geometry.h},
                "geometry": self.geometry.describe(),
                "frames": {"t_min_s": self.t_min, "block_time_s": self.block_time},
                "run_manifest": self.manifest, **({"files": self.files} if self.files else {}),
                "body_forces": [t.describe for t in self.body_forces]}

    def averager(self, frames=None, series: bool = True) -> CellAverage:
        """A :class:`CellAverage` of ``frames`` with the Couette cell's per-frame state
        (``series``; one is enough where several ring counts see the same frames)."""
        scene = self.manifest["scene"]
        state = TimeSeries(scene["R_i"], scene["R_o"], scene["h"], scene["rho_p"],
                           scene["d_s"]) if series else None
        if frames is not None and self.body_forces and "body" in self.groups:
            frames = WithBodyForces(frames, self.body_forces, self.geometry, scene["rho_p"])
        if frames is not None:
            frames = Prefetched(frames)
        avg = CellAverage(frames, self.geometry, self.groups, scene["rho_p"], self.t_min,
                          self.block_time, state, branch=self.branch,
                          sectors=self.sectors)
        avg.meta = self.meta
        return avg


@dataclass
class DumpAverage:
    """The cells of an average of anyone's dumps, from the options (lengths in the
    dumps' units).

    Parameters of :meth:`of`: ``dim`` (2 or 3); in 2D ``thickness`` (the disks' height
    h); ``bins`` or ``edges``; rings (2D) or cylindrical shells (3D): ``r_range`` (or
    ``edges``) and ``center``, in 3D with ``layers`` layers over ``z_range`` (default the
    box, one layer); ``slabs`` (x, y or z in 3D) with ``range`` (default the box) and, in
    2D, ``length`` (default the box's other side; the slabs span it from the box's lower
    bound, their segments the errors' spatial replicas), in 3D ``area`` (default the
    box's cross-section); ``grid`` (nx, ny or nx, ny, nz) over ``x_range``, ``y_range``
    (``z_range``), default the box. ``box`` is called for the first frame's box bounds
    where an option leaves a length to it; ``periodic`` for its periodic axes: 3D cells
    that span a periodic box along an axis take the spheres' images across its ends.
    """

    geometry: object

    @classmethod
    def of(cls, box, *, dim=2, thickness=None, bins=None, edges=None, center=(0.0, 0.0),
           r_range=None, slabs=None, range=None, length=None, grid=None, x_range=None,
           y_range=None, z_range=None, layers=None, area=None,
           periodic=lambda: (False,) * 3) -> "DumpAverage":
        validate.ring_options(bins, edges)
        if dim == 3:
            return cls(_cells3d(box, periodic, bins=bins, edges=edges, center=center,
                                r_range=r_range, slabs=slabs, range=range, grid=grid,
                                x_range=x_range, y_range=y_range, z_range=z_range,
                                layers=layers, area=area, thickness=thickness,
                                length=length))
        for flag, value in (("--z-range", z_range), ("--layers", layers), ("--area", area)):
            if value is not None:
                raise UserError(f"{flag} is for 3D dumps (spheres); these are 2D (give --dim "
                                "3 if the dump is 3D)")
        if thickness is None:
            raise UserError("--thickness H: give the disks' height, in the dump's length "
                            "unit (2D disks have volume pi h a^2)")
        validate.positive("--thickness", thickness)
        h = thickness
        if grid:
            if len(grid) != 2:
                raise UserError(f"--grid {' '.join(map(str, grid))}: give NX NY for a 2D dump")
            if min(grid) < 1 or grid[0] * grid[1] > validate.MAX_BINS:
                raise UserError(f"--grid {grid[0]} {grid[1]}: give between 1 and "
                                f"{validate.MAX_BINS} cells")
            bx = box() if not (x_range and y_range) else None
            xr, yr = x_range or bx[0], y_range or bx[1]
            return cls(Grid(np.linspace(*xr, grid[0] + 1), np.linspace(*yr, grid[1] + 1), h))
        if slabs:
            if slabs not in ("x", "y"):
                raise UserError(f"--slabs {slabs}: a 2D dump has slabs across x or y")
            k = "xy".index(slabs)
            bx = box()
            lo_hi = range or bx[k]
            cuts = np.asarray(edges, float) if edges else equal_edges(*lo_hi, bins)
            other = bx[1 - k]
            length = length or (other[1] - other[0])
            return cls(Slabs(cuts, h, slabs, length, (other[0], other[0] + length)))
        if edges is None and r_range is None:
            raise UserError("rings need --r-range R1 R2 (with --bins) or --edges; or choose "
                            "--slabs or --grid")
        cuts = np.asarray(edges, float) if edges else equal_edges(*r_range, bins)
        return cls(Rings(cuts, h, tuple(center)))


def _cells3d(box, periodic, *, bins, edges, center, r_range, slabs, range, grid, x_range,
             y_range, z_range, layers, area, thickness, length):
    """The 3D cells of the options (:class:`DumpAverage`)."""
    for flag, value in (("--thickness", thickness), ("--length", length)):
        if value is not None:
            raise UserError(f"{flag} is for 2D disks; the dump is 3D (spheres: volume 4/3 pi "
                            "a^3" + ("; slabs take --area" if flag == "--length" else "") + ")")
    ranges = {"x": x_range, "y": y_range, "z": z_range}
    bx = None

    def span(axis):
        nonlocal bx
        if ranges[axis] is not None:
            return tuple(ranges[axis])
        bx = box() if bx is None else bx
        return tuple(bx["xyz".index(axis)])

    def periods(axes):
        """The spans of the cells along periodic axes where they cover the whole box."""
        flags = periodic()
        out = []
        for k, axis in enumerate("xyz"):
            whole = axis in axes and ranges[axis] is None and flags[k]
            out.append(span(axis) if whole else None)
        return tuple(out) if any(out) else None

    if grid:
        if len(grid) != 3:
            raise UserError(f"--grid {' '.join(map(str, grid))}: give NX NY NZ for a 3D dump")
        if min(grid) < 1 or int(np.prod(grid)) > validate.MAX_BINS:
            raise UserError(f"--grid {' '.join(map(str, grid))}: give between 1 and "
                            f"{validate.MAX_BINS} cells")
        e = [np.linspace(*span(a), n + 1) for a, n in zip("xyz", grid)]
        return Boxes(*e, periods("xyz"))
    if slabs:
        k = "xyz".index(slabs)
        lo_hi = tuple(range) if range else span(slabs)
        cuts = np.asarray(edges, float) if edges else equal_edges(*lo_hi, bins)
        if area is None:
            others = [span(a) for a in "xyz" if a != slabs]
            area = (others[0][1] - others[0][0]) * (others[1][1] - others[1][0])
        validate.positive("--area", area)
        ranges[slabs] = tuple(range) if range else None
        return Slabs3D(cuts, slabs, float(area), periods(slabs))
    if edges is None and r_range is None:
        raise UserError("cylindrical shells need --r-range R1 R2 (with --bins) or --edges; "
                        "or choose --slabs or --grid")
    cuts = np.asarray(edges, float) if edges else equal_edges(*r_range, bins)
    if layers is not None and not 1 <= layers <= validate.MAX_BINS:
        raise UserError(f"--layers {layers}: give between 1 and {validate.MAX_BINS}")
    zedges = np.linspace(*span("z"), (layers or 1) + 1)
    return Shells(cuts, zedges, tuple(center), periods("z"))
