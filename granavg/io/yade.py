"""Frames of a running Yade (https://yade-dem.org), taken from its ``O.bodies`` and
``O.interactions`` in the same Python process (:class:`YadeScene`; the averager a Yade
script feeds each N steps is :class:`granavg.pipeline.yade.YadeAverage`).

What a frame holds (SI units, as Yade's):

- atoms: the dynamic spheres (``Sphere`` shape, ``dynamic``): ``id`` (the body id), ``x
  y z`` (wrapped into a periodic cell), ``radius``, ``vx vy vz``, ``omegax omegay
  omegaz``, ``mass``, ``type`` (the material's id, ``b.material.id``) and, where the
  scene's ``NewtonIntegrator`` has a gravity, the body force m g as ``bx by bz``;
- contacts: every real interaction with at least one such sphere; its partner is a
  particle, or a wall (wall code 1, ``id2`` the body id) where it is anything else: a
  ``Facet``, ``Box`` or ``Wall``, a fixed sphere, a body moved by an engine.

Yade's conventions (checked on a sphere resting on a wall and a pile at rest,
tests/test_yade.py): ``i.geom.normal`` points from body ``id1`` to body ``id2`` (from a
wall to the sphere); ``i.phys.normalForce`` and ``i.phys.shearForce`` act on ``id2``,
their opposites on ``id1``; ``i.geom.penetrationDepth`` is the overlap. granavg's
columns (:func:`granavg.io.contacts.contact_columns`) put the particle first and give the
forces on it and the normal from it towards its partner.

Not taken: the contact laws' couples (``CohFrictPhys``' moment_twist and
moment_bending: the couple stress comes from the forces alone), Cundall's local damping
of ``NewtonIntegrator`` (a force on the moving spheres the balance of momentum does not
see), clumps (refused), a sheared periodic cell (refused).
"""

from __future__ import annotations

import numpy as np

from granavg.engine.gate import Origin
from granavg.engine.unit_system import SI
from granavg.errors import UserError
from granavg.io.box import Box
from granavg.io.contacts import contact_columns
from granavg.io.frames import Frame


#: What Cundall's local damping (``NewtonIntegrator.damping`` > 0) means for the fields:
#: said in the log and the sidecar wherever it may act.
DAMPED = ("NewtonIntegrator's local damping acts on the moving spheres: a force that is "
          "not a contact force and not in the fields, so the contact stress does not "
          "balance the body forces where the spheres accelerate (a pile not yet at rest "
          "carries less than its weight); set damping=0 for fields that obey the momentum "
          "balance")

#: The contact columns of a frame, 3D, no couple.
#: What a refusal of the scene's own data says to do (instead of mending a file).
SCENE = ("the scene holds it: an unstable run (a time step too large for the stiffness), "
         "or a body or interaction set by hand; check them before averaging")
CONTACT_COLUMNS = ("id1", "id2", "wall", "fnx", "fny", "fnz", "ftx", "fty", "ftz", "nx",
                   "ny", "nz", "overlap")


