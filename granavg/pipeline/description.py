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


#: The options each kind of cells of plain dumps takes (the others are refused):
#: (dimension, kind) -> option names (:meth:`DumpAverage.of`'s keywords).
CELL_OPTIONS = {
    (2, "rings"): {"thickness", "bins", "edges", "r_range", "center"},
    (2, "slabs"): {"thickness", "slabs", "bins", "edges", "range", "length"},
    (2, "grid"): {"thickness", "grid", "x_range", "y_range"},
    (3, "shells"): {"bins", "edges", "r_range", "center", "layers", "z_range"},
    (3, "slabs"): {"slabs", "bins", "edges", "range", "area"},
    (3, "grid"): {"grid", "x_range", "y_range", "z_range"},
}
_KIND_NAMES = {(2, "rings"): "rings", (2, "slabs"): "slabs", (2, "grid"): "a 2D grid",
               (3, "shells"): "cylindrical shells", (3, "slabs"): "3D slabs",
               (3, "grid"): "a box grid"}


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _check_range(name, pair, nonnegative=False):
    """A (lo, hi) option: finite, lo < hi (and lo >= 0 for radii)."""
    if pair is None:
        return
    lo, hi = (float(v) for v in pair)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise UserError(f"{_flag(name)} {lo:g} {hi:g}: give finite numbers")
    if not lo < hi:
        raise UserError(f"{_flag(name)} {lo:g} {hi:g}: the first must be below the second")
    if nonnegative and lo < 0:
        raise UserError(f"{_flag(name)} {lo:g} {hi:g}: radii are >= 0")


