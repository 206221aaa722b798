"""The commands of the command line as functions of its parsed options (argparse's
names): each checks what belongs together and calls the pipeline once; :func:`run`
runs one of them as a process (logging, the engine's threads, one-line refusals with
exit code 2, Ctrl-C and SIGTERM)."""

from __future__ import annotations

import logging
import os
import re
from dataclasses import replace

from granavg.errors import UserError, literal, message, named

log = logging.getLogger("granavg")

#: Options of the frames that only anyone's files take (a run directory's manifest says
#: them), beside the formats' own (:func:`granavg.io.formats.options`); and every cells
#: option that does not declare it builds a run's cells too.
PLAIN_ONLY = ("density", "format", "gravity")


def format_options() -> dict:
    """The formats' options (:func:`granavg.io.formats.options`), by name."""
    from granavg.io import formats

    return formats.options()


def cell_options() -> list:
    """The options that build cells, as their registry declares them
    (:func:`granavg.engine.cells.option_specs`)."""
    from granavg.engine.cells import option_specs

    return list(option_specs().values())


def catalogues() -> dict:
    """The registries in words, for the command line's help: its placeholders
    ``<quantities>``, ``<kernels>``, ``<widths>``, ``<default kernel>``, ``<time
    kernels>``, ``<formats>`` and ``<rheology columns>``."""
    from granavg.analysis import rheology
    from granavg.engine import smoothing, timing
    from granavg.engine.quantities import catalogue
    from granavg.io import formats

    return {"<quantities>": catalogue(), "<kernels>": smoothing.catalogue(),
            "<widths>": smoothing.widths(), "<default kernel>": smoothing.DEFAULT,
            "<time kernels>": timing.catalogue(), "<formats>": formats.catalogue(),
            "<rheology columns>": rheology.catalogue()}


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


def time_accuracy(o):
    """``--time-accuracy``: a fraction (0 < it < 1), or None where not given."""
    from granavg.errors import ParameterError

    value = o.get("time_accuracy")
    if value is not None and not 0.0 < value < 1.0:
        raise ParameterError("time_accuracy", f"{{param}} {value:g}: give a fraction between "
                             "0 and 1 (0.01: a median residual of 1% of rho g)")
    return value


def simulate(o) -> str:
    from granavg.pipeline.simulation import simulate_command

    from granavg.pipeline.spec import Spec

    spec = Spec.of(t_min=o["t_min"], block_time=o["block_time"],
                   quantities=names(o["quantities"]), kernel=o["kernel"], width=o["width"],
                   workers=o["workers"] if o["seeds"] is not None else None,
                   scheduler=o["scheduler"], **time_options(o))
    return simulate_command(
        spec, preset=o["preset"], overrides=o["overrides"], out=o["out"], np=o["np"],
        omp=o["omp"], resume=o["resume"], start=o["start"], engine=o["engine"],
        average=o["average"], seeds=o["seeds"], progress=_progress(o),
        time_accuracy=time_accuracy(o))


def averaging(o, **extra) -> dict:
    """The options of the frames, cells and errors (average, scales) for the pipeline,
    with ``extra``; plain dumps' options refused beside a run directory."""
    from granavg.errors import ParameterError

    specs, of_formats = cell_options(), format_options()
    plain = [*PLAIN_ONLY, *of_formats, *(s.name for s in specs if not s.runs)]
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
    return dict(common, cells=cells, fmt=o["format"], density=o["density"],
                gravity=o["gravity"], **{k: spec.parse(o[k]) for k, spec in
                                         of_formats.items()})


#: A word of the command line that names a group of atom types, NAME=TYPES.
_GROUP = re.compile(r"[A-Za-z_][\w.+-]*=[^=/\\]*")


def species_group(word: str) -> bool:
    """Whether a word of the command line looks like a species group (``large=2,3``)
    rather than a path.

    Parameters
    ----------
    word : str
        The word as given.

    Returns
    -------
    bool
        True for NAME=TYPES where no such file or directory exists.
    """
    return bool(_GROUP.fullmatch(word)) and not os.path.exists(word)


def misplaced_group(words, read_as: str) -> None:
    """Refuse in one line a species group (:func:`species_group`) among ``words``, which
    the command line took for something else.

    Parameters
    ----------
    words : iterable of str
        The words to look at (run directories, unrecognised arguments).
    read_as : str
        How the command line read them, for the message: "a run directory".

    Raises
    ------
    UserError
        Where one of ``words`` looks like a species group.
    """
    group = next((w for w in words if species_group(w)), None)
    if group is not None:
        raise UserError(named(f"{literal(repr(group))} looks like a species group but was "
                              f"read as {read_as}; give all the groups together right "
                              "after {species}, e.g. granavg average RUN {species} small=1 "
                              "large=2,3 {out} p.csv"))


def species(o):
    """The words of ``--species`` as one split, the text
    :meth:`granavg.engine.species.Species.parse` reads (None: not given); a word among
    groups that is no group is refused.

    Parameters
    ----------
    o : dict
        The parsed options.

    Returns
    -------
    str or None
        ``type``, ``radius``, ``radius:E1,E2,...`` or the groups, space-separated.
    """
    from granavg.errors import ParameterError

    words = o.get("species")
    if not words:
        return None
    stray = [w for w in words if "=" not in w] if len(words) > 1 else []
    if stray:
        raise ParameterError("species", f"{{param}} {literal(' '.join(words))!r}: "
                             f"{literal(stray[0])!r} is no group NAME=TYPES; give type, "
                             "radius or radius:E1,E2,... alone, or groups only (small=1 "
                             "large=2,3), and the run directories before {param}")
    return " ".join(words)


