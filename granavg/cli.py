"""The ``granavg`` command line. User mistakes exit with code 2 and one line, no traceback."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

from granavg import __version__
from granavg.errors import UserError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="granavg", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"granavg {__version__}")
    p.add_argument("-v", "--verbose", action="store_true", help="log more")
    sub = p.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("simulate", help="run the Couette cell in LAMMPS (SI units)")
    sim.add_argument("--preset", default="demo",
                     help="scene preset: paper (rolling resistance and base-plate friction, "
                     "50 s from a shipped sheared packing; --seeds 4 for the four), demo "
                     "(the same, 30 s), paper-rolling (no base friction, 250 s), fast "
                     "(paper-rolling with k_n 2.5, 60 s), paper-hooke (plain "
                     "gran/hooke/history, grown, 500 s); docs/scene.md, docs/sweep/")
    sim.add_argument("--out", required=True, help="run directory to create (must be new)")
    sim.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="KEY=VALUE", help="change one scene value (SI units); repeatable")
    sim.add_argument("--np", type=int, default=1,
                     help="MPI ranks (>1 runs 'mpirun -np N lmp' from the mpich wheel)")
    sim.add_argument("--omp", type=int, default=1, help="OpenMP threads per rank")
    sim.add_argument("--resume", action="store_true",
                     help="continue the interrupted run in --out from its last restart")
    sim.add_argument("--start", metavar="DATA", help="shear this prepared packing (e.g. "
                     "RUN/prepared.data of an earlier run) instead of preparing one")
    sim.add_argument("--engine", default="lammps", choices=["lammps", "reference"],
                     help="reference: granavg's built-in DEM (needs --start; for "
                     "cross-checks, not production)")
    sim.add_argument("--average", type=int, nargs="+", metavar="N",
                     help="average in situ over N rings (several counts allowed) while "
                     "LAMMPS runs: writes profiles_N.csv; with --set dumps=0 no dump files")
    sim.add_argument("--t-min", type=float, help="in-situ averages from t >= T s (default: "
                     "the scene's discarded transient: discard_rotations inner-ring rotations)")
    sim.add_argument("--block-time", type=float, help="in-situ standard errors: base blocks "
                     "of this length in s (default: one dump interval, at most 512)")
    sim.add_argument("--quantities", help="comma-separated quantities the run is for (as "
                     "for 'average'); if none needs contact forces (nu, rho, v, omega, "
                     "dsigma, dsigma_fluct), LAMMPS computes and writes no contact output")
    sim.add_argument("--seeds", type=int, metavar="K", help="run K independent "
                     "realisations (different random packings) into OUT/seed<N>/, on a "
                     "dask cluster; average them together with 'granavg average RUN RUN ...'")
    sim.add_argument("--workers", type=int, default=2, help="with --seeds: processes of "
                     "the local dask cluster, one single-threaded LAMMPS each (default 2)")
    sim.add_argument("--scheduler", metavar="ADDRESS", help="with --seeds: run the "
                     "realisations on this dask scheduler's workers")
    sim.add_argument("--no-progress", action="store_true", help="hide the progress bar")

    avg = sub.add_parser("average", help="profiles over rings, slabs or a grid (Eqs. 1-7) "
                         "of a granavg run or an ensemble (SI units), or of plain LAMMPS "
                         "dumps (in their own units)")
    avg.add_argument("run_dir", nargs="*", help="run directory of 'granavg simulate' "
                     "(manifest + dumps); several: independent realisations of one scene, "
                     "combined into ensemble profiles with between-run errors; none: plain "
                     "LAMMPS dumps given by --atoms (and --contacts)")
    avg.add_argument("--atoms", help="per-atom dump (dump custom): instead of the run's, or "
                     "any LAMMPS dump without a run directory")
    avg.add_argument("--contacts", help="per-contact dump: granavg's, the deck's raw one, "
                     "or a dump local of compute pair/local + property/local")
    rings = avg.add_mutually_exclusive_group()
    rings.add_argument("--bins", type=int, help="number of equal rings (from R_i to R_o of "
                       "a run, default 20; or over --r-range) or slabs (over --range)")
    rings.add_argument("--edges", type=float, nargs="+", metavar="R",
                       help="ring (or slab) edges in m, increasing")
    plain = avg.add_argument_group("plain LAMMPS dumps (no run directory; every number in "
                                   "the dump's own units)")
    plain.add_argument("--units", metavar="STYLE", help="LAMMPS units style of the dumps "
                       "(si, lj, real, metal, cgs, electron, micro, nano) when they have no "
                       "ITEM: UNITS header (dump_modify units yes); only labels the outputs")
    plain.add_argument("--thickness", type=float, metavar="H", help="disk height h "
                       "(2D disks of volume pi h a^2); required")
    plain.add_argument("--density", type=float, metavar="RHO", help="material density "
                       "(masses rho pi h a^2); or the dump's mass column")
    plain.add_argument("--dt", type=float, help="time step, for dumps without ITEM: TIME")
    plain.add_argument("--center", type=float, nargs=2, metavar=("X", "Y"), default=(0.0, 0.0),
                       help="centre of the rings (default 0 0)")
    plain.add_argument("--r-range", type=float, nargs=2, metavar=("R1", "R2"),
                       help="rings: --bins equal rings from R1 to R2")
    plain.add_argument("--slabs", choices=["x", "y"], help="Cartesian strips across x or y "
                       "(--bins over --range, or --edges) instead of rings")
    plain.add_argument("--range", type=float, nargs=2, metavar=("LO", "HI"),
                       help="slabs: from LO to HI (default the box)")
    plain.add_argument("--length", type=float, help="slabs: their length along the other "
                       "axis (default the box's)")
    plain.add_argument("--grid", type=int, nargs=2, metavar=("NX", "NY"),
                       help="a grid of NX x NY rectangles over --x-range, --y-range")
    plain.add_argument("--x-range", type=float, nargs=2, metavar=("X1", "X2"))
    plain.add_argument("--y-range", type=float, nargs=2, metavar=("Y1", "Y2"))
    plain.add_argument("--wall-types", type=int, nargs="+", metavar="T", default=[],
                       help="atom types that are walls: left out of the packing, their "
                       "contacts with disks kept")
    plain.add_argument("--atom-columns", metavar="MAP", help="our name=dump column, e.g. "
                       "omegaz=c_spin[3],radius=c_r (others by name or alias)")
    plain.add_argument("--contact-columns", metavar="MAP", help="e.g. id1=c_pp[1],"
                       "id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
                       "ftx=c_pl[5],fty=c_pl[6]")
    avg.add_argument("--t-min", type=float, help="average frames with t >= T s "
                     "(default: the scene's discarded transient, discard_rotations inner-ring "
                     "rotations)")
    avg.add_argument("--block-time", type=float,
                     help="length in s of the base time blocks of the blocking analysis "
                     "behind the standard errors (default: one dump interval, at most 512 "
                     "blocks)")
    avg.add_argument("--quantities", help="comma-separated subset of: nu, rho, v, omega, "
                     "coordination, F, sigma, dsigma, dsigma_fluct, eps (default: all)")
    avg.add_argument("--out", required=True, help="profiles table (.csv; .parquet with "
                     "--parquet); a JSON sidecar <out>.json is written beside it")
    avg.add_argument("--parquet", action="store_true", help="write Parquet instead of CSV")
    avg.add_argument("--workers", type=int, help="average on a local dask cluster of this "
                     "many processes (frames split in chunks; same result as serial)")
    avg.add_argument("--scheduler", metavar="ADDRESS", help="average on this dask "
                     "scheduler's workers (tcp://host:8786); they must see the run directory")
    avg.add_argument("--no-progress", action="store_true", help="hide the progress bar")

    ana = sub.add_parser("analyze", help="figures 2-9, summary.json and report.html from "
                         "two ring profiles of one run")
    ana.add_argument("profiles", nargs=2, help="two profiles of 'granavg average' (e.g. 20 "
                     "and 60 rings)")
    ana.add_argument("--out", required=True, help="directory for the report (must be new)")
    ana.add_argument("--density-series", nargs="+", metavar="PROFILES", default=[],
                     help="coarse profiles of the same scene at other area fractions: "
                     "Fig. 5's master curve is judged on their collapse")

    demo = sub.add_parser("demo", help="simulate the demo scene, average over 20 and 60 "
                          "rings, analyse and write the report")
    demo.add_argument("--out", required=True, help="directory to create (must be new)")
    demo.add_argument("--omp", type=int, default=2, help="OpenMP threads (default 2)")
    demo.add_argument("--t-min", type=float, default=None,
                      help="average frames with t >= T s (default: the scene's discarded "
                      "start, 6.3 s)")
    return p


def _simulate(args) -> int:
    from granavg.sim.scene import preset
    from granavg.sim.simulate import resume, simulate

    if args.np < 1 or args.omp < 1:
        raise UserError("--np and --omp must be >= 1")
    progress = False if args.no_progress else None
    if args.resume:
        if (args.overrides or args.start or args.engine != "lammps" or args.average
                or args.quantities):
            raise UserError("--resume continues the run as it was set up; drop --set, "
                            "--start, --engine, --average and --quantities")
        out = resume(args.out, np_ranks=args.np, omp_threads=args.omp, progress=progress)
    elif args.seeds is not None:
        from granavg.sim.ensemble import simulate_ensemble
        if args.np != 1 or args.omp != 1 or args.start or args.engine != "lammps" or args.average:
            raise UserError("--seeds runs each realisation as one single-threaded LAMMPS "
                            "task; drop --np, --omp, --start, --engine and --average")
        scene = preset(args.preset).with_overrides(args.overrides)
        runs = simulate_ensemble(scene, args.out, args.seeds, workers=args.workers,
                                 scheduler=args.scheduler, preset=args.preset,
                                 quantities=_names(args.quantities))
        out = ", ".join(str(r) for r in runs)
    else:
        scene = preset(args.preset).with_overrides(args.overrides)
        out = simulate(scene, args.out, np_ranks=args.np, omp_threads=args.omp,
                       progress=progress, preset=args.preset, start=args.start,
                       engine=args.engine, average=args.average, t_min=args.t_min,
                       block_time=args.block_time, quantities=_names(args.quantities))
    logging.getLogger("granavg").info("run complete: %s", out)
    return 0


def _names(text):
    """'nu, v' -> ['nu', 'v']; None stays None (all quantities)."""
    return [q.strip() for q in text.split(",")] if text else None


def _average(args) -> int:

    from granavg.io import validate
    from granavg.analysis.claims import warn_if_inertial
    from granavg.io.profiles_io import REPLICATES, TIMESERIES, write_profiles
    from granavg.io.runs import average_run
    from granavg.io.runs import average_runs

    out = validate.free_output(Path(args.out), ("", ".json", REPLICATES, TIMESERIES))
    if not args.run_dir:
        return _average_plain(args, out)
    plain_only = [o for o, v in (("--thickness", args.thickness), ("--density", args.density),
                                 ("--dt", args.dt), ("--r-range", args.r_range),
                                 ("--units", args.units),
                                 ("--slabs", args.slabs), ("--grid", args.grid),
                                 ("--wall-types", args.wall_types),
                                 ("--atom-columns", args.atom_columns),
                                 ("--contact-columns", args.contact_columns)) if v]
    if plain_only:
        raise UserError(f"{plain_only[0]} is for plain LAMMPS dumps; a run directory's "
                        "manifest already says it (drop the option or the run directory)")
    validate.positive("--block-time", args.block_time)
    validate.finite("--t-min", args.t_min)
    validate.ring_options(args.bins, args.edges)
    for run in args.run_dir:
        validate.run_directory(run)
    validate.existing_file("--atoms", args.atoms)
    if args.contacts and Path(args.contacts).is_dir():       # read only if needed
        validate.existing_file("--contacts", args.contacts)
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers}: must be >= 1 (leave it out to average "
                        "in this process)")
    options = dict(bins=args.bins, edges=args.edges, t_min=args.t_min,
                   block_time=args.block_time, quantities=_names(args.quantities),
                   atoms=args.atoms, contacts=args.contacts)
    if len(args.run_dir) > 1 and (args.atoms or args.contacts):
        raise UserError("--atoms and --contacts name the dumps of one run; give one run "
                        "directory with them")
    if args.workers is not None or args.scheduler:
        from granavg.io.parallel import average_run_dask
        profiles = average_runs(args.run_dir, average_run_dask, workers=args.workers or 2,
                                scheduler=args.scheduler, **options)
    else:
        profiles = average_runs(args.run_dir, average_run,
                                progress=False if args.no_progress else None, **options)
    write_profiles(profiles, out, parquet=args.parquet)
    warn_if_inertial(profiles)
    logging.getLogger("granavg").info("%d rings x %d frames -> %s (+ %s.json)",
                                      profiles.rings.n, profiles.n_frames, out, out.name)
    return 0


def _average_plain(args, out) -> int:
    """``granavg average --atoms F [--contacts F] ...`` on anyone's LAMMPS dumps."""
    import numpy as np

    from granavg.engine import Grid, Rings, Slabs, average
    from granavg.io import validate
    from granavg.io.lammps_dumps import LammpsDumps, parse_map
    from granavg.io.profiles_io import write_profiles
    from granavg.io.reader import DumpReader

    if not args.atoms:
        raise UserError("give a run directory, or a LAMMPS dump with --atoms (and --contacts)")
    atoms = validate.existing_file("--atoms", args.atoms)
    contacts = validate.existing_file("--contacts", args.contacts)
    if args.thickness is None:
        raise UserError("--thickness H: give the disks' height, in the dump's length unit "
                        "(2D disks have volume pi h a^2)")
    validate.positive("--thickness", args.thickness)
    validate.positive("--density", args.density)
    validate.positive("--dt", args.dt)
    validate.positive("--block-time", args.block_time)
    validate.finite("--t-min", args.t_min)
    validate.ring_options(args.bins, args.edges)
    if args.workers is not None or args.scheduler:
        raise UserError("--workers and --scheduler average run directories; plain dumps are "
                        "averaged in this process")
    h = args.thickness
    if args.grid:
        box = _first_box(DumpReader(atoms))
        xr = args.x_range or box[0]
        yr = args.y_range or box[1]
        if min(args.grid) < 1 or args.grid[0] * args.grid[1] > validate.MAX_BINS:
            raise UserError(f"--grid {args.grid[0]} {args.grid[1]}: give between 1 and "
                            f"{validate.MAX_BINS} cells")
        geometry = Grid(np.linspace(*xr, args.grid[0] + 1), np.linspace(*yr, args.grid[1] + 1), h)
    elif args.slabs:
        box = _first_box(DumpReader(atoms))
        k = "xy".index(args.slabs)
        lo_hi = args.range or box[k]
        edges = args.edges or np.linspace(*lo_hi, (args.bins or 20) + 1)
        length = args.length or (box[1 - k][1] - box[1 - k][0])
        geometry = Slabs(np.asarray(edges, float), h, args.slabs, length)
    else:
        if args.edges is None and args.r_range is None:
            raise UserError("rings need --r-range R1 R2 (with --bins) or --edges; or choose "
                            "--slabs or --grid")
        edges = args.edges or np.linspace(*args.r_range, (args.bins or 20) + 1)
        geometry = Rings(np.asarray(edges, float), h, tuple(args.center))
    frames = LammpsDumps(atoms, contacts, atom_map=parse_map(args.atom_columns),
                         contact_map=parse_map(args.contact_columns),
                         wall_types=args.wall_types, dt=args.dt, units=args.units)
    if frames.units.style == "unstated":
        logging.getLogger("granavg").info("%s does not say its units (no ITEM: UNITS): the "
                                          "outputs are labelled 'unstated'; --units STYLE "
                                          "names them", atoms)
    profiles = average(frames, geometry, rho_p=args.density,
                       quantities=_names(args.quantities), t_min=args.t_min or 0.0,
                       block_time=args.block_time,
                       progress=False if args.no_progress else None, units=frames.units)
    profiles.meta.update({"files": {"atoms": str(atoms), "contacts": str(contacts) if contacts
                                    else None},
                          "inputs": {"thickness": h, "density": args.density,
                                     "wall_types": args.wall_types, "dt": args.dt,
                                     "atom_columns": frames.amap, "contact_columns": frames.cmap}})
    if any(frames.dropped.values()):
        profiles.meta["dropped"] = dict(frames.dropped)
    write_profiles(profiles, out, parquet=args.parquet)
    logging.getLogger("granavg").info("%d %s x %d frames -> %s (+ %s.json)", geometry.n,
                                      geometry.kind, profiles.n_frames, out, out.name)
    return 0


