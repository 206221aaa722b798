"""The embedded run: the deck through the LAMMPS Python module, the shear driven in
chunks; at every dump step the contact dump is written and/or the in-situ averages fed
(SI units). Under MPI every rank runs this and rank 0 gathers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from granavg.errors import UserError
from granavg.io.contacts import COLUMNS, FORMAT, contact_table, radius_by_id
from granavg.io.dumpfile import open_text, write_frame
from granavg.sim.lammps_frames import gather, local_atoms, local_contacts, local_radii
from granavg.sim.lammps_session import lammps_session, load_lammps
from granavg.sim.run_layout import (CONTACTS, DECK, SHEARED, cmdargs, dump_ext, is_dump_step,
                                   shear_bar)
from granavg.sim.run_monitor import Overlaps, Timing
from granavg.sim.scene import Derived, Scene


def run_embedded(out, derived: Derived, manifest, variables, omp, progress, comm=None,
                 insitu=None):
    """Run the deck through the LAMMPS Python module and drive the shear in chunks; at
    every dump step write the contact dump and/or feed the in-situ averages. Under MPI
    (``comm``, an mpi4py communicator) every rank calls this; rank 0 gathers and writes.

    ``insitu`` is the frame sink of a run with ``manifest["average"]``: a class whose
    instance ``insitu(manifest)`` takes every frame (``add(step, atoms, table)``, rows of
    :func:`~granavg.sim.lammps_frames.local_atoms` and
    :func:`~granavg.io.contacts.contact_table`) and finally ``write(out)``; the pipeline
    gives it (:class:`granavg.pipeline.insitu.InSituAverage`)."""
    lammps = load_lammps()
    scene = derived.scene
    root = comm is None or comm.rank == 0
    contacts_needed = scene.contacts and (scene.dumps or bool(manifest.get("average")))
    writer = _ContactWriter(out / CONTACTS.format(ext=dump_ext(scene)), derived) \
        if scene.contacts and scene.dumps and root else None
    sink = insitu(manifest) if insitu is not None and manifest.get("average") and root \
        else None
    frames_needed = contacts_needed or bool(manifest.get("average"))
    overlaps = Overlaps(derived)
    with lammps_session(cmdargs(out, variables, omp), log_hint=str(out / "log.lammps"),
                        comm=comm) as lmp:
        lmp.file(str(out / "deck" / DECK.name))
        _check_inserted(lmp, scene, variables["start"])
        lmp.command("run 0")                     # set up; writes the atom dump if due
        radii = gather(comm, local_radii(lmp))  # sizes are fixed during shear
        radius = radius_by_id(radii[:, 0], radii[:, 1]) if radii is not None else None
        step = int(lmp.get_thermo("step"))
        stride = max(1, derived.n_shear // 400)
        box = np.column_stack(lmp.extract_box()[:2])
        timing = Timing()
        with shear_bar(derived, step, progress if root else False) as bar:
            while True:
                if frames_needed and is_dump_step(step, derived):
                    timing.start_frame()
                    raw = gather(comm, local_contacts(lmp, lammps)) if contacts_needed else None
                    atoms = gather(comm, local_atoms(lmp)) if sink or comm else None
                    table = contact_table(raw, radius) if raw is not None else None
                    if table is not None:
                        overlaps.add(table, step)
                    if writer is not None:
                        writer.write(step, table, box)
                    if sink is not None:
                        sink.add(step, atoms, table)
                    timing.end_frame()
                if step >= derived.n_shear:
                    break
                target = min(_next_dump_step(step, derived) if frames_needed else math.inf,
                             step + stride, derived.n_shear)
                with timing.lammps():
                    lmp.command(f"run {target} upto pre no post no")
                bar.update((target - step) * derived.dt)
                step = target
        lmp.command(f"write_data {out / SHEARED} nocoeff")
    if sink is not None:
        sink.write(out)
    if root:
        overlaps.record(out)
        timing.record(out)


class _ContactWriter:
    """Appends contact-dump frames (rows of :func:`~granavg.io.contacts.contact_table`)."""

    def __init__(self, path: Path, derived: Derived):
        self.path, self.derived = path, derived

    def write(self, step, table, box):
        with open_text(self.path, "at") as fh:
            write_frame(fh, step, step * self.derived.dt, COLUMNS, table, box, FORMAT)


def _next_dump_step(step, d: Derived) -> int:
    return max(d.n_dump_start, (step // d.dump_every + 1) * d.dump_every)


def _check_inserted(lmp, scene: Scene, start) -> None:
    lmp.command("variable granavg_nmob equal count(mobile)")
    n = int(lmp.extract_variable("granavg_nmob"))
    want = scene.n_small + scene.n_large
    if n != want and start != "none":
        raise UserError(f"the start file {start} holds {n} disks, the scene {want}; set "
                        "n_small, n_large and the geometry of the run that wrote it")
    if n != want:
        raise UserError(f"only {n} of {want} disks could be inserted at grow_from="
                        f"{scene.grow_from}; lower grow_from or the number of disks")
