"""Simulations as the ``simulate`` and ``demo`` commands run them: LAMMPS (or the
reference DEM) through :mod:`granavg.sim`, with the in-situ averages of
:mod:`granavg.pipeline.insitu` when asked for, ensembles of realisations on dask."""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

from granavg.errors import ParameterError
from granavg.extras import require
from granavg.engine.timing import OPTIONS
from granavg.pipeline.insitu import InSituAverage
from granavg.pipeline.spec import Execution, Spec

log = logging.getLogger(__name__)


def simulate_run(scene, out, *, average=None, spec: Spec | None = None, **options) -> Path:
    """:func:`granavg.sim.simulate.simulate`, averaging in situ over the ring counts
    ``average`` (if given) with :class:`~granavg.pipeline.insitu.InSituAverage`, as the
    ``spec`` says (:class:`~granavg.pipeline.spec.Spec`: its kernel, time axis and
    quantities, checked before the run; the quantities also choose the scene's contact
    output)."""
    from granavg.sim.simulate import scene_for, simulate

    spec = spec if spec is not None else Spec()
    scene = scene_for(scene, spec.averaging.quantities)
    time = spec.averaging.time
    if spec.kernel not in (None, "exact") or spec.width is not None:
        if not average:
            raise ParameterError("kernel", "{param} and {width} smooth the in-situ "
                                 "averages: give {average} N with them")
        InSituAverage.check_kernel(scene, average, spec)
    given = [k for k in OPTIONS if getattr(time, k) is not None]
    if given and not average:
        raise ParameterError(given[0], "{param} resolves the in-situ averages in time: "
                             "give {average} N with it")
    plan = replace(spec, kernel=None if spec.kernel == "exact" else spec.kernel,
                   execution=Execution())
    return simulate(scene, out, average=average, insitu=InSituAverage if average else None,
                    plan=plan.to_dict() if average else None, **options)


def simulate_command(spec: Spec, *, preset="demo", overrides=(), out, np=1, omp=1,
                     resume=False, start=None, engine="lammps", average=None, seeds=None,
                     progress=None, time_accuracy=None) -> str:
    """The ``simulate`` command: one run, a resumed run, or ``seeds`` realisations (on
    the spec's execution: its workers, default 2, or scheduler)."""
    quantities, scheduler = spec.averaging.quantities, spec.execution.scheduler
    require("lammps", what="granavg simulate")
    if seeds is not None or scheduler:
        require("dask", "seeds" if seeds is not None else "scheduler")
    from granavg.sim.scene import preset as scene_preset
    from granavg.sim.simulate import resume as resume_run

    if np < 1 or omp < 1:
        raise ParameterError("np", "{param} and {omp} must be >= 1")
    if resume:
        if overrides or start or engine != "lammps" or average or quantities:
            raise ParameterError("resume", "{param} continues the run as it was set up; drop "
                                 "{overrides}, {start}, {engine}, {average} and "
                                 "{quantities}")
        return str(resume_run(out, np_ranks=np, omp_threads=omp, progress=progress))
    scene = scene_preset(preset).with_overrides(overrides)
    if seeds is not None:
        from granavg.sim.realisations import simulate_ensemble
        from granavg.sim.simulate import scene_for
        in_time = any(getattr(spec.averaging.time, k) is not None for k in OPTIONS)
        if np != 1 or omp != 1 or start or engine != "lammps" or average or in_time:
            raise ParameterError("seeds", "{param} runs each realisation as one "
                                 "single-threaded LAMMPS task; drop {np}, {omp}, {start}, "
                                 "{engine} and {average}")
        runs = simulate_ensemble(scene_for(scene, quantities), out, seeds, spec.execution,
                                 preset=preset)
        return ", ".join(str(r) for r in runs)
    return str(simulate_run(scene, out, np_ranks=np, omp_threads=omp, progress=progress,
                            preset=preset, start=start, engine=engine, average=average,
                            spec=spec, time_accuracy=time_accuracy))
