"""Fields of a running Yade, averaged each N steps in its own process: the frame sink a
Yade script's ``PyRunner`` feeds (:class:`YadeAverage`), on the frames of
:class:`granavg.io.yade.YadeScene`.
"""

from __future__ import annotations

import logging
from dataclasses import replace

from granavg.engine.api import averager
from granavg.engine.cells import Space, from_options
from granavg.engine.cells.base import Cells
from granavg.engine.fields import Fields
from granavg.engine.smoothing import smooth
from granavg.engine.unit_system import SI
from granavg.errors import ParameterError, UserError
from granavg.io.yade import DAMPED, YadeScene
from granavg.pipeline.spec import Spec

log = logging.getLogger(__name__)


class YadeAverage:
    """Fields of a running Yade, one frame each time :meth:`add` is called: a script
    adds ``PyRunner(iterPeriod=N, command="average.add()")`` to ``O.engines`` (after
    the ``InteractionLoop``, before the ``NewtonIntegrator``: positions and forces of
    the same step) and, when the run ends, ``fields = average.conclude()``.

    The fields equal ``granavg.average(average.scene.frames, cells=average.cells,
    ...)`` with ``keep=True``: the same averager
    (:func:`granavg.engine.api.averager`) chooses the quantities and the errors' base
    block from the first two frames, and takes the frames one by one.

    Parameters
    ----------
    cells : Cells or dict
        The cells (:mod:`granavg.cells`), or their options as ``granavg.average`` takes
        them (``{"slabs": "z", "bins": 6, "range": (0, 0.024)}``), lengths defaulting to
        the periodic cell, or to the spheres' extent at the first frame.
    omega : yade.Omega, optional
        The simulation; default ``yade.Omega()``.
    keep : bool
        Keep every frame added (``scene.frames``).
    **options
        Options of an average as ``granavg.average`` takes them
        (:meth:`granavg.pipeline.spec.Spec.of`): ``kernel`` and ``width`` (m),
        ``quantities``, ``t_min``, ``t_max``, ``block_time``, ``branch``, ``sectors``,
        ``windows``, ...

    Attributes
    ----------
    scene : YadeScene
    cells : Cells or None
        The cells, built at the first frame.
    """

    def __init__(self, cells, *, omega=None, keep=False, **options):
        if not isinstance(cells, (Cells, dict)):
            raise UserError(f"cells {cells!r}: give granavg cells (granavg.cells) or a "
                            "dict of their options")
        self.scene, self.keep = YadeScene(omega), keep
        spec = Spec.of(cells=cells, **options)
        src = spec.source
        files = [k for k in ("atoms", "contacts") if getattr(src, k)] + \
            [k for k in src.given() if k != "density"] + ["workers"] * spec.execution.on_dask
        if files:
            raise ParameterError(files[0], "{param}: not an option of a running Yade's "
                                 "average (its frames come from O.bodies and "
                                 "O.interactions, in this process; the masses from the "
                                 "spheres, or density=)")
        #: the average's spec (:class:`~granavg.pipeline.spec.Spec`), its frames Yade's
        self.spec = replace(spec, source=replace(spec.source, frames=self.scene))
        self.cells, self._avg, self._head = None, None, []

    def add(self) -> None:
        """Take the frame now and average it."""
        frame = self.scene.record() if self.keep else self.scene.frame()
        if self.cells is None:
            given = self.spec.cells if isinstance(self.spec.cells, Cells) else \
                from_options(Space(3, self.scene.box, self.scene.periodic), **self.spec.cells)
            self.cells = smooth(given, self.spec.kernel, self.spec.width)
        if self._avg is not None:
            self._avg.add(frame)
            return
        self._head.append(frame)
        if len(self._head) == 2:
            self._start()

    def _start(self) -> None:
        if self.scene.damping():
            log.warning("damping %g: %s", self.scene.damping(), DAMPED)
        self._avg = averager(self._head, self.cells, self.spec.averaging,
                             density=self.spec.source.density, units=SI)
        self._avg.prepare()
        for frame in self._head:
            self._avg.add(frame)
        self._head = []

    def conclude(self) -> Fields:
        """The fields of the frames added so far (values and errors per cell, with the
        sidecar's metadata: ``meta["inputs"]`` the scene's settings).

        Raises
        ------
        UserError
            No frame was added.
        """
        if self._avg is None:
            if not self._head:
                raise UserError("no frame to average: add() was never called (a PyRunner "
                                "in O.engines calls it each N steps)")
            self._start()
        fields = self._avg.conclude()
        fields.meta.update({"files": {"atoms": "in process (Yade)", "contacts":
                                      "in process (Yade)"},
                            "inputs": {"format": self.scene.format_name,
                                       **self.scene.describe()},
                            "spec": self.spec.to_dict()})
        if any(self.scene.dropped.values()):
            fields.meta["dropped"] = dict(self.scene.dropped)
        log.info("averaged %d Yade frames", fields.frames_averaged)
        return fields
