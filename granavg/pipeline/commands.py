"""The commands of the command line as functions of its parsed options (argparse's
names): each checks what belongs together and calls the pipeline once; :func:`run`
runs one of them as a process (logging, the engine's threads, one-line refusals with
exit code 2, Ctrl-C and SIGTERM)."""

from __future__ import annotations

import logging
import sys

from granavg.errors import UserError, message, named

#: Options of the frames that only plain dumps take (a run directory's manifest says
#: them); and every cells option that does not declare it builds a run's cells too.
PLAIN_ONLY = ("density", "dt", "wall_types", "atom_columns", "contact_columns", "units",
              "format", "gravity", "dim", "inertia", "liggghts", "wall_contacts",
              "liggghts_walls")


def cell_options() -> list:
    """The options that build cells, as their registry declares them
    (:func:`granavg.engine.cells.option_specs`)."""
    from granavg.engine.cells import option_specs

    return list(option_specs().values())


def catalogues() -> dict:
    """The registries in words, for the command line's help: its placeholders
    ``<quantities>``, ``<kernels>``, ``<widths>``, ``<default kernel>`` and ``<time
    kernels>``."""
    from granavg.engine import smoothing, timing
    from granavg.engine.quantities import catalogue

    return {"<quantities>": catalogue(), "<kernels>": smoothing.catalogue(),
            "<widths>": smoothing.widths(), "<default kernel>": smoothing.DEFAULT,
            "<time kernels>": timing.catalogue()}


def time_options(o) -> dict:
    """The options of the fields in time (:data:`granavg.engine.timing.OPTIONS`) that
    were given."""
    from granavg.engine.timing import OPTIONS

    return {k: o[k] for k in OPTIONS if o.get(k) is not None}


def names(text):
    """'nu, v' -> ['nu', 'v']; None stays None (all quantities)."""
    return [q.strip() for q in text.split(",")] if text else None


def _progress(o):
    return False if o.get("no_progress") else None


def simulate(o) -> str:
    from granavg.pipeline.simulation import simulate_command

    return simulate_command(
        preset=o["preset"], overrides=o["overrides"], out=o["out"], np=o["np"],
        omp=o["omp"], resume=o["resume"], start=o["start"], engine=o["engine"],
        average=o["average"], t_min=o["t_min"], block_time=o["block_time"],
        quantities=names(o["quantities"]), seeds=o["seeds"], workers=o["workers"],
        scheduler=o["scheduler"], progress=_progress(o), kernel=o["kernel"],
        width=o["width"], time=time_options(o))


def averaging(o, **extra) -> dict:
    """The options of the frames, cells and errors (average, scales) for the pipeline,
    with ``extra``; plain dumps' options refused beside a run directory."""
    from granavg.io.lammps_dumps import parse_map
    from granavg.errors import ParameterError

    specs = cell_options()
    plain = [*PLAIN_ONLY, *(s.name for s in specs if not s.runs)]
    given = [k for k in plain if o.get(k) not in (None, [], ())]
    if o["run_dir"] and given:
        raise ParameterError(given[0], "{param} is for plain LAMMPS dumps; a run "
                             "directory's manifest already says it (drop the option or "
                             "the run directory)")
    common = dict(t_min=o["t_min"], block_time=o["block_time"],
                  quantities=names(o["quantities"]), branch=o["branch"],
                  sectors=o["sectors"], kernel=o["kernel"], **extra)
    cells = {s.name: o[s.name] for s in specs if o[s.name] is not None}
    if o["run_dir"]:
        return dict(common, cells=cells)
    return dict(common, cells=cells, fmt=o["format"], density=o["density"], dt=o["dt"],
                units=o["units"], wall_types=o["wall_types"], dim=o["dim"],
                gravity=o["gravity"], inertia=o["inertia"],
                atom_map=parse_map(o["atom_columns"]),
                contact_map=parse_map(o["contact_columns"]), liggghts=o["liggghts"],
                wall_contacts=o["wall_contacts"], wall_keywords=o["liggghts_walls"])


def average(o):
    from granavg.pipeline.averaging import average_to_file

    return average_to_file(o["run_dir"], o["out"], parquet=o["parquet"], netcdf=o["netcdf"],
                           vtk=o["vtk"], workers=o["workers"], scheduler=o["scheduler"],
                           atoms=o["atoms"], contacts=o["contacts"], progress=_progress(o),
                           species=o["species"], **averaging(o, width=o["width"]),
                           **time_options(o))


def scales(o):
    from granavg.pipeline.scales import scale_study_to_file

    return scale_study_to_file(o["run_dir"], o["out"], widths=o["widths"],
                               diameter=o["diameter"], fields=names(o["fields"]),
                               atoms=o["atoms"], contacts=o["contacts"],
                               progress=_progress(o), **averaging(o))


def analyze(o):
    from granavg.pipeline.reporting import analyze_command

    return analyze_command(o["profiles"], o["out"], o["density_series"], o["closed"],
                           o["torque_arm"], figures=not o["no_figures"])


def demo(o):
    from granavg.pipeline.reporting import demo_command

    return demo_command(o["out"], omp=o["omp"], t_min=o["t_min"])


COMMANDS = {"simulate": simulate, "average": average, "scales": scales,
            "analyze": analyze, "demo": demo}


def run(parse, word) -> int:
    """Run the command ``parse()`` returns the options of (argparse's namespace) as a
    process: its exit code. ``word``: the command's name in the arguments, for the
    words said after a signal (a run is kept and can be resumed)."""
    from granavg.pipeline.session import (configure_logging, interrupt_code, no_room,
                                          outputs_written, signals_as_interrupts,
                                          use_threads)

    with signals_as_interrupts():
        try:
            options = vars(parse())
            configure_logging(options["verbose"])
            use_threads(options.get("threads"))
            done = COMMANDS[options["command"]](options)
            if options["command"] == "simulate":
                logging.getLogger("granavg").info("run complete: %s", done)
            return 0
        except UserError as exc:
            print(f"granavg: error: {message(exc)}", file=sys.stderr)
            return exc.exit_code
        except (KeyboardInterrupt, Exception) as raised:
            code = interrupt_code(raised)
            if code is None and (full := no_room(raised)):
                print(f"granavg: error: {full}", file=sys.stderr)
                return 2
            if code is None:
                raise
            done = outputs_written()
            what = named("stopped (the run is kept; {resume} continues it)") if \
                word in ("simulate", "demo") else \
                f"the outputs were complete before it: {done[-1]} (with its companions)" \
                if done else "nothing written"
            print(f"granavg: interrupted; {what}", file=sys.stderr)
            return code
