"""A Yade pile at rest, averaged by granavg while Yade runs and exported to VTK.

Run headless with granavg importable in Yade's Python (tests/test_yade.py builds such a
venv)::

    yade -n -x tests/decks/pile_yade.py OUT [n=800] [every=200] [frames=10] [seed=1]

About 800 bidisperse glass-like spheres (d = 1.6 and 2.4 mm, 2500 kg/m^3, friction
tan 0.5) rain from a loose lattice onto a box floor (its top at z = 0) in a cell
periodic in x and y (16 x 16 mm; Yade's cell is periodic in z too, 100 mm tall, well
above the pile) and settle under gravity -z until Yade's unbalanced force is below
1e-4. Then ``frames`` frames, ``every`` steps apart, are

- averaged in process (:class:`granavg.pipeline.yade.YadeAverage`, 6 slabs of 4 mm across z
  from the floor): OUT/inprocess.csv and its sidecar;
- kept as arrays: OUT/frames.npz (each frame's atom and contact columns, and Yade's
  own sum of the contact forces on each sphere, ``O.forces.f``, at the last frame);
- exported as a Yade user would: ``VTKRecorder`` (spheres, velocities, masses, ids,
  the periodic cell) and ``yade.export.VTKExporter.exportInteractions`` (each contact's
  ids, normal, penetration depth, normal and shear force) into OUT/vtk/.

OUT/run.json says the settling (steps, wall time, unbalanced force), the time step,
the cell and the cells averaged over.
"""

import json
import logging
import sys
import time
from pathlib import Path

import numpy as np
from yade import export, utils
from yade.wrapper import (Bo1_Box_Aabb, Bo1_Sphere_Aabb, ForceResetter, FrictMat,
                          Ig2_Box_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom,
                          InsertionSortCollider, InteractionLoop,
                          Ip2_FrictMat_FrictMat_FrictPhys, Law2_ScGeom_FrictPhys_CundallStrack,
                          NewtonIntegrator, Omega, PyRunner, VTKRecorder)

from granavg.io.profiles_io import write_profiles
from granavg.pipeline.yade import YadeAverage
from granavg.io.yade_vtk import INTERACTIONS

logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
log = logging.getLogger("pile_yade")

OUT = Path(sys.argv[1])
SETTINGS = {"n": 800, "every": 200, "frames": 10, "seed": 1,
            **{k: int(v) for k, v in (a.split("=") for a in sys.argv[2:])}}
L, H = 0.016, 0.1                       # the cell, m
RADII = (0.8e-3, 1.2e-3)                # m
G = (0.0, 0.0, -9.81)
CELLS = {"slabs": "z", "range": (0.0, 0.024), "bins": 6}

O = Omega()
O.periodic = True
O.cell.setBox(L, L, H)
O.materials.append(FrictMat(young=1e6, poisson=0.3, density=2500, frictionAngle=0.5))
O.bodies.append(utils.box((L / 2, L / 2, -1e-3), (L / 2, L / 2, 1e-3), fixed=True))
rng = np.random.default_rng(SETTINGS["seed"])
side = 6
pitch = L / side
for k in range(SETTINGS["n"]):
    layer, cell = divmod(k, side * side)
    i, j = divmod(cell, side)
    centre = ((i + 0.5) * pitch + rng.uniform(-1e-4, 1e-4),
              (j + 0.5) * pitch + rng.uniform(-1e-4, 1e-4), 1.3e-3 + layer * pitch)
    O.bodies.append(utils.sphere(centre, RADII[int(rng.random() < 0.5)]))
# an infinite Wall floor hangs Yade 2023.02a's collider in a periodic cell: a box
newton = NewtonIntegrator(gravity=G, damping=0.5)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()],
                                   allowBiggerThanPeriod=True),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                             [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             newton]
O.dt = 0.5 * utils.PWaveTimeStep()

start = time.time()
while O.iter < 200_000:
    O.run(2000, True)
    if O.iter >= 20_000 and utils.unbalancedForce() < 1e-4:
        break
settled = {"steps": O.iter, "wall_s": round(time.time() - start, 1),
           "unbalanced_force": utils.unbalancedForce()}
log.info("settled: %s", settled)

(OUT / "vtk").mkdir(parents=True, exist_ok=True)
average = YadeAverage(CELLS, keep=True)
exporter = export.VTKExporter(str(OUT / "vtk" / "pile"))
contact_force = {}


def sample():
    """One frame: averaged, exported, and Yade's own force sums kept."""
    average.add()
    real = [(i.id1, i.id2) for i in O.interactions if i.isReal]
    exporter.exportInteractions(ids=real, what=INTERACTIONS, numLabel=O.iter)
    contact_force.update({b.id: tuple(O.forces.f(b.id)) for b in O.bodies})


# after the InteractionLoop, before the NewtonIntegrator: the positions the forces
# were computed at
every = SETTINGS["every"]
O.engines = O.engines[:-1] + [
    PyRunner(iterPeriod=every, initRun=True, command="sample()"),
    VTKRecorder(iterPeriod=every, initRun=True, fileName=str(OUT / "vtk" / "pile-"),
                recorders=["spheres", "velocity", "mass", "id", "pericell"]),
    newton]
O.run(every * (SETTINGS["frames"] - 1) + 1, True)

fields = average.conclude()
write_profiles(fields, OUT / "inprocess.csv")
frames = average.scene.frames
arrays = {}
for k, f in enumerate(frames):
    arrays.update({f"atoms{k}_{c}": v for c, v in f.atoms.items()})
    arrays.update({f"contacts{k}_{c}": v for c, v in f.contacts.items()})
ids = frames[-1].atoms["id"].astype(int)
arrays["yade_force"] = np.array([contact_force[i] for i in ids])
np.savez(OUT / "frames.npz", steps=[f.timestep for f in frames],
         times=[f.time for f in frames], **arrays)
(OUT / "run.json").write_text(json.dumps({
    "settled": settled, "dt": O.dt, "cell": [L, L, H], "gravity": G, "cells": CELLS,
    "settings": SETTINGS, "wall_s": round(time.time() - start, 1)}, indent=1))
log.info("done: %d frames in %s", len(frames), OUT)
