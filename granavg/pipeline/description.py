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
from granavg.engine.spec import Averaging
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
    averaging : Averaging
        The engine's part of the spec, resolved: t_min (s; default the scene's
        discarded transient) and the base block length (s).
    spec : Spec or None
        The spec as given, for the sidecar (:class:`~granavg.pipeline.spec.Spec`).
    """

    manifest: dict
    geometry: Cells
    groups: list
    averaging: Averaging
    files: dict = field(default_factory=dict)
    body_forces: list = field(default_factory=list)
    spec: object = None

    @property
    def t_min(self) -> float:
        return self.averaging.time.t_min

    @property
    def block_time(self) -> float:
        return self.averaging.time.block_time

    @classmethod
    def of(cls, manifest: dict, groups, spec=None) -> "RunAverage":
        """The average of the run ``manifest`` describes, its spec
        (:class:`~granavg.pipeline.spec.Spec`; None: the defaults) resolved. The spec's
        cells: cells (:mod:`granavg.cells`), or options of the cells
        (:func:`granavg.engine.cells.from_options`: ``bins`` equal rings or ``edges``, or
        any kind of 2D cells about the cell's axis) in the run's annulus: the disks'
        height h, radii from R_i to R_o about the origin; with a smoothing kernel of a
        width (m), their nodes (:func:`granavg.engine.smoothing.smooth`)."""
        from granavg.pipeline.spec import Spec

        spec = spec if spec is not None else Spec()
        scene, derived = manifest["scene"], manifest["derived"]
        kernel, time = spec.kernel, spec.averaging.time
        if isinstance(spec.cells, Cells):
            rings = smooth(spec.cells, kernel, spec.width)
        else:
            given = {k: v for k, v in (spec.cells or {}).items() if v is not None}
            rings = smooth(from_options(Space(2), **{"thickness": scene["h"],
                                                     "r_range": (scene["R_i"], scene["R_o"]),
                                                     **given}), kernel, spec.width)
        if kernel not in (None, "exact"):            # refused before any frame is read
            resolvable(rings, 0.5 * scene_diameters(scene), warn=False)
        t_min = discard_time(manifest) if time.t_min is None else float(time.t_min)
        block_time = time.block_time or max(derived["dump_interval_s"],
                                            (derived["t_end_s"] - t_min) / MAX_BLOCKS)
        return cls(manifest, rings, list(groups),
                   spec.averaging.with_time(t_min=t_min, block_time=block_time,
                                            interval=derived["dump_interval_s"],
                                            origin=_first_dump(derived)),
                   body_forces=scene_body_forces(manifest), spec=spec)

    def meta(self, engine: dict) -> dict:
        """The sidecar's description of this average: the engine's (``engine``: its
        units, quantities, geometry and frames), with the run's version, manifest, files
        and body forces."""
        first = {k: engine[k] for k in ("units", "unit_system", "quantities")}
        rest = {k: v for k, v in engine.items() if k not in first}
        return {"granavg_version": __version__, **first,
                **legacy_description(self.geometry), **rest, "run_manifest": self.manifest,
                **({"files": self.files} if self.files else {}),
                "body_forces": [t.describe for t in self.body_forces],
                **({"spec": self.spec.to_dict()} if self.spec is not None else {})}

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
        avg = averager(frames, self.geometry, replace(self.averaging, quantities=self.groups),
                       density=scene["rho_p"], units=SI, series=state)
        avg.meta = self.meta(avg.meta)
        return avg


def _first_dump(derived: dict):
    """The first dump's time (s), on the dumps' grid: where fields in time count their
    frames' phases from (None where an older manifest lacks it: the first frame seen)."""
    step = derived.get("first_dump_step")
    return None if step is None else step * derived["dt_s"]
