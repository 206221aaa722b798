"""Mixtures: the particles split into species, and each species' share of a frame.

A species' share holds its particles and every contact one of them makes (MercuryCG's
split, Weinhart et al. 2013): a contact between two of its particles as it is; a
contact with a particle of another species on its own particle alone, as a wall's
(:data:`~granavg.engine.kernels.PARTNER`): its branch runs from the particle's centre to
the contact point, and its force, at the contact point, is the force between species
(the ``inter`` block, :mod:`granavg.engine.channels`). So the partial sums of every
channel add up to the mixture's (each contact's two halves in their own species), the
partial stresses to the mixture's stress, and each species balances its momentum with
the other species' force: div sigma_s + f_inter,s + b_s + t_s = d(rho_s v_s)/dt +
div(rho_s v_s v_s) (at rest: 0).

How particles are split (:class:`Species`, ``species=`` of
:func:`granavg.engine.api.averager`, ``--species``):

- ``type``: by atom type (the atoms' ``type`` column), a species per type present;
- ``radius``: by size, a species per distinct radius (at most :data:`MAX_CLASSES`);
  ``radius:E1,E2,...``: size classes between these edges (polydisperse data);
- ``NAME=T1,T2 NAME=T3 ...`` (or a dict ``{"small": [1, 2], "large": [3]}``): named
  groups of types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from granavg.engine.kernels import PARTNER, frame_rows
from granavg.errors import ParameterError, UserError

#: The species label of the whole mixture.
MIXTURE = "all"
#: Distinct radii ``radius`` takes as species; more: give edges.
MAX_CLASSES = 8
#: Radii equal to this relative tolerance are one size.
SAME_SIZE = 1e-6
#: Contact columns that are vectors on particle 1: side 2 sees them reversed.
_ON_FIRST = ("fnx", "fny", "fnz", "ftx", "fty", "ftz", "nx", "ny", "nz", "mx", "my", "mz")


@dataclass(frozen=True)
class Species:
    """How the particles are split into species.

    Attributes
    ----------
    by : {"type", "radius", "groups"}
    groups : tuple of (str, tuple of int)
        Named groups of atom types (``by="groups"``).
    edges : tuple of float
        Size classes' edges in radius (``by="radius"``; empty: each distinct radius).
    """

    by: str
    groups: tuple = ()
    edges: tuple = ()

    @classmethod
    def parse(cls, spec) -> "Species":
        """A split from its text (``type``, ``radius``, ``radius:E1,E2``,
        ``small=1,2 large=3``), a dict of named type groups, or a Species."""
        if isinstance(spec, Species):
            return spec
        if isinstance(spec, dict):
            return cls._groups([(str(k), v) for k, v in spec.items()])
        text = str(spec).strip()
        if text in ("type", "radius"):
            return cls(text)
        if text.startswith("radius:"):
            try:
                edges = tuple(sorted(float(e) for e in text[7:].split(",") if e.strip()))
            except ValueError:
                edges = ()
            if not edges or any(not e > 0 for e in edges):
                raise ParameterError("species", f"{{param}} {text!r}: give positive radius "
                                     "edges, radius:E1,E2,...")
            return cls("radius", edges=edges)
        parts = [p.split("=", 1) for p in text.replace(";", " ").split()]
        if not parts or any(len(p) != 2 or not p[0] for p in parts):
            raise ParameterError("species", f"{{param}} {text!r}: give type, radius, "
                                 "radius:E1,E2,... or named groups of types such as "
                                 "small=1,2 large=3")
        return cls._groups([(k, v.split(",")) for k, v in parts])

    @classmethod
    def _groups(cls, items) -> "Species":
        groups, seen = [], {}
        for name, types in items:
            listed = types if isinstance(types, (list, tuple)) else [types]
            ts = tuple(_type_id(name, t) for t in listed if str(t).strip())
            if not ts:
                raise ParameterError("species", f"{{param}}: the group {name} has no type")
            if name == MIXTURE or name in dict(groups):
                raise ParameterError("species", f"{{param}}: the name {name} is taken (one "
                                     f"group each; {MIXTURE} is the whole mixture)")
            for t in ts:
                if t in seen:
                    raise ParameterError("species", f"{{param}}: type {t} is in both "
                                         f"{seen[t]} and {name}; a type belongs to one group")
                seen[t] = name
            groups.append((name, ts))
        return cls("groups", groups=tuple(groups))

    def describe(self) -> dict:
        return {"by": self.by, **({"groups": {k: list(v) for k, v in self.groups}}
                                  if self.groups else {}),
                **({"radius_edges": list(self.edges)} if self.edges else {})}

    def classes(self, atoms) -> "Classes":
        """The species of this split in a frame's atoms (the first frame's: kept for
        every frame), checked against what the atoms hold."""
        if self.by in ("type", "groups"):
            if "type" not in atoms:
                raise ParameterError("species", "{param} " + self.by + " needs the atoms' "
                                     "type column; dump it (or split by radius)")
            present = sorted({int(t) for t in np.unique(atoms["type"])})
            if self.by == "type":
                return Classes(self, tuple(f"type{t}" for t in present),
                               tuple((t,) for t in present))
            lacking = [(n, t) for n, ts in self.groups for t in ts if t not in present]
            if lacking:
                name, t = lacking[0]
                raise ParameterError("species", f"{{param}}: the group {name} names type "
                                     f"{t}, which no particle of the data has (types: "
                                     f"{', '.join(map(str, present))})")
            return Classes(self, tuple(n for n, _ in self.groups),
                           tuple(ts for _, ts in self.groups))
        radius = np.asarray(atoms["radius"], float)
        if self.edges:
            e = self.edges
            names = tuple(f"r<{e[0]:g}" if k == 0 else f"r>={e[-1]:g}" if k == len(e)
                          else f"{e[k - 1]:g}<=r<{e[k]:g}" for k in range(len(e) + 1))
            return Classes(self, names, edges=e)
        sizes = _distinct(radius)
        if len(sizes) > MAX_CLASSES:
            raise ParameterError("species", f"{{param}} radius: the particles have more than "
                                 f"{MAX_CLASSES} distinct radii (polydisperse); give size "
                                 "classes, radius:E1,E2,...")
        return Classes(self, tuple(f"r={r:g}" for r in sizes), sizes=tuple(sizes))


def _type_id(name: str, text) -> int:
    """One atom type of a named group, refused in one line unless it is an integer.

    Parameters
    ----------
    name : str
        The group's name (for the message).
    text : str or number
        The type as given: ``2``, ``"2"`` and ``2.0`` are type 2; ``1.5`` or ``"a"`` are
        refused, never rounded.

    Returns
    -------
    int
        The atom type.
    """
    try:
        value = float(str(text).strip())
    except ValueError:
        value = math.nan
    if not value.is_integer():
        raise ParameterError("species", f"{{param}}: the group {name} names type "
                             f"{str(text).strip()!r}, not an integer; give atom types as "
                             f"integers, e.g. {name}=1,2")
    return int(value)


def _distinct(radius) -> list:
    """The distinct radii, equal within :data:`SAME_SIZE` relative."""
    out = []
    for r in np.unique(radius):
        if not out or r > out[-1] * (1 + SAME_SIZE):
            out.append(float(r))
        if len(out) > MAX_CLASSES:
            break
    return out


@dataclass(frozen=True)
class Classes:
    """The species of a split, fixed from the first frame: their names and how a
    particle is told to be of one."""

    split: Species
    names: tuple
    types: tuple = ()
    edges: tuple = ()
    sizes: tuple = ()

    def label(self, atoms) -> np.ndarray:
        """Each particle's species (index into :attr:`names`), -1 for none."""
        if self.types:
            t = np.asarray(atoms["type"]).astype(np.int64)
            out = np.full(len(t), -1, np.int64)
            for k, ts in enumerate(self.types):
                out[np.isin(t, ts)] = k
            if self.split.by == "type" and np.any(out < 0):
                raise UserError(f"a frame holds atom type {int(t[out < 0][0])}, which the "
                                "first frame had none of: species by type are fixed by the "
                                "first frame averaged; name the groups (small=1,2 ...)")
            return out
        r = np.asarray(atoms["radius"], float)
        if self.edges:
            return np.searchsorted(np.asarray(self.edges), r, side="right").astype(np.int64)
        sizes = np.asarray(self.sizes)
        k = np.clip(np.searchsorted(sizes, r * (1 - SAME_SIZE)), 0, len(sizes) - 1)
        out = np.where(np.abs(sizes[k] - r) <= SAME_SIZE * sizes[k], k, -1)
        if np.any(out < 0):
            raise UserError(f"a frame holds a particle of radius {r[out < 0][0]:g}, a size the "
                            "first frame had none of: species by radius are fixed by the "
                            "first frame; give size classes, radius:E1,E2,...")
        return out

    def shares(self, frame) -> list:
        """Each species' share of ``frame`` (module docstring), in :attr:`names` order."""
        label = self.label(frame.atoms)
        contacts = frame.contacts
        rows = frame_rows(frame) if contacts is not None else None
        return [_share(frame, label == k, rows) for k in range(len(self.names))]


