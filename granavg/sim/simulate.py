"""Run the Couette deck: in-process through the LAMMPS Python module, or under mpirun.

Data flow: :class:`~granavg.sim.scene.Scene` -> deck variables -> LAMMPS -> run directory
(``manifest.json``, ``log.lammps``, ``deck/``, ``atoms.dump.gz``, ``contacts.dump.gz``,
``restart/``). Every quantity is in SI units.

This module sets a run up (refusals, manifest, resume) and hands it to a job:
:mod:`granavg.sim.embedded` (default, one process: LAMMPS runs the deck up to the start
of shear, then granavg advances it in chunks, writing the contact dump from ``compute
pair/local`` in-process), :mod:`granavg.sim.mpi` (``np > 1``: ``mpirun -np N lmp`` runs
the whole deck and its raw contact dump is converted afterwards) or the reference DEM.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import logging
import math
import re
import shlex
import shutil
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

from granavg import __version__
from granavg.engine.quantities import QUANTITIES
from granavg.engine.requirements import groups_for
from granavg.errors import LammpsError, ParameterError, UserError, literal
from granavg.sim.lammps_session import lammps_version, threads_that_fit
from granavg.sim.run_layout import ATOMS, CONTACTS, CONTACTS_RAW, DECK, SHEARED, cmdargs, dump_ext
from granavg.sim.embedded import run_embedded
from granavg.sim.mpi import run_mpi, run_mpi_python
from granavg.io.run_directory import (claim_new, frame_steps, read_manifest, restart_files,
                               truncate_dump, write_manifest)
from granavg.sim import packings, trade
from granavg.sim.scene import Derived, Scene

log = logging.getLogger(__name__)

PREPARATION = (
    "disks inserted at random without overlap at grow_from of their diameter (large ones "
    "first), grown linearly to full size over t_grow with viscous damping (time t_damp), "
    "relaxed t_relax at full size, damping removed, clock reset to t = 0, then sheared")
WALLS = (
    "rough walls: rings of glued disks of diameter wall_d, centres wall_spacing*wall_d "
    "apart, touching R_i from inside (turned rigidly counter-clockwise at Omega by fix "
    "move rotate, which also spins them) and R_o from outside (fixed); both rings frozen "
    "(infinite mass: a disk-wall contact uses the disk's mass). Contacts with them are "
    "computed by the same pair style (friction mu_wall).")


class Interrupted(Exception):
    """The run was stopped by a signal; results so far are kept and can be resumed."""


ENGINES = ("lammps", "reference")


def simulate(scene: Scene, out, *, np_ranks: int = 1, omp_threads: int = 1,
             progress: bool | None = None, preset: str | None = None, start=None,
             engine: str = "lammps", average=None, insitu=None,
             plan: dict | None = None, time_accuracy: float | None = None) -> Path:
    """Run a new Couette simulation into the empty directory ``out``.

    Parameters
    ----------
    scene : Scene
        What to simulate (SI units); refused with a :class:`UserError` if unsound.
    out : path
        Output directory; must not hold another run.
    np_ranks : int
        MPI ranks; > 1 runs ``mpirun -np N lmp`` from the mpich wheel.
    omp_threads : int
        OpenMP threads per rank (``-sf omp -pk omp N``).
    progress : bool or None
        Show a progress bar; ``None`` shows it only on a terminal.
    preset : str, optional
        Name of the preset the scene came from, recorded in the manifest.
    start : path, optional
        A prepared packing (``prepared.data`` of an earlier run, or any sphere-style
        LAMMPS data file of this scene): shear it instead of preparing a new one.
        Contacts start with unloaded tangential springs (data files hold no history).
    engine : {"lammps", "reference"}
        ``reference`` runs :mod:`granavg.sim.refdem` instead of LAMMPS (needs ``start``, one
        process, no restart files): for cross-validation, not production.
    average : sequence of int, optional
        Ring counts to average over in situ (while LAMMPS runs, from its memory): writes
        ``profiles_<n>.csv`` for each. Under MPI each rank runs granavg with LAMMPS and
        rank 0 gathers the frames. With ``scene.dumps`` False no dump is written.
    insitu : class, optional
        The frame sink that averages in situ (needed with ``average``): built as
        ``insitu(manifest)`` on the process that gathers the frames, fed
        ``add(step, atoms, table)`` and ``write(out)``; ``insitu.files(bins)`` names
        what it writes and ``insitu.RANK_MODULE`` is started on every MPI rank. The
        pipeline gives :class:`granavg.pipeline.insitu.InSituAverage`.
    plan : dict, optional
        The in-situ averages' spec as plain values (the pipeline's ``Spec.to_dict()``),
        recorded for the sink (``manifest["average"]["spec"]``): their start (``time``'s
        ``t_min``, s; default the scene's discarded transient, ``discard_rotations``
        inner-ring rotations), base block (default one dump interval, at most 512
        blocks), kernel, width and time axis.

    time_accuracy : float, optional
        The median momentum residual in time (of rho g) that the dump-interval forecast
        aims for (:func:`granavg.sim.trade.dump_interval`; the manifest's
        ``dump_interval_forecast``, for 0.01 where not given), logged where given.

    Returns
    -------
    Path
        The run directory, with ``manifest.json`` status ``complete``.
    """
    derived = scene.derive()                      # refuse before touching the disk
    shipped = scene.packing and start is None
    if shipped:
        packings.check(scene.packing, scene.seed)
    start = _check_start(start, engine, np_ranks, omp_threads, shipped)
    average = _check_average(derived, average, engine, plan)
    if average and insitu is None:
        raise UserError("in-situ averages need a frame sink (granavg.pipeline.simulation."
                        "simulate_run gives it)")
    if np_ranks > 1 and derived.coeffs.mu_roll > 0:
        log.warning("with rolling resistance under MPI, a disk that changes processor can "
                    "swap a contact's order in LAMMPS' neighbour list, and LAMMPS then "
                    "reverses that contact's rolling spring (docs/scene.md); one process "
                    "keeps every order")
    if engine == "lammps" and not DECK.exists():
        raise UserError(f"the LAMMPS deck {DECK} is missing; reinstall granavg (the wheel "
                        "ships it as granavg/lammps_inputs/couette.lmp)")
    out = claim_new(Path(out))
    if shipped:
        start = packings.unpack(scene.packing, scene.seed, out)
    if engine == "lammps":
        (out / "deck").mkdir()
        shutil.copy2(DECK, out / "deck" / DECK.name)
    manifest = _new_manifest(derived, preset, np_ranks, omp_threads, start, engine)
    if engine == "lammps":
        manifest["forecast"] = trade.expectation(derived, prepared=start is not None,
                                                 np_ranks=np_ranks, omp_threads=omp_threads)
        log.info("%s", trade.describe(manifest["forecast"]))
    if derived.dump_every:
        manifest["dump_interval_forecast"] = trade.dump_interval(
            derived.coeffs.t_c, derived.dt, derived.dump_every, time_accuracy or 0.01)
        if time_accuracy is not None:          # said where asked; the manifest holds it
            log.info("%s", trade.describe_dump_interval(manifest["dump_interval_forecast"]))
    manifest["average"] = {"bins": average, "spec": plan} if average else None
    if average:
        manifest["files"].update(insitu.files(average))
    write_manifest(out, manifest)
    return _execute(out, derived, manifest, resume_from=None, progress=progress,
                    insitu=insitu)


def scene_for(scene: Scene, quantities) -> Scene:
    """The scene with contact output only when a requested quantity needs it: contact
    forces for coordination, F, sigma and eps; positions and velocities for the rest."""
    if quantities is None:
        return scene
    groups_for(quantities, have_contacts=True)        # unknown names are refused
    needs = [q for q in quantities if QUANTITIES[q].contacts]
    if needs and not scene.contacts:
        raise ParameterError("quantities", f"{{param}} {needs[0]} needs contact forces, but "
                             "the scene has contacts=0; drop the quantity or the setting")
    if not needs and scene.contacts:
        log.info("no requested quantity needs contact forces: LAMMPS computes and writes "
                 "no contact output")
        return dataclasses.replace(scene, contacts=False)
    return scene


def _check_average(derived: Derived, average, engine, plan):
    scene = derived.scene
    bins = sorted({int(n) for n in average}) if average else []
    t_min = ((plan or {}).get("time") or {}).get("t_min")
    if any(n < 1 for n in bins):
        raise ParameterError("average", f"{{param}} {literal(bins)}: ring counts must be "
                             ">= 1")
    t0 = derived.t_discard if t_min is None else t_min
    if bins and t0 >= derived.n_shear * derived.dt:
        raise ParameterError("t_min", f"in-situ averages would start at t_min = {t0:g} s, "
                             f"after the end of shear (t_end = {scene.t_end:g} s); give "
                             "{param} below t_end")
    if not scene.dumps and not bins:
        raise ParameterError("average", "dumps=0 writes no dump files: add {param} N so the "
                             "run keeps its profiles")
    if bins and engine != "lammps":
        raise ParameterError("average", "{param} runs inside LAMMPS; the reference engine "
                             "writes dumps (average them with 'granavg average')")
    return bins


def _explained(exc: LammpsError, out: Path, derived: Derived) -> LammpsError:
    """A LAMMPS error, with what it means for a Couette run and what to do."""
    msg = str(exc)
    m = re.search(r"halt condition .*?met on step (\d+)", msg)
    lost = "Lost atoms" in msg
    if not (m or lost):
        return exc
    where = f" near step {m.group(1)} (t = {int(m.group(1)) * derived.dt:.4g} s of shear)" \
        if m else ""
    what = ("disks were lost from the box" if lost else
            f"the disks' kinetic energy passed {derived.ke_max:.3g} J (all disks at "
            f"{derived.blowup_speed:.3g} m/s) or a disk left the annulus")
    return LammpsError(f"the run blew up{where}: {what}; dumps and restart files written "
                       f"before are kept in {out}; lower dt (raise n_per_tc), Omega or the "
                       f"overlaps (k_n, grow_from)")


def _check_start(start, engine, np_ranks, omp_threads, shipped=False):
    if engine not in ENGINES:
        raise UserError(f"unknown engine {engine!r}; choose one of: {', '.join(ENGINES)}")
    if start is not None:
        start = Path(start).resolve()
        if not start.is_file():
            raise ParameterError("start", f"{{param}} {literal(start)}: no such file; give a "
                                 "prepared packing such as RUN/prepared.data")
    if engine == "reference" and ((start is None and not shipped) or np_ranks > 1
                                  or omp_threads > 1):
        raise ParameterError("start", "the reference engine shears a prepared packing in "
                             "one process: give {param} RUN/prepared.data and no {np}/{omp}")
    return start


def resume(out, *, np_ranks: int | None = None, omp_threads: int | None = None,
           progress: bool | None = None) -> Path:
    """Continue an interrupted run from its newest usable restart file.

    The dumps are cut back to the frames before the restart point, then the deck
    continues (``read_restart``) to the same final step the run was set up for.
    """
    out = Path(out)
    manifest = read_manifest(out)
    if manifest.get("status") == "complete":
        raise UserError(f"{out} is already complete; nothing to resume")
    if manifest["execution"].get("engine", "lammps") != "lammps":
        raise ParameterError("out", f"{literal(out)} was run by the reference engine, which "
                             "writes no restart files; run it again with a new {param}")
    scene = Scene.from_dict(manifest["scene"])
    derived = scene.derive()
    if manifest.get("average"):
        if not scene.dumps:
            raise ParameterError("out", f"{literal(out)} averaged in situ without dumps; its "
                                 "averages cannot continue from a restart; run it again "
                                 "with a new {param}")
        log.warning("in-situ averages do not survive an interruption: the resumed run "
                    "writes dumps only; average them with 'granavg average %s'", out)
        manifest["average"] = None
    restart_step, restart_path = _usable_restart(out, derived)
    for name in (ATOMS, CONTACTS, CONTACTS_RAW):
        path = out / name.format(ext=dump_ext(scene))
        if path.exists():
            truncate_dump(path, restart_step)
    for step in [s for s in restart_files(out) if s > restart_step]:
        restart_files(out)[step].unlink()
    _keep_old_log(out)
    manifest["resumed"] = manifest.get("resumed", []) + [
        {"from_step": restart_step, "at": _now()}]
    if np_ranks is not None:
        manifest["execution"]["np"] = np_ranks
    if omp_threads is not None:
        manifest["execution"].update({"omp": omp_threads, "omp_asked": omp_threads})
    return _execute(out, derived, manifest, resume_from=restart_path, progress=progress)


def _execute(out, derived, manifest, resume_from, progress, insitu=None):
    manifest["status"] = "running"
    write_manifest(out, manifest)
    ex = manifest["execution"]
    start = manifest.get("start")
    threads, why = threads_that_fit(ex.get("omp_asked", ex["omp"]), ex["np"])
    if why:
        log.warning(why)
    ex.update({"omp_asked": ex.get("omp_asked", ex["omp"]), "omp": threads})
    if ex.get("engine") != "reference":
        variables = deck_variables(out, derived, embedded=ex["np"] == 1 or bool(
            manifest.get("average")), resume=resume_from, start=start)
        (out / "run.sh").write_text(_command_script(variables, ex))
    try:
        with _signals_interrupt():
            if ex.get("engine") == "reference":
                from granavg.sim.refdem_run import run_reference
                run_reference(out, derived, Path(start), progress)
            elif ex["np"] == 1:
                run_embedded(out, derived, manifest, variables, ex["omp"], progress,
                             insitu=insitu)
            elif manifest.get("average"):
                run_mpi_python(out, derived, ex["np"], progress, insitu.RANK_MODULE)
            else:
                run_mpi(out, derived, variables, ex["np"], ex["omp"], progress)
    except (Interrupted, KeyboardInterrupt):
        _finish(out, manifest, "interrupted")
        raise ParameterError("resume", f"run interrupted; results so far are in "
                             f"{literal(out)}; continue it with 'granavg simulate {{out}} "
                             f"{literal(out)} {{param}}'") from None
    except LammpsError as exc:
        _finish(out, manifest, "failed")
        raise _explained(exc, out, derived) from None
    except BaseException:                # bad input found mid-run, or a bug
        _finish(out, manifest, "failed")
        raise
    _finish(out, manifest, "complete")
    return out


def _usable_restart(out, derived):
    """The newest restart step at or before which both dumps are complete."""
    restarts = restart_files(out)
    if not restarts:
        raise ParameterError("out", f"{literal(out)} has no restart file yet; start it again "
                             "with a new {param}")
    limit = math.inf
    for name in (ATOMS, CONTACTS, CONTACTS_RAW):
        path = out / name.format(ext=dump_ext(derived.scene))
        if path.exists():
            steps = frame_steps(path)
            limit = min(limit, (steps[-1] + derived.dump_every) if steps
                        else derived.n_dump_start)
    ok = [s for s in restarts if s <= limit]
    if not ok:
        raise ParameterError("out", f"{literal(out)}: no restart file matches the dumps "
                             "written; start it again with a new {param}")
    return max(ok), restarts[max(ok)]


def deck_variables(out, derived: Derived, embedded: bool, resume, start) -> dict:
    s = derived.scene
    v = {k: repr(x) if isinstance(x, float) else str(x)
         for k, x in derived.lammps_variables().items()}
    v.update({
        "out": str(out), "drive": "python" if embedded else "lammps",
        "contacts": ("python" if embedded else "native") if s.contacts and s.dumps
        else "none",
        "atoms_dump": "1" if s.dumps else "0",
        "resume": str(resume) if resume else "none", "resuming": "1" if resume else "0",
        "start": str(start) if start else "none", "starting": "1" if start else "0",
        "astyle": "custom/gz" if s.gzip else "custom",
        "lstyle": "local/gz" if s.gzip else "local", "ext": dump_ext(s),
        "thermo_every": str(max(1, derived.n_shear // 200)),
    })
    v["restart_step"] = str(int(Path(resume).name.split(".")[1]) if resume else 0)
    return v


def _command_script(variables, ex) -> str:
    cmd = (["mpirun", "-np", str(ex["np"])] if ex["np"] > 1 else []) + \
          ["lmp", "-in", "deck/couette.lmp", *cmdargs(Path("."), variables, ex["omp"])]
    note = ("# granavg ran this deck in-process with drive=python: after the deck, it\n"
            "# advanced the shear with 'run N upto' and wrote contacts.* from compute\n"
            "# pair/local. To let LAMMPS run it alone: -var drive lammps -var contacts native\n"
            if ex["np"] == 1 else "")
    return "#!/bin/sh\n# The exact LAMMPS run of this directory (SI units).\n" + note + \
        shlex.join(cmd) + "\n"


def _new_manifest(d: Derived, preset, np_ranks, omp, start=None, engine="lammps") -> dict:
    s, c = d.scene, d.coeffs
    lammps = engine == "lammps"
    return {
        "granavg_version": __version__,
        "units": "SI (m, s, kg, N, rad/s)",
        "status": "created",
        "preset": preset,
        "scene": s.to_dict(),
        "contact_law": {
            "model": f"{c.pair_style} (linear spring-dashpot, tangential history, "
                     "Coulomb cap); one gamma_n set by e_n of a small-small pair",
            "pair_style": c.pair_style,
            "k_n_N_per_m": c.kn, "k_t_N_per_m": c.kt, "gamma_n_per_s": c.gamma_n,
            "gamma_t_per_s": c.gamma_t, "mu": c.mu, "mu_wall": c.mu_wall,
            "mu_roll": c.mu_roll, "k_roll_N_per_m": c.k_roll, "gamma_roll_kg_per_s":
            c.gamma_roll,
            "e_n_by_pair": d.restitutions(),
        },
        "derived": {
            "t_c_s": c.t_c, "dt_s": d.dt, "dt_safe_max_s": d.dt_safe,
            "steps_per_contact": s.n_per_tc, "period_T_s": d.period,
            "t_discard_s": d.t_discard,
            "area_fraction": d.area_fraction, "mass_small_kg": d.m_small,
            "mass_large_kg": d.m_large, "wall_d_m": d.wall_d, "n_grow": d.n_grow, "n_relax": d.n_relax,
            "n_shear_steps": d.n_shear, "t_end_s": d.n_shear * d.dt,
            "dump_every_steps": d.dump_every, "dump_interval_s": d.dump_every * d.dt,
            "first_dump_step": d.n_dump_start, "restart_every_steps": d.restart_every,
        },
        "start": str(start) if start else None,
        "preparation": PREPARATION if start is None else
        packings.describe(s.packing, s.seed) if Path(start).name == packings.START else
        f"the packing in {start} (contacts start with unloaded tangential springs)",
        "wall_model": WALLS,
        "seeds": {"large_disks": s.seed, "small_disks": s.seed + 1},
        "lammps_version": lammps_version(),
        "execution": {"engine": engine, "np": np_ranks, "omp": omp,
                      "mode": "reference" if not lammps else
                      "embedded" if np_ranks == 1 else "mpirun"},
        "started": _now(),
        "finished": None,
        "files": {
            **({"deck/couette.lmp": "the LAMMPS deck run (variables in run.sh)",
                "run.sh": "the exact LAMMPS command line with every variable",
                "log.lammps": "LAMMPS log"} if lammps else {}),
            **({"prepared.data": "the prepared packing at t = 0 (LAMMPS data file; a run "
                "can start from it again)"} if lammps and start is None else {}),
            **({packings.START: "the shipped sheared packing this run started from "
                "(LAMMPS data file)"} if start is not None
               and Path(start).name == packings.START else {}),
            **({SHEARED: "the packing at the end of shear (LAMMPS data file; a run started "
                "from it shears it further, tangential springs unloaded)"} if lammps else {}),
            **({ATOMS.format(ext=dump_ext(s)): "per-atom dump (docs/outputs.md)"}
               if s.dumps else {}),
            **({CONTACTS.format(ext=dump_ext(s)): "per-contact dump (docs/outputs.md)"}
               if s.contacts and s.dumps else {}),
            **({"restart/restart.<step>.bin": "LAMMPS restart files, to resume the run"}
               if lammps else {}),
        },
    }


def _keep_old_log(out):
    """Move ``log.lammps`` of the interrupted part aside (``log.1.lammps``, ...)."""
    log_path = out / "log.lammps"
    if log_path.exists():
        k = 1
        while (out / f"log.{k}.lammps").exists():
            k += 1
        log_path.rename(out / f"log.{k}.lammps")


def _finish(out, manifest, status):
    """Record the end status; what the run added to the manifest on disk (overlaps) stays."""
    manifest.update({k: v for k, v in read_manifest(out).items() if k not in manifest})
    manifest["status"] = status
    manifest["finished"] = _now()
    write_manifest(out, manifest)


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


@contextmanager
def _signals_interrupt():
    """Turn SIGTERM into :class:`Interrupted` (SIGINT already gives KeyboardInterrupt)."""
    def handler(signum, frame):
        raise Interrupted(signal.Signals(signum).name)
    if threading.current_thread() is not threading.main_thread():   # e.g. a dask worker
        yield
        return
    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