def yade_contacts(id1, id2, normal, depth, fn, fs, r1, r2, wall1, wall2):
    """Yade's interactions -> granavg's contact columns, and what is left out.

    Parameters
    ----------
    id1, id2 : ndarray, shape (n,)
        ``i.id1``, ``i.id2``.
    normal : ndarray, shape (n, 3)
        ``i.geom.normal``: unit, from body id1 towards body id2.
    depth : ndarray, shape (n,)
        ``i.geom.penetrationDepth`` (m).
    fn, fs : ndarray, shape (n, 3)
        ``i.phys.normalForce``, ``i.phys.shearForce``: the forces on body id2 (N).
    r1, r2 : ndarray, shape (n,)
        The bodies' radii, 0 for a wall.
    wall1, wall2 : ndarray of int, shape (n,)
        1 where the body is a wall, else 0.

    Returns
    -------
    columns : dict of str -> ndarray, shape (m,)
        :data:`CONTACT_COLUMNS`, the particle first, of the pairs that touch
        (penetrationDepth > 0) or carry a normal force.
    dropped : dict of str -> int
        ``contacts_not_touching`` (real interactions with neither: Yade keeps them
        while the bounding boxes overlap), ``contacts_between_walls``.
    """
    normal, fn, fs = (np.asarray(a, float).reshape(-1, 3) for a in (normal, fn, fs))
    depth = np.asarray(depth, float)
    # body 1 is granavg's atom 1: its force is minus Yade's, d = x_1 - x_2 along -normal,
    # and dist such that r1 + r2 - dist is Yade's depth
    c = contact_columns(np.asarray(id1), np.asarray(id2), -normal, r1 + r2 - depth, -fn, -fs,
                        np.asarray(wall1), np.asarray(wall2), r1, r2)
    length = np.sqrt(np.sum(normal * normal, axis=1))
    for x in "xyz":                 # Yade's normal as given: the gate judges its length
        c[f"n{x}"] = c[f"n{x}"] * length
    touching = (depth > 0) | np.any(fn != 0, axis=1)
    keep = c["packing"] & touching
    dropped = {"contacts_not_touching": int(np.sum(c["packing"] & ~touching)),
               "contacts_between_walls": int(np.sum(~c["packing"]))}
    return {k: c[k][keep] for k in CONTACT_COLUMNS}, dropped


def _vec(v) -> tuple:
    return v[0], v[1], v[2]


def _kind(body) -> str:
    return type(body.shape).__name__


