"""One typed description of an average of a granavg run, built from its manifest, with
every default computed here and nowhere else: rings (or other cells of the annulus) from R_i to R_o
(default :data:`~granavg.engine.cells.base.DEFAULT_BINS`), t_min the scene's discarded
transient (:func:`discard_time`), base time blocks of one dump interval (at most
:data:`~granavg.engine.cell_average.MAX_BLOCKS`), the Couette cell's per-frame state and its
body forces. Anyone's dumps build their cells from options instead
(:mod:`granavg.pipeline.dumps`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from granavg import __version__
from granavg.engine.api import averager, resolvable
from granavg.engine.cell_average import MAX_BLOCKS, CellAverage
from granavg.engine.body_forces import add_body_forces, base_plate
from granavg.engine.cells import Space, from_options, legacy_description
from granavg.engine.cells.base import Cells
from granavg.engine.requirements import needs_body
from granavg.engine.smoothing import smooth
from granavg.engine.unit_system import SI
from granavg.io.frames import Frame
from granavg.io.prefetch import Prefetched
from granavg.sim.couette_state import CouetteState

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


def scene_diameters(scene: dict):
    """The smallest and largest disk diameter of a scene (m): its two sizes, spread by
    ``size_spread``."""
    import numpy as np

    spread = scene.get("size_spread", 0.0)
    return np.array([scene["d_s"] * (1 - spread), scene["d_l"] * (1 + spread)])


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
        return replace(f, atoms=add_body_forces(     # the same atoms, in their order
            f.atoms, self.terms, self.cells.particle_volume, self.rho_p))

    def __iter__(self):
        return (self.frame(f) for f in self.source)

    def __getattr__(self, name):
        return getattr(self.source, name)


@dataclass
class RunAverage:
    """An average of a granavg run: its cells, quantities, window and time blocks.

    Attributes
    ----------
    manifest : dict
        The run's manifest (its scene: geometry, h, rho_p, Omega, d_s).
    geometry : Cells
        Rings by default (:mod:`granavg.engine.cells`).
    groups : list of str
        Quantity groups (:data:`granavg.engine.quantities.QUANTITIES`).
    t_min, block_time : float
        Start of the average and base block length, s.
    time : dict
        The time axis' options (:func:`granavg.engine.api.averager`: ``t_max``,
        ``windows``, ``time_kernel``, ...).
    """

    manifest: dict
    geometry: Cells
    groups: list
    t_min: float
    block_time: float
    files: dict = field(default_factory=dict)
    branch: str = "contact"
    body_forces: list = field(default_factory=list)
    sectors: object = "auto"
    time: dict = field(default_factory=dict)

    @classmethod
    def of(cls, manifest: dict, groups, *, t_min=None, block_time=None, branch="contact",
           sectors="auto", kernel=None, width=None, cells=None, time=None,
           **options) -> "RunAverage":
        """The average of the run ``manifest`` describes, options resolved. ``cells``:
        cells (:mod:`granavg.cells`), or options of the cells (a dict, or as keywords
        ``options``; :func:`granavg.engine.cells.from_options`: ``bins`` equal rings or
        ``edges``, or any kind of 2D cells about the cell's axis) in the run's annulus:
        the disks' height h, radii from R_i to R_o about the origin; with a smoothing
        ``kernel`` of ``width`` (m), their nodes (:func:`granavg.engine.smoothing.smooth`)."""
        scene, derived = manifest["scene"], manifest["derived"]
        if isinstance(cells, Cells):
            rings = smooth(cells, kernel, width)
        else:
            given = {k: v for k, v in {**(cells or {}), **options}.items() if v is not None}
            rings = smooth(from_options(Space(2), **{"thickness": scene["h"],
                                                     "r_range": (scene["R_i"], scene["R_o"]),
                                                     **given}), kernel, width)
        if kernel not in (None, "exact"):            # refused before any frame is read
            resolvable(rings, 0.5 * scene_diameters(scene), warn=False)
        t_min = discard_time(manifest) if t_min is None else float(t_min)
        block_time = block_time or max(derived["dump_interval_s"],
                                       (derived["t_end_s"] - t_min) / MAX_BLOCKS)
        return cls(manifest, rings, list(groups), t_min, block_time, branch=branch,
                   body_forces=scene_body_forces(manifest), sectors=sectors,
                   time={k: v for k, v in (time or {}).items() if v is not None})

    def meta(self, engine: dict) -> dict:
        """The sidecar's description of this average: the engine's (``engine``: its
        units, quantities, geometry and frames), with the run's version, manifest, files
        and body forces."""
        first = {k: engine[k] for k in ("units", "unit_system", "quantities")}
        rest = {k: v for k, v in engine.items() if k not in first}
        return {"granavg_version": __version__, **first,
                **legacy_description(self.geometry), **rest, "run_manifest": self.manifest,
                **({"files": self.files} if self.files else {}),
                "body_forces": [t.describe for t in self.body_forces]}

    def averager(self, frames=None, series: bool = True) -> CellAverage:
        """The :func:`~granavg.engine.api.averager` of ``frames`` (None: fed later, in
        situ or by a dask client's merges) with the Couette cell's per-frame state
        (``series``; one is enough where several ring counts see the same frames)."""
        scene = self.manifest["scene"]
        state = CouetteState(scene["R_i"], scene["R_o"], scene["h"], scene["rho_p"],
                             scene["d_s"]) if series else None
        if frames is not None and self.body_forces and needs_body(self.groups):
            frames = WithBodyForces(frames, self.body_forces, self.geometry, scene["rho_p"])
        if frames is not None:
            frames = Prefetched(frames)
        avg = averager(frames, self.geometry, rho_p=scene["rho_p"], quantities=self.groups,
                       t_min=self.t_min, block_time=self.block_time, units=SI,
                       branch=self.branch, sectors=self.sectors, series=state,
                       interval=self.manifest["derived"]["dump_interval_s"], **self.time)
        avg.meta = self.meta(avg.meta)
        return avg