#: The command line's options of an average that are no flags of its spec (the
#: outputs, the execution, the logging); every other option given beside ``--spec`` is
#: refused.
NOT_OF_THE_SPEC = ("command", "verbose", "threads", "spec", "out", "parquet", "netcdf",
                   "vtk", "workers", "scheduler", "no_progress", "time_accuracy")
#: Options whose parser default is a value, not None (``--sectors off`` is None).
DEFAULTS = {"branch": "contact", "sectors": "auto"}


def _given(key, value) -> bool:
    """Whether the command line gave an option (its value not the parser's default)."""
    if key in DEFAULTS:
        return value != DEFAULTS[key]
    return value is not None and value is not False and not (
        isinstance(value, (list, tuple)) and not value)


def average_spec(o):
    """The spec of the ``average`` command's options (:class:`granavg.pipeline.spec.Spec`):
    the sidecar's of ``--spec``, else the one the flags say."""
    from granavg.errors import ParameterError
    from granavg.pipeline.spec import Execution, Spec

    execution = Execution(o["workers"], o["scheduler"], _progress(o))
    if o.get("spec"):
        given = [k for k, v in o.items() if k not in NOT_OF_THE_SPEC and _given(k, v)]
        if given:
            param = "run_dirs" if given[0] == "run_dir" else given[0]
            raise ParameterError(param, "{param} beside {spec}: the spec says how to "
                                 "average; leave out {param}, or {spec}")
        spec = Spec.load(o["spec"])
        return replace(spec, execution=execution)
    misplaced_group(o["run_dir"], "a run directory")
    return Spec.of(o["run_dir"] or None, atoms=o["atoms"], contacts=o["contacts"],
                   workers=execution.workers, scheduler=execution.scheduler,
                   progress=execution.progress, species=species(o),
                   **averaging(o, width=o["width"]), **time_options(o))


def average(o):
    from granavg.pipeline.averaging import average_to_file

    accuracy = time_accuracy(o)
    return average_to_file(average_spec(o), o["out"], parquet=o["parquet"],
                           netcdf=o["netcdf"], vtk=o["vtk"], time_accuracy=accuracy)


def scales(o):
    from granavg.pipeline.scales import scale_study_to_file

    from granavg.pipeline.spec import Spec

    spec = Spec.of(o["run_dir"] or None, atoms=o["atoms"], contacts=o["contacts"],
                   progress=_progress(o), **averaging(o))
    return scale_study_to_file(spec, o["out"], widths=o["widths"], diameter=o["diameter"],
                               fields=names(o["fields"]))


def analyze(o):
    from granavg.pipeline.reporting import analyze_command

    return analyze_command(o["profiles"], o["out"], o["density_series"], o["closed"],
                           o["torque_arm"], figures=not o["no_figures"])


def rheology(o):
    from granavg.pipeline.rheology import rheology_command

    return rheology_command(o["fields"], o["out"], diameter=o["diameter"],
                            density=o["density"], figures=not o["no_figures"])


def demo(o):
    from granavg.pipeline.reporting import demo_command

    from granavg.pipeline.spec import Spec

    return demo_command(o["out"], omp=o["omp"], spec=Spec.of(t_min=o["t_min"], progress=None))


COMMANDS = {"simulate": simulate, "average": average, "scales": scales,
            "analyze": analyze, "rheology": rheology, "demo": demo}


def run(parse, word) -> int:
    """Run the command ``parse()`` returns the options of (argparse's namespace) as a
    process: its exit code. ``word``: the command's name in the arguments, for the
    words said after a signal (a run is kept and can be resumed). Every line it writes
    to stderr is a log line (:func:`granavg.pipeline.session.log_to_stderr`)."""
    from granavg.pipeline.session import (configure_logging, interrupt_code, log_to_stderr,
                                          no_room, signals_as_interrupts, use_threads)

    with signals_as_interrupts():
        try:
            log_to_stderr()
            options = vars(parse())
            configure_logging(options["verbose"])
            use_threads(options.get("threads"))
            done = COMMANDS[options["command"]](options)
            if options["command"] == "simulate":
                log.info("run complete: %s", done)
            return 0
        except UserError as exc:
            log.error("error: %s", message(exc))
            return exc.exit_code
        except (KeyboardInterrupt, Exception) as raised:
            code = interrupt_code(raised)
            if code is None and (full := no_room(raised)):
                log.error("error: %s", full)
                return 2
            if code is None:
                raise
            log.warning("interrupted; %s", _after_signal(word))
            return code


def _after_signal(word) -> str:
    """What a signal left: the run kept (simulate, demo), or the outputs complete
    before it, or nothing.

    Parameters
    ----------
    word : str or None
        The command's name in the arguments.

    Returns
    -------
    str
        The words after "interrupted; ".
    """
    from granavg.pipeline.session import outputs_written

    done = outputs_written()
    if word in ("simulate", "demo"):
        return named("stopped (the run is kept; {resume} continues it)")
    if done:
        return f"the outputs were complete before it: {done[-1]} (with its companions)"
    return "nothing written"
