"""The ``granavg`` command line: its arguments, parsed; each command is one call of
:mod:`granavg.pipeline.commands`. User mistakes exit with code 2 and one line, no
traceback."""

from __future__ import annotations

import argparse
import math
import os
import sys
import textwrap

# The command's parallel work is its own (engine threads, the reader's, dask workers); BLAS
# sees only small matrices, and an OpenBLAS pool of idle threads spins a core after each
# call (~0.1 s of CPU). Set before numpy loads; a user's own setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# Each frame's arrays are allocated and freed again; numpy's advice to back large arrays
# with 2 MB pages makes each new one cost a huge page's first touch in the kernel
# (measured: docs/running-big.md, "Huge pages"). Off for the command unless set.
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")

from granavg import __version__
from granavg.errors import UserError, name_parameters, named

DESCRIPTION = ("granavg turns discrete-element (DEM) simulations of granular matter into "
               "continuum fields - density, velocity, spin, fabric, static and dynamic "
               "stress, elastic strain - with their errors, and checks that the fields obey "
               "the balance laws. It simulates the 2D Couette cell of Luding et al. (2001) "
               "in LAMMPS, averages that run or anyone's LAMMPS dumps (2D and 3D) over "
               "cells, and writes figures and a report.")

#: The options whose flag is not the library's parameter name with dashes
#: (:func:`flag`): how the command line names them in messages.
FLAGS = {"fmt": "--format", "overrides": "--set", "run_dirs":
         "the run directory", "progress": "--no-progress"}


def flag(name: str) -> str:
    """The command line's name of a library parameter: ``t_min`` -> ``--t-min``; a
    format's option as the format declares it (``contact_map`` -> ``--contact-columns``)."""
    if name in FLAGS:
        return FLAGS[name]
    from granavg.pipeline.commands import format_options

    spec = format_options().get(name)
    return spec.cli_flag if spec is not None else "--" + name.replace("_", "-")


#: Where the help names the quantities and the kernels: filled in from their registries
#: when help is shown (they are not imported for anything else the command line does).
CATALOGUE, KERNELS, WIDTHS, DEFAULT_KERNEL, TIME_KERNELS, FORMATS = (
    "<quantities>", "<kernels>", "<widths>", "<default kernel>", "<time kernels>",
    "<formats>")


class _Formatter(argparse.HelpFormatter):
    """Help wrapped between words only: an example such as a column map stays one
    token a user can copy."""

    def _split_lines(self, text, width):
        return textwrap.wrap(" ".join(text.split()), width, break_long_words=False,
                             break_on_hyphens=False)