@dataclass
class Share:
    """A species' share of a frame: what :func:`~granavg.engine.frame_sums.frame_sums`
    takes."""

    timestep: int
    time: float
    atoms: dict
    contacts: dict | None
    rows: tuple | None = None
    shear: object | None = None


def _share(frame, mine: np.ndarray, rows) -> Share:
    """The particles ``mine`` and their contacts: the others' particles as walls
    (:data:`~granavg.engine.kernels.PARTNER`), side 2 turned to side 1 where the
    species' particle is second."""
    atoms = {k: np.asarray(v)[mine] for k, v in frame.atoms.items()}
    if frame.contacts is None:
        return Share(frame.timestep, frame.time, atoms, None, None, getattr(frame, "shear", None))
    i1, i2 = rows
    wall = np.asarray(frame.contacts["wall"])
    first = mine[i1]
    second = (i2 >= 0) & mine[np.maximum(i2, 0)]
    keep = first | second
    turn = second & ~first                                    # mine is particle 2
    partner = (first ^ second) & (wall == 0)                  # the other is of another species
    out = {}
    for key, value in frame.contacts.items():
        v = np.asarray(value)
        if key == "id1" or key == "id2":
            other = np.asarray(frame.contacts["id2" if key == "id1" else "id1"])
            v = np.where(turn, other, v)
        elif key in _ON_FIRST:
            v = np.where(turn, -v, v)
        elif key == "wall":
            v = np.where(partner, PARTNER, v)
        out[key] = v[keep]
    return Share(frame.timestep, frame.time, atoms, out, None, getattr(frame, "shear", None))