@dataclass
class DumpAverage:
    """The cells of an average of anyone's dumps, from the options (lengths in the
    dumps' units).

    Parameters of :meth:`of`: ``dim`` (2 or 3); in 2D ``thickness`` (the disks' height
    h); ``bins`` or ``edges``; rings (2D) or cylindrical shells (3D): ``r_range`` (or
    ``edges``) and ``center`` (default 0, 0), in 3D with ``layers`` layers over
    ``z_range`` (default the box, one layer); ``slabs`` (x, y or z in 3D) with ``range``
    (default the box) and, in 2D, ``length`` (default the box's other side; the slabs
    span it from the box's lower bound, their segments the errors' spatial replicas), in
    3D ``area`` (default the box's cross-section); ``grid`` (nx, ny or nx, ny, nz) over
    ``x_range``, ``y_range`` (``z_range``), default the box. An option the chosen cells
    do not take is refused (:data:`CELL_OPTIONS`). ``box`` is called for the first
    frame's cell bounds where an option leaves a length to it; ``periodic`` for its
    periodic axes: cells that span a periodic box along an axis take the particles'
    images across its ends; ``tilt`` for its tilt factors (xy, xz, yz): in a tilted box
    slabs must lie across an axis the tilt does not shift (planes of constant z; y where
    yz = 0; x where xy = xz = 0), and other cells need their ranges given. ``why_2d``:
    why the dump was read as 2D, for the message that asks for the thickness.
    """

    geometry: object

    @classmethod
    def of(cls, box, *, dim=2, thickness=None, bins=None, edges=None, center=None,
           r_range=None, slabs=None, range=None, length=None, grid=None, x_range=None,
           y_range=None, z_range=None, layers=None, area=None,
           periodic=lambda: (False,) * 3, tilt=lambda: (0.0, 0.0, 0.0),
           why_2d=None) -> "DumpAverage":
        validate.ring_options(bins, edges)
        given = {k for k, v in dict(thickness=thickness, bins=bins, edges=edges,
                                   center=center, r_range=r_range, slabs=slabs,
                                   range=range, length=length, grid=grid,
                                   x_range=x_range, y_range=y_range, z_range=z_range,
                                   layers=layers, area=area).items() if v is not None}
        kind = "grid" if grid else "slabs" if slabs else ("rings" if dim == 2 else "shells")
        cls._applies(dim, kind, given)
        _check_range("r_range", r_range, nonnegative=True)
        for name, pair in (("range", range), ("x_range", x_range), ("y_range", y_range),
                           ("z_range", z_range)):
            _check_range(name, pair)
        center = (0.0, 0.0) if center is None else tuple(center)
        tilted = any(t != 0.0 for t in tilt())
        if tilted:
            cls._tilted(kind, dim, slabs, tilt(), given)
            if kind != "slabs":       # images across tilted faces are not axis shifts
                periodic = lambda: (False,) * 3                   # noqa: E731
        if dim == 3:
            return cls(_cells3d(box, periodic, bins=bins, edges=edges, center=center,
                                r_range=r_range, slabs=slabs, range=range, grid=grid,
                                x_range=x_range, y_range=y_range, z_range=z_range,
                                layers=layers, area=area))
        if thickness is None:
            why = f" (read as 2D disks: {why_2d}; for spheres give --dim 3)" \
                if why_2d and why_2d != "given" else ""
            raise UserError("--thickness H: give the disks' height, in the dump's length "
                            f"unit (2D disks have volume pi h a^2){why}")
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
            flags = periodic()
            periods = tuple(tuple(r) if given is None and flags[k] else None
                            for k, (given, r) in enumerate(((x_range, xr), (y_range, yr))))
            return cls(Grid(np.linspace(*xr, grid[0] + 1), np.linspace(*yr, grid[1] + 1), h,
                            periods if any(periods) else None))
        if slabs:
            if slabs not in ("x", "y"):
                raise UserError(f"--slabs {slabs}: a 2D dump has slabs across x or y")
            k = "xy".index(slabs)
            bx = box()
            lo_hi = range or bx[k]
            cuts = np.asarray(edges, float) if edges else equal_edges(*lo_hi, bins)
            other = bx[1 - k]
            if length is not None:
                validate.positive("--length", length)
            length = length or (other[1] - other[0])
            # in a tilted box the slabs' segments along x would not follow the cell
            span = None if tilted else (other[0], other[0] + length)
            periods = None
            if range is None and edges is None and periodic()[k]:
                periods = tuple(tuple(bx[k]) if j == k else None for j in (0, 1))
            return cls(Slabs(cuts, h, slabs, length, span, periods))
        if edges is None and r_range is None:
            raise UserError("rings need --r-range R1 R2 (with --bins) or --edges; or choose "
                            "--slabs or --grid")
        cuts = np.asarray(edges, float) if edges else equal_edges(*r_range, bins)
        return cls(Rings(cuts, h, center))

    @staticmethod
    def _applies(dim, kind, given):
        """Refuse options the chosen cells do not take (one line naming the first)."""
        for flag, name in (("--z-range", "z_range"), ("--layers", "layers"),
                           ("--area", "area")):
            if dim == 2 and name in given:
                raise UserError(f"{flag} is for 3D dumps (spheres); these are 2D (give --dim "
                                "3 if the dump is 3D)")
        for flag, name in (("--thickness", "thickness"), ("--length", "length")):
            if dim == 3 and name in given:
                raise UserError(f"{flag} is for 2D disks; the dump is 3D (spheres: volume "
                                "4/3 pi a^3" + ("; slabs take --area" if name == "length"
                                                else "") + ")")
        foreign = sorted(given - CELL_OPTIONS[(dim, kind)])
        if foreign:
            takers = [_KIND_NAMES[key] for key, names in CELL_OPTIONS.items()
                      if key[0] == dim and foreign[0] in names]
            raise UserError(f"{_flag(foreign[0])} does not apply to {_KIND_NAMES[(dim, kind)]}"
                            + (f" (it is for {' and '.join(takers)})" if takers else "")
                            + "; leave it out")

    @staticmethod
    def _tilted(kind, dim, slabs, tilt, given):
        """In a tilted (triclinic) box: slabs across an axis the tilt does not shift;
        other cells with every range given (they are cells in space; no periodic images
        across the tilted faces are taken)."""
        xy, xz, yz = tilt
        shown = f"xy {xy:g}, xz {xz:g}, yz {yz:g}" if dim == 3 else f"xy {xy:g}"
        if kind == "slabs":
            shifting = {"x": (xy, xz), "y": (yz,), "z": ()}[slabs]
            if any(t != 0.0 for t in shifting):
                raise UserError(f"--slabs {slabs}: the box is tilted ({shown}), and planes "
                                f"of constant {slabs} cut its cell in areas that change "
                                "along them; choose slabs across "
                                + ("y or z" if dim == 3 and yz == 0 else "z" if dim == 3
                                   else "y") + ", or a grid with --x-range and --y-range")
            return
        needed = {"grid": ["x_range", "y_range"] + (["z_range"] if dim == 3 else []),
                  "shells": ["z_range"], "rings": []}[kind]
        missing = [n for n in needed if n not in given]
        if missing:
            raise UserError(f"the box is tilted ({shown}): give {_flag(missing[0])} for "
                            f"{_KIND_NAMES[(dim, kind)]} (such cells are cells in space, "
                            "not of the tilted box, and take no images across its faces)")


def _cells3d(box, periodic, *, bins, edges, center, r_range, slabs, range, grid, x_range,
             y_range, z_range, layers, area):
    """The 3D cells of the options (:class:`DumpAverage`)."""
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
