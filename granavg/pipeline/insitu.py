"""In-situ averaging: ring profiles accumulated while LAMMPS runs, without dump files.

At every dump step the driver hands the frame (atoms and contacts taken from LAMMPS
through its Python module, gathered to rank 0 under MPI) to :class:`InSituAverage`,
which feeds the same :class:`~granavg.engine.cell_average.CellAverage` steps the file reader feeds:
the profiles equal those of averaging the same run's dumps, up to the dumps' 12-digit
rounding. SI units.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from granavg.analysis.regime import warn_if_inertial
from granavg.engine.requirements import groups_for, needs_body
from granavg.engine.smoothing import get as get_kernel
from granavg.io.contacts import COLUMNS
from granavg.io.frames import Frame
from granavg.io.profiles_io import write_profiles
from granavg.engine.api import resolvable
from granavg.engine.cells import Space, from_options
from granavg.engine.smoothing import smooth
from granavg.pipeline.description import (RunAverage, WithBodyForces, scene_body_forces,
                                          scene_diameters)
from granavg.pipeline.runs import chosen_sectors
from granavg.pipeline.spec import Spec
from granavg.sim.lammps_frames import atoms_by_id

log = logging.getLogger(__name__)


def profile_path(out: Path, bins: int) -> Path:
    """Where a run's in-situ profiles over ``bins`` rings go."""
    return Path(out) / f"profiles_{bins}.csv"



class InSituAverage:
    """Ring averages over several ring counts, fed frame by frame: the frame sink
    :func:`granavg.sim.simulate.simulate` feeds (``insitu=InSituAverage``).

    Parameters
    ----------
    manifest : dict
        The run's manifest (geometry, rho_p, dt, Omega, t_end) with ``average``: ``bins``
        (ring counts, equal rings from R_i to R_o, e.g. (20, 60)), ``t_min_s``,
        ``block_time_s``, ``quantities``.
    """

    #: The module ``mpirun`` starts on every rank when the run is averaged in situ
    #: under MPI.
    RANK_MODULE = "granavg.pipeline.mpi_rank"

    @staticmethod
    def files(bins) -> dict:
        """The manifest's ``files`` entries of the profiles over each ring count."""
        return {profile_path(Path("."), n).name:
                f"ring profiles over {n} rings, averaged in situ (docs/profiles.md)"
                for n in bins}

    @staticmethod
    def check_kernel(scene, bins, spec: Spec) -> None:
        """Refuse, before the run, a kernel the in-situ averages cannot take: unknown,
        without a width, or narrower than half the smallest disk radius."""
        rings = smooth(from_options(Space(2), thickness=scene.h,
                                    r_range=(scene.R_i, scene.R_o), bins=min(bins)),
                       spec.kernel, spec.width)
        resolvable(rings, 0.5 * scene_diameters(scene.to_dict()), warn=False)

    def __init__(self, manifest: dict):
        contacts = manifest["scene"].get("contacts", True)
        opts = manifest["average"]
        spec = Spec.from_dict(opts["spec"]) if "spec" in opts else _older(opts)
        spec = replace(spec, source=replace(spec.source, frames="LAMMPS, in situ"))
        kernel = spec.kernel
        self.groups = groups_for(spec.averaging.quantities, contacts,
                                 bool(scene_body_forces(manifest)),
                                 smooth=bool(kernel) and get_kernel(kernel).smooth_edge,
                                 in_time=bool(spec.averaging.time.time_kernel))
        specs = [RunAverage.of(manifest, self.groups, replace(spec, cells={"bins": n}))
                 for n in opts["bins"]]
        self.body = WithBodyForces((), specs[0].body_forces if needs_body(self.groups) else [],
                                   specs[0].geometry, manifest["scene"]["rho_p"])
        self.averages = {n: run.averager(series=k == 0)  # one time series serves all
                         for k, (n, run) in enumerate(zip(opts["bins"], specs))}
        for avg in self.averages.values():
            avg.prepare()
        self.dt, self.contacts = manifest["derived"]["dt_s"], contacts

    def add(self, step: int, atoms: np.ndarray, table: np.ndarray | None) -> None:
        """Accumulate one frame: rows of :func:`granavg.sim.lammps_frames.local_atoms` of all
        ranks and their contacts (:func:`~granavg.io.contacts.contact_table` rows)."""
        frame = self.body.frame(Frame(step, step * self.dt, atoms_by_id(atoms),
                                      dict(zip(COLUMNS, table.T)) if table is not None
                                      else None))
        for avg in self.averages.values():
            avg.add(frame)

    def write(self, out: Path) -> list:
        """Conclude and write ``profiles_<bins>.csv`` (+ JSON sidecar) into ``out``."""
        paths, first = [], None
        for n, avg in self.averages.items():
            if first is not None and avg.sectors:
                avg.sectors = chosen_sectors(first, avg.sectors)   # the same replicas
            profiles = avg.conclude()
            if first is None:
                first = profiles
            else:
                profiles.series = first.series
                profiles.meta["stationarity"] = first.meta.get("stationarity")
            profiles.meta["files"] = {"atoms": "in situ (no file)",
                                      "contacts": "in situ (no file)" if self.contacts else None}
            paths.append(write_profiles(profiles, profile_path(out, n)))
            warn_if_inertial(profiles)
            log.info("in-situ profiles over %d rings: %s (%d frames)", n, paths[-1],
                     profiles.frames_averaged)
        return paths


def _older(opts: dict) -> Spec:
    """The spec of a manifest's in-situ averages written before specs were (a run
    resumed across versions)."""
    return Spec.of(t_min=opts.get("t_min_s"), block_time=opts.get("block_time_s"),
                   quantities=opts.get("quantities"), branch=opts.get("branch", "contact"),
                   kernel=opts.get("kernel"), width=opts.get("width"),
                   **(opts.get("time") or {}))