def with_species(whole, parts: dict, classes: Classes):
    """The mixture's fields with a species axis: each species' (``parts``) and the
    whole's (:data:`MIXTURE`, first), each with the concentration ``c`` = nu_s / nu
    (Eq. 2's volume fractions; 1 for the whole), the segregation flux ``seg_*`` =
    nu_s (v_s - v) (0 for the whole) and the kinetic stress about the mixture's velocity
    ``dsigma_mix_*``, where the fields hold what they need. Their standard errors come
    from the species' and the whole's replicates of the same parts of the data (time
    blocks, sectors: the covariance counted) where both have them, else NaN (an
    ensemble's come from its runs)."""
    from granavg.engine.fields import Fields

    fields = {MIXTURE: whole, **parts}
    if "nu" in whole.values:
        for f in fields.values():
            _derived(f.values, whole.values)
            _errors(f, whole)
    meta = dict(whole.meta)
    meta["species"] = {**classes.split.describe(), "names": [MIXTURE, *classes.names],
                       "dsigma_fluct": "about the species' own velocity; dsigma_mix about "
                                       "the mixture's: dsigma_fluct + rho_s (v_s - v)(v_s - v)",
                       "derived": "c = nu_s / nu, seg_<i> = nu_s (v_s - v)_i and dsigma_mix "
                                  "with errors from the replicates of the species and the "
                                  "whole (the same parts of the data)"}
    return Fields.of_species(fields, meta)


def _derived(values: dict, whole: dict) -> list:
    """Add c, seg_* and dsigma_mix_* to a species' values (arrays of any shape, the
    whole's alike: fields, or replicates); returns their names."""
    nu = np.asarray(whole["nu"], float)
    with np.errstate(invalid="ignore", divide="ignore"):
        values["c"] = np.where(nu > 0, values["nu"] / nu, np.nan)
    names = ["c"]
    axes = [c[2:] for c in whole if c.startswith("v_")]
    for a in axes:
        flux = values["nu"] * (values["v_" + a] - whole["v_" + a])
        values["seg_" + a] = np.where(np.isfinite(flux), flux,
                                      np.where(values["nu"] == 0, 0.0, np.nan))
        names.append("seg_" + a)
    if "rho" in values:
        for key in [k for k in values if k.startswith("dsigma_fluct_")]:
            ij = key[len("dsigma_fluct_"):]
            i, j = next((a, ij[len(a):]) for a in axes if ij.startswith(a) and ij[len(a):] in axes)
            drift = (values["v_" + i] - whole["v_" + i]) * (values["v_" + j] - whole["v_" + j])
            values["dsigma_mix_" + ij] = values[key] + values["rho"] * drift
            names.append("dsigma_mix_" + ij)
    return names


def _errors(f, whole) -> None:
    """The derived columns' errors (and replicates) from the species' and the whole's
    replicates of the same parts of the data, replicate by replicate (per time for
    fields in time); NaN where they are not alike."""
    made = [k for k in f.values if k == "c" or k.startswith(("seg_", "dsigma_mix_"))]
    for k in made:
        f.sem[k] = np.full(np.shape(f.values[k]), np.nan)
    mine, theirs = f.replicates, whole.replicates
    if isinstance(mine, list) and isinstance(theirs, list):
        pairs = list(enumerate(zip(mine, theirs)))
    elif mine is not None and theirs is not None and not isinstance(mine, list):
        pairs = [(None, (mine, theirs))]
    else:
        pairs = []
    needed = ("nu", *[c for c in whole.values if c.startswith("v_")])
    for j, (r, w) in pairs:
        if r is None or w is None or r.kind != w.kind or r.n != w.n or r.parts != w.parts \
                or not all(k in r.values and k in w.values for k in needed):
            continue
        values = dict(r.values)
        extra = {k: values[k] for k in _derived(values, w.values)}
        r.values.update(extra)
        for k, e in type(r)(r.kind, extra, r.parts).profile_errors().items():
            if j is None:
                f.sem[k] = e
            else:
                f.sem[k][j] = e
