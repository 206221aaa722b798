"""What a run records about itself in its manifest while it runs: the largest overlap
seen (``overlap``) and where its wall time went (``timing``). SI units."""

from __future__ import annotations

import logging
import time
from contextlib import contextmanager
from pathlib import Path

from granavg.io.contacts import COLUMNS
from granavg.io.run_directory import read_manifest, write_manifest
from granavg.sim.scene import Derived

log = logging.getLogger(__name__)


#: Largest overlap accepted without a warning, as a fraction of the small diameter: the
#: linear model and the branch vectors of Eqs. 4-7 (centre to contact point = radius)
#: assume overlaps much smaller than a disk; at 0.2 d_s the branch vector is 10% off.
OVERLAP_WARN = 0.2


class Overlaps:
    """The largest overlap in the frames of the averaging window (t >= the scene's
    discarded transient; all frames where none reaches it), recorded in the manifest as
    ``overlap.max_over_d_s`` with a warning above :data:`OVERLAP_WARN`, and the largest
    of any frame beside it. The transient's frames do not count for the warning: a run
    from a data file (no contact history) or a packing made by another law starts with
    the overlaps of how it was made (measured: 0.167 d_s in the first frame of a
    packing aged with mu_roll = 0.3 and sheared with 0.1, at most 0.13 d_s after it). A
    run that took no contact frames (``contacts=0``) records nothing rather than a
    zero."""

    def __init__(self, derived: Derived):
        self.d_s, self.seen = derived.scene.d_s, False
        self.dt, self.t_window = derived.dt, derived.t_discard
        self.window = self.all = 0.0

    def add(self, table, step: int) -> None:
        self.seen = True
        if len(table):
            largest = float(table[:, COLUMNS.index("overlap")].max())
            self.all = max(self.all, largest)
            if step * self.dt >= self.t_window:
                self.window = max(self.window, largest)

    def record(self, out: Path) -> None:
        if not self.seen:
            return
        manifest = read_manifest(out)
        old = manifest.get("overlap") or {}                # an earlier part of the run
        window = max(self.window / self.d_s, old.get("window_max_over_d_s") or 0.0)
        everywhere = max(self.all / self.d_s, old.get("max_over_d_s_all_frames",
                                                     old.get("max_over_d_s", 0.0)))
        ratio = window if window > 0 else everywhere
        manifest["overlap"] = {"max_over_d_s": ratio, "window_max_over_d_s": window or None,
                               "max_over_d_s_all_frames": everywhere,
                               "warn_above": OVERLAP_WARN,
                               "from": "contact frames written or averaged, at t >= "
                                       f"{self.t_window:g} s (all frames if none is)"}
        write_manifest(out, manifest)
        if ratio > OVERLAP_WARN:
            log.warning("largest overlap %.2f d_s is above %.2f d_s: the springs are too soft "
                        "for the linear contact model (raise k_n or lower Omega)", ratio,
                        OVERLAP_WARN)


class Timing:
    """Wall seconds this process spent in LAMMPS' steps and in taking frames from it
    (contact dump, in-situ averages); recorded in the manifest as ``timing`` (summed
    over the parts of a resumed run), so that what an output costs is measured in the
    run itself."""

    def __init__(self):
        self.lammps_s = self.frames_s = 0.0
        self.frames, self._t0 = 0, 0.0

    @contextmanager
    def lammps(self):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.lammps_s += time.perf_counter() - t0

    def start_frame(self) -> None:
        self._t0 = time.perf_counter()

    def end_frame(self) -> None:
        self.frames_s += time.perf_counter() - self._t0
        self.frames += 1

    def record(self, out: Path) -> None:
        manifest = read_manifest(out)
        old = manifest.get("timing") or {}
        manifest["timing"] = {
            "units": "s (wall time of the granavg process)",
            "lammps_steps_s": old.get("lammps_steps_s", 0.0) + self.lammps_s,
            "frames_s": old.get("frames_s", 0.0) + self.frames_s,
            "frames": old.get("frames", 0) + self.frames,
            "what": "LAMMPS' steps; taking frames from LAMMPS (contact dump, in-situ averages)"}
        write_manifest(out, manifest)