def _first_box(reader):
    """The box bounds (x, y) of a dump's first frame, m."""
    for frame in reader:
        return frame.box[0], frame.box[1]
    raise UserError(f"{reader.path}: holds no frame")


#: Profile columns the analysis needs.
ANALYSED = ("nu", "rho", "v_phi", "omega", "F_rr", "sigma_rr", "dsigma_rr", "eps_rr")


def _analyze(args) -> int:

    from granavg.io.profiles_io import read_profiles
    from granavg.analysis.pipeline import report_profiles

    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"--out {out}: exists and is not an empty directory; choose a new "
                        "--out (reports are never overwritten)")
    inputs = [read_profiles(p) for p in args.profiles]
    series = [read_profiles(p) for p in args.density_series]
    for p, name in zip([*inputs, *series], [*args.profiles, *args.density_series]):
        if not (p.meta or {}).get("run_manifest"):
            raise UserError(f"{name}.json: carries no run manifest; make the profiles with "
                            "'granavg average'")
        missing = [q for q in ANALYSED if q not in p.values]
        if missing:
            raise UserError(f"{name}: the profiles lack {missing[0]}; average with all "
                            "quantities (the contact dump is needed)")
    with staged_directory(out) as tmp:
        report_profiles(*inputs, tmp, density_series=series)
    logging.getLogger("granavg").info("report: %s", out / "report.html")
    return 0