class YadeScene:
    """The frame source of a running Yade: :meth:`frame` the state now.

    Parameters
    ----------
    omega : yade.Omega, optional
        The simulation (a script's ``O``); default ``yade.Omega()``.

    Attributes
    ----------
    frames : list of Frame
        The frames :meth:`record` took, in order: iterating the scene gives them (a
        frame source, e.g. for :func:`granavg.average`).
    dropped : dict of str -> int
        Interactions left out, summed over the frames taken (:func:`yade_contacts`).
    units : UnitSystem
        SI.
    """

    format_name = "yade"
    dim = 3

    def __init__(self, omega=None):
        if omega is None:
            import yade

            omega = yade.Omega()
        self.omega, self.units, self.frames = omega, SI, []
        self.dropped = {"contacts_not_touching": 0, "contacts_between_walls": 0}

    def __iter__(self):
        return iter(self.frames)

    def _cell(self):
        """The periodic cell's sides (Lx, Ly, Lz), or None for an aperiodic scene;
        refuses a sheared cell."""
        if not self.omega.periodic:
            return None
        h = np.array([[self.omega.cell.hSize[i, j] for j in range(3)] for i in range(3)])
        if np.any(h[~np.eye(3, dtype=bool)] != 0):
            raise UserError("the periodic cell is sheared (O.cell.hSize has off-diagonal "
                            "terms): granavg averages Yade's orthogonal cells only")
        return np.diag(h)

    def _newton(self):
        return next((e for e in self.omega.engines if type(e).__name__ == "NewtonIntegrator"),
                    None)

    def gravity(self) -> tuple | None:
        """The gravity of the scene's ``NewtonIntegrator`` (m/s^2), None where none."""
        newton = self._newton()
        g = None if newton is None else _vec(newton.gravity)
        return g if g is not None and any(x != 0 for x in g) else None

    def frame(self) -> Frame:
        """The state now: the dynamic spheres and their contacts (see the module
        docstring).

        Returns
        -------
        Frame
            ``timestep`` O.iter, ``time`` O.time (s); atoms' columns shape (P,),
            contacts' (C,).
        """
        bodies = [b for b in self.omega.bodies if b is not None]
        if any(b.isClump or b.isClumpMember for b in bodies):
            raise UserError("the scene has clumps: granavg averages spheres, not clumps "
                            "(their members would count as free spheres)")
        spheres = [b for b in bodies if _kind(b) == "Sphere" and b.dynamic]
        rows = np.array([(b.id, *_vec(b.state.pos), b.shape.radius, *_vec(b.state.vel),
                          *_vec(b.state.angVel), b.state.mass, b.material.id)
                         for b in spheres], float).reshape(-1, 13)
        names = ("id", "x", "y", "z", "radius", "vx", "vy", "vz", "omegax", "omegay",
                 "omegaz", "mass", "type")
        atoms = {k: rows[:, j] for j, k in enumerate(names)}
        sides = self._cell()
        if sides is not None:
            for k, x in enumerate("xyz"):
                atoms[x] = np.mod(atoms[x], sides[k])
        g = self.gravity()
        if g is not None:
            atoms.update({f"b{x}": atoms["mass"] * gx for x, gx in zip("xyz", g)})
        box = None if sides is None else Box((0.0, 0.0, 0.0), tuple(map(float, sides)),
                                             periodic=(True, True, True))
        return Frame(int(self.omega.iter), float(self.omega.time), atoms,
                     self._contacts(bodies, atoms), box=box,
                     origin={"atoms": Origin("the Yade scene", scene=SCENE),
                             "contacts": Origin("the Yade scene", scene=SCENE)})

    def _contacts(self, bodies, atoms) -> dict:
        size = max((b.id for b in bodies), default=-1) + 1
        radius, wall = np.zeros(size), np.ones(size, int)
        ids = atoms["id"].astype(int)
        radius[ids], wall[ids] = atoms["radius"], 0
        try:
            rows = np.array([(i.id1, i.id2, *_vec(i.geom.normal), i.geom.penetrationDepth,
                              *_vec(i.phys.normalForce), *_vec(i.phys.shearForce))
                             for i in self.omega.interactions if i.isReal], float)
        except AttributeError as exc:
            raise UserError(f"an interaction's geometry or physics has no {exc.name}: "
                            "granavg reads ScGeom geometries (normal, penetrationDepth) "
                            "and FrictPhys physics (normalForce, shearForce) and their "
                            "kinds") from None
        rows = rows.reshape(-1, 12)
        if np.isnan(rows[:, 5]).any():
            raise UserError("the scene's interactions have NaN penetration depths, as a "
                            "saved scene has right after O.load(): run a step (O.step()) "
                            "before averaging")
        i1, i2 = rows[:, 0].astype(int), rows[:, 1].astype(int)
        columns, dropped = yade_contacts(i1, i2, rows[:, 2:5], rows[:, 5], rows[:, 6:9],
                                         rows[:, 9:12], radius[i1], radius[i2], wall[i1],
                                         wall[i2])
        for k, n in dropped.items():
            self.dropped[k] += n
        return columns

    def record(self) -> Frame:
        """:meth:`frame`, kept in ``frames``."""
        frame = self.frame()
        self.frames.append(frame)
        return frame

    def box(self) -> tuple:
        """Per axis (lo, hi): the periodic cell, else the spheres' extent now."""
        sides = self._cell()
        if sides is not None:
            return tuple((0.0, float(s)) for s in sides)
        atoms = self.frame().atoms
        if not len(atoms["x"]):
            raise UserError("the scene has no dynamic sphere: nothing to average")
        a = atoms["radius"]
        return tuple((float((atoms[x] - a).min()), float((atoms[x] + a).max())) for x in "xyz")

    def periodic(self) -> tuple:
        """Per axis, whether the scene is periodic along it (Yade's cell: all three)."""
        return (bool(self.omega.periodic),) * 3

    def damping(self) -> float:
        """The ``NewtonIntegrator``'s local damping (0 where none)."""
        newton = self._newton()
        return 0.0 if newton is None else float(newton.damping)

    def describe(self) -> dict:
        """The scene's settings the frames depend on, for the sidecar."""
        newton = self._newton()
        walls = {}
        for b in self.omega.bodies:
            if b is not None and not (_kind(b) == "Sphere" and b.dynamic):
                walls[_kind(b)] = walls.get(_kind(b), 0) + 1
        sides = self._cell()
        return {"dim": 3, "dt": float(self.omega.dt),
                "periodic_cell": None if sides is None else [float(s) for s in sides],
                "walls": walls, "type": "the material's id (b.material.id)",
                "body_forces": {"gravity": list(self.gravity() or ())},
                "damping": None if newton is None else float(newton.damping),
                **({"non_contact_forces": DAMPED} if self.damping() else {}),
                "inertia": {"shape": "sphere", "I": "2/5 m a^2", "why": "3D"}}