class _Parser(argparse.ArgumentParser):
    """argparse, its refusals as one line (a :class:`UserError`) without the usage, the
    quantities' catalogue in its help."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, formatter_class=_Formatter, **kwargs)

    def error(self, message):
        raise UserError(f"{message} (see {self.prog} --help)")

    def parse_args(self, args=None, namespace=None):
        """argparse's, a species group among the arguments it does not know refused
        with how to write it (:func:`granavg.pipeline.commands.misplaced_group`)."""
        from granavg.pipeline.commands import misplaced_group

        options, unknown = self.parse_known_args(args, namespace)
        if unknown:
            misplaced_group(unknown, "an argument no option takes")
            self.error("unrecognized arguments: " + " ".join(unknown))
        return options

    def format_help(self):
        from granavg.pipeline.commands import catalogues

        for action in self._actions:
            for name, text in catalogues().items():
                if action.help and name in action.help:
                    action.help = action.help.replace(name, text)
        return super().format_help()


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="granavg", description=DESCRIPTION)
    p.add_argument("--version", action="version", version=f"granavg {__version__}")
    p.add_argument("-v", "--verbose", action="store_true", help="log more")
    sub = p.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("simulate", help="run the Couette cell in LAMMPS (SI units)")
    sim.add_argument("--preset", default="demo",
                     help="scene preset: paper (rolling resistance and base-plate friction, "
                     "50 s from a shipped sheared packing; --seeds 4 for the four), demo "
                     "(the same, 30 s), paper-rolling (no base friction, 250 s), fast "
                     "(paper-rolling with k_n 2.5, 60 s), paper-hooke (plain "
                     "gran/hooke/history, grown, 500 s); docs/scene.md, docs/sweep/ (what each setting "
                     "costs and how accurate it is)")
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
    sim.add_argument("--t-min", type=_finite, help="in-situ averages from t >= T s (default: "
                     "the scene's discarded transient: discard_rotations inner-ring rotations)")
    sim.add_argument("--block-time", type=_finite, help="in-situ standard errors: base blocks "
                     "of this length in s (default: one dump interval, at most 512)")
    sim.add_argument("--kernel", help="with --average: smooth the in-situ averages with "
                     "this kernel (" + KERNELS + "; docs/profiles.md)")
    sim.add_argument("--width", type=_finite, metavar="W", help="with --kernel: its width, m")
    sim.add_argument("--quantities", help="comma-separated quantities the run is for, of: "
                     + CATALOGUE + "; if none needs contact forces, LAMMPS computes and "
                     "writes no contact output")
    _time(sim, "with --average: ")
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
    _frames_and_cells(avg)
    avg.add_argument("--kernel", help="how particles enter the fields: " + KERNELS +
                     ". The first is the default; a smoothing kernel gives fields at the "
                     "cells' centres, with their gradients (gradv, D, W, divsigma, "
                     "divdsigma); docs/profiles.md")
    avg.add_argument("--width", type=_finite, metavar="W", help="the smoothing kernel's "
                     "width, in the data's length unit (m for runs): " + WIDTHS)
    _branch_and_errors(avg)
    _time(avg)
    avg.add_argument("--species", nargs="+", metavar="SPEC", help="a mixture's partial "
                     "fields per species beside the whole's (the table's species column, "
                     "'all' the whole): by atom type (type), by size (radius; "
                     "radius:E1,E2,... size classes between these radii) or named groups "
                     "of types, one NAME=TYPES each (--species small=1,2 large=3; run "
                     "directories go before it); with the force density between species "
                     "(f_inter), the concentration c and the segregation flux seg "
                     "(docs/species.md)")
    avg.add_argument("--spec", metavar="FILE", help="average as the sidecar FILE (an "
                     "<out>.json 'granavg average' wrote) says, with no other option of the "
                     "frames, cells or time: the same fields, bit for bit, into --out")
    avg.add_argument("--out", required=True, help="profiles table (.csv; .parquet with "
                     "--parquet); a JSON sidecar <out>.json is written beside it")
    avg.add_argument("--parquet", action="store_true", help="write Parquet instead of CSV")
    avg.add_argument("--netcdf", action="store_true", help="also write <out>.nc: the "
                     "profiles as a NetCDF (xarray) dataset on the cells' grid, with units "
                     "and errors")
    avg.add_argument("--vtk", action="store_true", help="also write <out>.vtu for ParaView "
                     "(grids, boxes and cylindrical shells; fields in time: <out>.pvd, one "
                     "animation, and its folder <out>.vtu.d)")
    avg.add_argument("--workers", type=int, help="average on a local dask cluster of this "
                     "many processes (frames split in chunks; same result as serial): run "
                     "directories, LAMMPS dump.* series and uncompressed dumps; where one "
                     "process is as fast (big frames, a gzip stream, little work: "
                     "docs/running-big.md) it says so and averages in this process")
    avg.add_argument("--scheduler", metavar="ADDRESS", help="average on this running dask "
                     "scheduler's workers (tcp://host:8786; reused, not closed); they must "
                     "see the run directory or the dumps")
    avg.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    _threads(avg)

    scl = sub.add_parser("scales", help="a scale study: the same frames averaged with a "
                         "smoothing kernel at several widths, the fields and their errors "
                         "against the width, and where each stops depending on it")
    _frames_and_cells(scl)
    scl.add_argument("--kernel", help="the smoothing kernel (default " + DEFAULT_KERNEL +
                     "), of: " + KERNELS)
    scl.add_argument("--widths", type=_finite, nargs="+", metavar="F",
                     default=[0.25, 0.5, 1.0, 2.0, 4.0], help="the kernel's widths in mean "
                     "particle diameters (default 0.25 0.5 1 2 4)")
    scl.add_argument("--diameter", type=_finite, metavar="D", help="the mean diameter, in "
                     "the dumps' length unit (default: the run's scene, or the mean over "
                     "the first frame's particles)")
    scl.add_argument("--fields", help="comma-separated columns of the profiles to draw "
                     "(default: the density and up to three of velocity, spin and stress)")
    _branch_and_errors(scl)
    scl.add_argument("--out", required=True, help="the study's table (.csv), one row per "
                     "width and cell, the exact weights' profile first; <out>.json says "
                     "where each field stops depending on the width; <out>.png and .pdf "
                     "the figure")
    scl.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    _threads(scl)


    ana = sub.add_parser("analyze", help="figures 2-9, summary.json and report.html from "
                         "two ring profiles of one run; for profiles of any other cells "
                         "(slabs, grids, plain dumps) the fields and the balance of forces and "
                         "of the spins")
    ana.add_argument("profiles", nargs="+", help="profiles of 'granavg average' (two ring "
                     "profiles of a run, e.g. 20 and 60 rings, for the paper's analysis; a "
                     "third averaged with --species type adds the mixture's segregation)")
    ana.add_argument("--closed", action="store_true", help="the cells' outer faces are "
                     "walls or empty space: edge cells' balance judged too (runs' rings are)")
    ana.add_argument("--torque-arm", choices=["contact", "surface"], default="contact",
                     help="where the contact law's lever arm for the torque ends, for the "
                     "balance of the spins: the contact point (pair granular, the "
                     "default) or the particle's surface (pair gran/hooke, "
                     "gran/hooke/history, gran/hertz/history)")
    ana.add_argument("--out", required=True, help="directory for the report (must be new)")
    ana.add_argument("--no-figures", action="store_true", help="the numbers, claims, "
                     "summary.json and report.html without figures (drawing them takes "
                     "most of the time)")
    ana.add_argument("--density-series", nargs="+", metavar="PROFILES", default=[],
                     help="coarse profiles of the same scene at other area fractions: "
                     "Fig. 5's master curve is judged on their collapse")

    rhe = sub.add_parser("rheology", help="the local rheology of field tables, per cell: "
                         "pressure, shear stress and rate, inertial number I, friction mu, "
                         "packing fraction, normal-stress differences, the stress's angle "
                         "to the strain rate, fluidity, each with its error; and the fits "
                         "mu(I) and phi(I) over all the tables' cells (docs/rheology.md)")
    rhe.add_argument("fields", nargs="+", help="tables of 'granavg average' (with their "
                     ".json sidecars and replicates): the cells of one run, or of several "
                     "runs or scenes, fitted together")
    rhe.add_argument("--diameter", type=_finite, metavar="D", help="the particles' mean "
                     "diameter for I, in the fields' length unit (default: the run's scene)")
    rhe.add_argument("--density", type=_finite, metavar="RHO_P", help="the particles' "
                     "material density for I, in the fields' units (default: the run's "
                     "scene, or the density the fields were averaged with)")
    rhe.add_argument("--out", required=True, help="directory to create (must be new): a "
                     "table per input, fits.json, fits.png and .pdf. Each table's columns, "
                     "each with <name>_sem, its error, and the flags (units in the fields' "
                     "unit system; SI shown): <rheology columns>")
    rhe.add_argument("--no-figures", action="store_true", help="the tables and fits.json "
                     "without the figure")

    demo = sub.add_parser("demo", help="simulate the demo scene, average over 20 and 60 "
                          "rings, analyse and write the report")
    demo.add_argument("--out", required=True, help="directory to create (must be new)")
    demo.add_argument("--omp", type=int, default=1, help="OpenMP threads (default 1: the "
                      "demo's law, pair granular, has no OpenMP version)")
    demo.add_argument("--t-min", type=_finite, default=None,
                      help="average frames with t >= T s (default: the scene's discarded "
                      "start, 6.3 s)")
    return p


def _frames_and_cells(avg):
    """The options that choose the frames and the cells (average, scales)."""
    avg.add_argument("run_dir", nargs="*", help="run directory of 'granavg simulate' "
                     "(manifest + dumps); several: independent realisations of one scene, "
                     "combined into ensemble profiles with between-run errors; none: plain "
                     "LAMMPS dumps given by --atoms (and --contacts)")
    avg.add_argument("--atoms", help="per-atom dump (dump custom): instead of the run's, or "
                     "any LAMMPS dump without a run directory")
    avg.add_argument("--contacts", help="per-contact dump: granavg's, the deck's raw one, "
                     "or a dump local of compute pair/local + property/local")
    plain = avg.add_argument_group("anyone's files: LAMMPS dumps and the formats of "
                                   "--format (no run directory; every number in the "
                                   "files' own units)")
    from granavg.pipeline.commands import cell_options, format_options   # the registries

    plain.add_argument("--format", help="input format of --atoms/--contacts (" + FORMATS +
                       "; default: the one the file looks like)")
    plain.add_argument("--density", type=_finite, metavar="RHO", help="material density "
                       "(masses rho pi h a^2 for disks, rho 4/3 pi a^3 for spheres); or the "
                       "dump's mass column")
    plain.add_argument("--gravity", type=_finite, nargs="+", metavar="G",
                       help="gravitational acceleration GX GY (3D: GX GY GZ): a body force "
                       "m g on every particle")
    for spec in [*format_options().values(), *cell_options()]:
        (avg if spec.runs else plain).add_argument(
            spec.cli_flag, dest=spec.name, type={"float": _finite, "int": int, "str": str,
                                                 "map": str}[spec.kind],
            nargs=spec.nargs, metavar=spec.metavar, choices=spec.choices,
            help=named(spec.help))
    avg.add_argument("--t-min", type=_finite, help="average frames with t >= T s (default: "
                     "the scene's discarded transient, discard_rotations rotations)")
    avg.add_argument("--block-time", type=_finite, help="base time blocks of the errors' "
                     "blocking analysis, s (default: one dump interval, at most 512 blocks)")
    avg.add_argument("--quantities", help="comma-separated subset of: " + CATALOGUE +
                     " (default: all the data allow)")


def _branch_and_errors(avg):
    """Branch vectors and the errors' sectors (average, scales)."""
    avg.add_argument("--branch", choices=["contact", "paper"], default="contact", help=(
        "branch vectors of Eqs. 5, 7 to the contact point (default: the stress carries the "
        "contact forces exactly) or, as printed, to the surface (too large by ~overlap/d)"))
    avg.add_argument("--sectors", type=_sectors, default="auto", help=(
        "spatial replicas for the errors: each ring (slab) split into K sectors along phi "
        "(its length) to count the packing's frozen structure; auto (default: K from the "
        "sectors' correlation), a number from 4 to 48, or off (errors from time alone)"))