@contextmanager
def staged_directory(out):
    """A temporary directory beside ``out``, renamed to ``out`` only when the block
    completes; removed otherwise (a refused or interrupted report leaves nothing)."""
    import shutil
    import tempfile

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        if out.exists():
            out.rmdir()                  # empty (checked before)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _demo(args) -> int:

    from granavg.analysis.pipeline import report_run
    from granavg.sim.scene import preset
    from granavg.sim.simulate import simulate

    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        raise UserError(f"{out} is not empty; choose a new --out")
    run = simulate(preset("demo"), out / "run", omp_threads=args.omp, preset="demo")
    report_run(run, out, t_min=args.t_min, title="granavg demo (the paper preset's scene: rolling resistance and "
                                        "base-plate friction, 30 s of shear, one realisation)")
    logging.getLogger("granavg").info("demo complete: open %s", out / "report.html")
    return 0


class Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an exception like Ctrl-C's."""


_signalled: list[int] = []          # the signals received during this ``main()``


def _on_signal(signum, frame):
    _signalled.append(signum)
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _interrupt_code(raised: BaseException) -> int | None:
    """Exit code when ``raised`` is (the aftermath of) Ctrl-C or SIGTERM, else None.

    A signal can land inside a compiled (numba) call or a ctypes callback; there the
    interrupt is swallowed or turned into another error (``SystemError``, numba's
    ``RuntimeError``), so any error raised after a signal arrived counts as the signal's.
    """
    if isinstance(raised, Terminated) or signal.SIGTERM in _signalled:
        return 143
    if isinstance(raised, KeyboardInterrupt) or _signalled:
        return 130
    return None


