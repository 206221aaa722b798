"""One run directory (manifest + dumps) -> its :class:`~granavg.engine.cell_average.CellAverage`
and profiles, with granavg's defaults (:class:`~granavg.pipeline.description.RunAverage`)."""

from __future__ import annotations

from pathlib import Path

from granavg.engine.fields import Fields
from granavg.engine.quantities import QUANTITIES
from granavg.engine.requirements import (groups_for, needed_columns, needs_body,
                                         optional_columns)
from granavg.engine.smoothing import get as get_kernel
from granavg.errors import UserError
from granavg.io import validate
from granavg.io.dump_columns import dump_header
from granavg.io.reader import DumpReader
from granavg.io.run_directory import read_manifest
from granavg.io.run_dumps import RunDumps
from granavg.pipeline.description import RunAverage, scene_body_forces
from granavg.pipeline.spec import Spec


def run_averager(run_dir, spec: Spec | None = None, *, steps=None, fed: bool = False,
                 **keywords):
    """The :class:`~granavg.engine.cell_average.CellAverage` of a run directory, its frames
    read lazily (only those with time steps in ``steps = (first, last)`` if given).

    Parameters
    ----------
    run_dir : path
        A ``granavg simulate`` directory: manifest (geometry, h, rho_p, dt, Omega) and
        dumps.
    spec : Spec, optional
        The average (:class:`~granavg.pipeline.spec.Spec`): its cells (or their options
        in the run's annulus: ``bins`` equal rings between R_i and R_o, or their
        ``edges`` in m; :meth:`~granavg.pipeline.description.RunAverage.of`; default 20
        rings), kernel and width (m), engine part (defaults in
        :class:`~granavg.pipeline.description.RunAverage`), the dumps to use instead of
        the run directory's (its source's ``atoms`` and ``contacts``) and its
        execution's ``check_cells``. None: the spec of ``keywords``
        (:meth:`~granavg.pipeline.spec.Spec.of`: ``bins=8, t_min=1.5``).
    steps : (int, int), optional
        A dask worker's chunk: the frames with time steps from first to last.
    fed : bool
        No frame is read: the averager is fed later (a dask client merging its workers'
        sums).
    """
    spec = _spec(run_dir, spec, keywords)
    if run_dir is None:
        raise UserError("give the run directory: its manifest holds h, rho_p and the rings")
    run_dir = validate.run_directory(run_dir)
    manifest = validate.check_manifest(read_manifest(run_dir), run_dir / "manifest.json")
    atoms, contacts = run_dumps(run_dir, manifest, spec.source.atoms, spec.source.contacts)
    kernel, time = spec.kernel, spec.averaging.time
    body = scene_body_forces(manifest)
    smooth_edge = kernel not in (None, "exact") and get_kernel(kernel).smooth_edge
    species = spec.averaging.species is not None
    groups = groups_for(spec.averaging.quantities, contacts is not None, bool(body),
                        smooth=smooth_edge, in_time=bool(time.time_kernel), species=species)
    atom_cols, contact_cols = needed_columns(groups)
    if species:
        atom_cols["type"] = "species"
    if needs_body(groups):                # computed from the disks' velocities, not read
        atom_cols = {**{c: g for c, g in atom_cols.items() if c not in ("bx", "by")},
                     "vx": "body", "vy": "body"}
    need_contacts = any(QUANTITIES[g].contacts for g in groups)
    if need_contacts:                     # the couple, where the run's dump holds it
        held = set(dump_header(contacts)[0])
        contact_cols.update({c: g for c, g in optional_columns(groups).items() if c in held})
    reader_a = DumpReader(atoms, list(atom_cols), atom_cols, steps)
    reader_c = DumpReader(contacts, list(contact_cols), contact_cols, steps) \
        if need_contacts else None
    run = RunAverage.of(manifest, groups, spec)
    if spec.execution.check_cells is not None:
        spec.execution.check_cells(run.geometry)
    run.files = {"atoms": str(atoms), "contacts": str(reader_c.path) if reader_c else None}
    return run.averager(None if fed else RunDumps(reader_a, reader_c,
                                                  dt=manifest["derived"]["dt_s"]))


def average_run(run_dir=None, spec: Spec | None = None, **keywords) -> Fields:
    """Ring profiles of a run directory (:func:`run_averager`), with the spec's progress
    bar (keywords: ``progress=None`` on a terminal)."""
    spec = _spec(run_dir, spec, keywords)
    return run_averager(run_dir, spec).run(spec.execution.progress)


def _spec(run_dir, spec, keywords) -> Spec:
    """The spec given, or that of the keywords for this run directory (``progress``
    default None: a bar on a terminal)."""
    if spec is not None and keywords:
        raise TypeError("give a spec, or the options as keywords, not both")
    return spec if spec is not None else Spec.of(run_dir, **{"progress": None, **keywords})


def chosen_sectors(profiles, default="auto"):
    """The number of sectors a single run's profiles took for their errors (to average the
    same run over other cells with the same replicas), or ``default``."""
    return (profiles.meta.get("errors", {}).get("sectors") or {}).get("sectors", default)


def run_dumps(run_dir, manifest: dict, atoms=None, contacts=None) -> tuple:
    """The atoms and contacts dumps a run's average reads: those given, else the run
    directory's (contacts None where it has none)."""
    run_dir = Path(run_dir)
    ext = "dump.gz" if manifest["scene"].get("gzip", True) else "dump"
    atoms = Path(atoms) if atoms else run_dir / f"atoms.{ext}"
    if contacts is None and (run_dir / f"contacts.{ext}").exists():
        contacts = run_dir / f"contacts.{ext}"
    return atoms, contacts