def _time(p, prefix=""):
    """The fields in time (average; simulate --average): --t-max, windows, time kernels."""
    t = p.add_argument_group("fields in time (docs/time.md)")
    t.add_argument("--t-max", type=_finite, help=prefix + "average frames with t <= T "
                   "(with --t-min: exactly the frames in [t_min, t_max])")
    t.add_argument("--windows", type=_finite, metavar="DT", help=prefix + "a field per "
                   "window of DT from t_min (one pass; the table gains t, t_lo, t_hi)")
    t.add_argument("--window-frames", type=int, metavar="N", help=prefix + "a field per "
                   "N frames")
    t.add_argument("--time-kernel", help=prefix + "fields smoothed in time, at --times: "
                   + TIME_KERNELS + "; with their time derivatives (drho_dt, "
                   "dmomentum_dt) and, with a smoothing --kernel, the residuals of the "
                   "continuity and momentum balance (continuity, momentum_balance)")
    t.add_argument("--time-width", type=_finite, metavar="WT", help="the time kernel's "
                   "width (at least the frames' interval)")
    t.add_argument("--times", type=_finite, nargs=3, metavar=("START", "STOP", "STEP"),
                   help="the times of the smoothed fields")
    t.add_argument("--time-accuracy", type=_finite, metavar="FRACTION",
                   help="the median residual of the momentum balance in time (of rho g at "
                   "bulk nodes) that the dump-interval forecast aims for (default 0.01): "
                   "average says after it runs what interval gives it, simulate before "
                   "it runs")


def _threads(p):
    """--threads (average, scales)."""
    p.add_argument("--threads", metavar="N", help="cores to use: the files of a series (or "
                   "the pieces of one plain dump) read on N threads and the chunks of a "
                   "frame's particles summed on N (default: the cores available, or "
                   "GRANAVG_THREADS; 1: one core; the same result for any N)")


def _finite(text):
    """A float option: a finite number (nan and inf are refused where a length, a time
    or an acceleration is meant)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite number")
    return value


def _sectors(text):
    """--sectors: 'auto', 'off' or a number of sectors (checked by the engine)."""
    if text in ("auto", "off"):
        return None if text == "off" else text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give auto, off or a number") from None


def argv_command(argv) -> str | None:
    """The command word of the arguments (``sys.argv`` without one)."""
    words = list(sys.argv[1:] if argv is None else argv)
    return next((w for w in words if w in ("simulate", "average", "scales", "analyze",
                                           "rheology", "demo")), None)


def main(argv=None) -> int:
    """Entry point of the ``granavg`` command."""
    from granavg.pipeline.commands import run

    name_parameters(flag)
    return run(lambda: _parser().parse_args(argv), argv_command(argv))


if __name__ == "__main__":
    sys.exit(main())