def _unraisable(previous):
    """``sys.unraisablehook`` that keeps an interrupt inside a callback quiet (main reports it)."""
    def hook(unraisable):
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            previous(unraisable)
    return hook


def main(argv=None) -> int:
    """Entry point of the ``granavg`` command."""
    args = _parser().parse_args(argv)
    _signalled.clear()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, _on_signal)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:   # not if ignored
            previous[signal.SIGINT] = signal.signal(signal.SIGINT, _on_signal)
    unraisable, sys.unraisablehook = sys.unraisablehook, _unraisable(sys.unraisablehook)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="granavg: %(message)s")
    quiet = "debug" if args.verbose else "warning"
    for noisy in ("distributed", "tornado", "bokeh"):     # dask's own chatter
        logging.getLogger(noisy).setLevel(quiet.upper())
    import dask                      # distributed resets its loggers from this on import
    dask.config.set({"logging.distributed": quiet})
    try:
        return {"simulate": _simulate, "average": _average, "analyze": _analyze,
                "demo": _demo}[args.command](args)
    except UserError as exc:
        print(f"granavg: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except (KeyboardInterrupt, Exception) as raised:
        code = _interrupt_code(raised)
        if code is None:
            raise
        what = "stopped (the run is kept; --resume continues it)" if \
            args.command in ("simulate", "demo") else "nothing written"
        print(f"granavg: interrupted; {what}", file=sys.stderr)
        return code
    finally:
        sys.unraisablehook = unraisable
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":
    sys.exit(main())
