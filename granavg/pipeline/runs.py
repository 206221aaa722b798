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


def run_averager(run_dir, *, t_min=None, block_time=None, quantities=None, atoms=None,
                 contacts=None, steps=None, branch="contact", sectors="auto",
                 check_cells=None, kernel=None, width=None, fed=False, cells=None,
                 time=None, **options):
    """The :class:`~granavg.engine.cell_average.CellAverage` of a run directory, its frames
    read lazily (only those with time steps in ``steps = (first, last)`` if given).

    Parameters
    ----------
    run_dir : path
        A ``granavg simulate`` directory: manifest (geometry, h, rho_p, dt, Omega) and
        dumps.
    t_min, block_time : float, optional
        Start of the average and base block length (s); defaults in
        :class:`~granavg.pipeline.description.RunAverage`.
    quantities : sequence of str, optional
        Keys of :data:`~granavg.engine.quantities.QUANTITIES`; default all the files allow.
    atoms, contacts : path, optional
        Dump files to use instead of the run directory's.
    branch : {"contact", "paper"}
        Where the branch vectors of Eqs. 5 and 7 end
        (:data:`granavg.engine.kernels.BRANCHES`).
    sectors : "auto", int or None
        Sectors per ring for the errors' spatial replicas
        (:mod:`granavg.engine.uncertainty.structure`).
    kernel, width : optional
        A smoothing kernel and its width (m): fields at the cells' centres
        (:mod:`granavg.engine.smoothing`).
    check_cells : callable, optional
        Called with the cells before any frame is read (e.g. that an output can hold
        them); raises to refuse.
    fed : bool
        No frame is read: the averager is fed later (a dask client merging its workers'
        sums).
    cells : Cells or dict, optional
        The cells (:mod:`granavg.cells`), or options of the cells in the run's annulus
        (``bins`` equal rings between R_i and R_o, or their ``edges`` in m;
        :meth:`~granavg.pipeline.description.RunAverage.of`); default 20 rings.
    time : dict, optional
        The time axis' options of :func:`granavg.engine.api.averager` (``t_max``,
        ``windows``, ``window_frames``, ``time_kernel``, ``time_width``, ``times``).
    **options
        Options of the cells, as keywords (``bins=60``).
    """
    if run_dir is None:
        raise UserError("give the run directory: its manifest holds h, rho_p and the rings")
    run_dir = validate.run_directory(run_dir)
    manifest = validate.check_manifest(read_manifest(run_dir), run_dir / "manifest.json")
    atoms, contacts = run_dumps(run_dir, manifest, atoms, contacts)
    body = scene_body_forces(manifest)
    smooth_edge = kernel not in (None, "exact") and get_kernel(kernel).smooth_edge
    groups = groups_for(quantities, contacts is not None, bool(body), smooth=smooth_edge,
                        in_time=bool((time or {}).get("time_kernel")),
                        species=(time or {}).get("species") is not None)
    atom_cols, contact_cols = needed_columns(groups)
    if (time or {}).get("species") is not None:
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
    spec = RunAverage.of(manifest, groups, t_min=t_min, block_time=block_time,
                         branch=branch, sectors=sectors, kernel=kernel, width=width,
                         cells=cells, time=time, **options)
    if check_cells is not None:
        check_cells(spec.geometry)
    spec.files = {"atoms": str(atoms), "contacts": str(reader_c.path) if reader_c else None}
    return spec.averager(None if fed else RunDumps(reader_a, reader_c,
                                                   dt=manifest["derived"]["dt_s"]))


def average_run(run_dir=None, *, progress=None, **options) -> Fields:
    """Ring profiles of a run directory (options as for :func:`run_averager`)."""
    return run_averager(run_dir, **options).run(progress)


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
