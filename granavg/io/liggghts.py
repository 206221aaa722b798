"""LIGGGHTS' output: atoms from ``dump custom`` (LAMMPS' text layout), contacts from a
``dump local`` of ``compute pair/gran/local`` and mesh walls' contacts from one of
``compute wall/gran/local``.

LIGGGHTS' contact computes write their values in one fixed order whatever the order of
their keywords (:data:`KEYWORDS`); the dump names them ``c_ID[1]`` .. ``c_ID[N]`` and
nothing else. The user names the keywords of the compute line (``pos id force delta``,
any order; none: LIGGGHTS' default set, :data:`DEFAULT`), and the columns follow. Their
count is checked against the dump's (``history`` takes what the others leave).

Each contact becomes granavg's columns through :func:`granavg.io.contacts.
contact_columns`:

- the branch d = x_i - x_j from the ``pos`` columns (positions wrapped into the box, so
  the minimum image along periodic axes), else from the atoms' positions;
- the total ``force`` on i is split into its normal part along d and the rest, unless
  ``force_normal`` and ``force_tangential`` are given;
- the overlap is ``delta`` where dumped (exact to the print precision), else
  r_i + r_j - |d| (which loses digits: |d| is printed, the overlap is its small
  difference from the radii);
- a mesh-wall contact (``wall/gran/local``: ``pos`` is the contact point, then the
  particle's centre; ``id`` the mesh, the triangle, the particle) has the particle as
  atom 1 and the mesh as its wall partner (wall code 1), its normal towards the contact
  point. Primitive walls cannot be dumped by LIGGGHTS: their force enters only as a
  per-atom column named ``bx by bz`` (``fix wall/gran ... store_force yes`` keeps it in
  ``f_force_ID[1..3]``), said in the log and the sidecar.

``torque``, ``vel``, ``history``, ``contactArea``, ``heatFlux`` and ``contactPoint``
are read past: the contact couple beyond the forces' moments (rolling resistance) is
not recovered from them.
"""

from __future__ import annotations

import logging
import re

import numpy as np

from granavg.errors import ParameterError, UserError, literal
from granavg.engine.kernels import lookup
from granavg.io.box import Box
from granavg.io.contacts import contact_columns
from granavg.engine.plugins import Option
from granavg.io.formats import ATOM_MAP, DIM, DT, INERTIA, UNITS, Format
from granavg.io.frames import CONSISTENCY, check_integers
from granavg.io.dump_columns import dump_header
from granavg.io.lammps_dumps import LammpsDumps
from granavg.io.reader import DumpReader

log = logging.getLogger(__name__)

_XYZ = ("x", "y", "z")
#: ``compute pair/gran/local`` / ``wall/gran/local`` keywords in LIGGGHTS' fixed output
#: order: (keyword, number of values (None: the contact model's history), the names
#: granavg gives them for a pair, for a mesh-wall contact).
KEYWORDS = (
    ("pos", 6, ("x1", "y1", "z1", "x2", "y2", "z2"),
     ("cpx", "cpy", "cpz", "x1", "y1", "z1")),
    ("vel", 6, None, None),
    ("id", 3, ("id1", "id2", "periodic"), ("mesh", "triangle", "id1")),
    ("force", 3, ("fx", "fy", "fz"), ("fx", "fy", "fz")),
    ("force_normal", 3, ("fnx", "fny", "fnz"), ("fnx", "fny", "fnz")),
    ("force_tangential", 3, ("ftx", "fty", "ftz"), ("ftx", "fty", "ftz")),
    ("torque", 3, None, None),
    ("history", None, None, None),
    ("contactArea", 1, None, None),
    ("delta", 1, ("delta",), ("delta",)),
    ("heatFlux", 1, None, None),
    ("contactPoint", 3, None, None),
)
#: What the computes store when their line names no keyword.
DEFAULT = ("pos", "vel", "id", "force", "torque", "history", "contactArea")
_ENTRY = re.compile(r"^c_(.+)\[(\d+)\]$")


def parse_keywords(text, param="liggghts") -> tuple:
    """The keywords of a compute line (``"pos id force delta"``; ``"default"`` or empty:
    :data:`DEFAULT`), in LIGGGHTS' output order; one-line refusal of an unknown one."""
    words = str(text or "").replace(",", " ").split()
    if not words or words == ["default"]:
        return DEFAULT
    known = [k for k, *_ in KEYWORDS]
    unknown = [w for w in words if w not in known]
    if unknown:
        raise ParameterError(param, f"{{param}} {literal(unknown[0])}: not a keyword of "
                             f"LIGGGHTS' compute pair/gran/local; name those of your "
                             f"compute line, of: {' '.join(known)}")
    return tuple(k for k in known if k in words)


def layout(keywords, names, path, wall=False, param="liggghts") -> dict:
    """Our name -> the dump's column of each value granavg uses.

    Parameters
    ----------
    keywords : tuple of str
        :func:`parse_keywords`' result.
    names : list of str
        The dump's columns: ``c_ID[k]`` (the compute's k-th value, any subset and order)
        or, named otherwise, the compute's values in order.
    wall : bool
        A ``wall/gran/local`` dump (its own names for ``pos`` and ``id``).

    Raises
    ------
    ParameterError
        The keywords make more or fewer values than the dump holds (naming the counts).
    """
    entries = [_ENTRY.match(n) for n in names]
    indexed = all(entries) and len({m.group(1) for m in entries}) == 1
    n_values = max(int(m.group(2)) for m in entries) if indexed and entries else len(names)
    fixed = sum(n or 0 for k, n, *_ in KEYWORDS if k in keywords)
    counts = ", ".join(f"{k} {n if n is not None else '?'}" for k, n, *_ in KEYWORDS
                       if k in keywords)
    history = n_values - fixed if "history" in keywords else 0
    if ("history" in keywords and history < 1) or ("history" not in keywords and
                                                    fixed != n_values):
        what = f"{fixed} values per contact and history at least 1" \
            if "history" in keywords else f"{fixed} values per contact"
        raise ParameterError(param, f"{{param}} {literal(' '.join(keywords))}: {what} "
                             f"({counts}), but {path} holds {n_values} "
                             f"({names[0]} .. {names[-1]}); name the keywords of the "
                             "compute line that wrote it")
    column = {(int(m.group(2)) if indexed else k + 1): name
              for k, (m, name) in enumerate(zip(entries, names))}
    out, k = {}, 0
    for key, n, pair, walls in KEYWORDS:
        if key not in keywords:
            continue
        ours = walls if wall else pair
        for j in range(n if n is not None else history):
            if ours is not None and k + j + 1 in column:
                out[ours[j]] = column[k + j + 1]
        k += n if n is not None else history
    return out


def _minimum_image(d, box: Box):
    """``d`` (n, 3) with each periodic axis' component the nearest image's."""
    for k in range(3):
        if box.periodic[k]:
            L = box.hi[k] - box.lo[k]
            d[:, k] -= L * np.round(d[:, k] / L)
    return d


class _Contacts:
    """The pair and (optional) mesh-wall contact dumps read in step: frames of the pair
    dump carrying the wall dump's frame of the same time step as ``walls``."""

    def __init__(self, pair: DumpReader, walls: DumpReader | None):
        self.pair, self.walls, self.path = pair, walls, pair.path

    def __getattr__(self, name):                # steps, from_time: the pair reader's
        return getattr(self.pair, name)

    def __setattr__(self, name, value):
        if name in ("steps", "from_time"):
            setattr(self.pair, name, value)
            if self.walls is not None:
                setattr(self.walls, name, value)
        else:
            super().__setattr__(name, value)

    def __iter__(self):
        walls = iter(self.walls) if self.walls is not None else None
        for fp in self.pair:
            if walls is not None:
                fw = next(walls, None)
                if fw is None or fw.timestep != fp.timestep:
                    found = "ends before" if fw is None else \
                        f"has timestep {fw.timestep} at line {fw.line} for"
                    raise UserError(f"{self.walls.path}: {found} timestep {fp.timestep} of "
                                    f"{fp.path or self.pair.path} (line {fp.line}); dump the "
                                    "pair and wall contacts at the same steps")
                fp.walls = fw
            yield fp


class LiggghtsDumps(LammpsDumps):
    """Frames of LIGGGHTS' dumps (see the module docstring); the options of
    :class:`~granavg.io.lammps_dumps.LammpsDumps` for the atoms, and

    Parameters
    ----------
    liggghts : str
        The keywords of the ``compute pair/gran/local`` line that wrote ``contacts``.
    wall_contacts : path, optional
        A ``dump local`` of ``compute wall/gran/local`` (mesh walls), at the same steps.
    wall_keywords : str, optional
        The keywords of that compute's line (default: ``liggghts``'s).
    """

    format_name = "liggghts"

    def __init__(self, atoms, contacts=None, *, liggghts=None, wall_contacts=None,
                 wall_keywords=None, **options):
        if options.get("contact_map"):
            raise ParameterError("contact_map", "{param} is for LAMMPS' pair/local; a "
                                 "LIGGGHTS dump's columns follow from {liggghts}")
        if options.get("dim") == 2:
            raise ParameterError("dim", "{param} 2: LIGGGHTS' contact columns are 3D")
        super().__init__(atoms, None, dim=3, **options)
        if wall_contacts is not None and contacts is None:
            raise ParameterError("wall_contacts", "{param} needs the pair contacts too "
                                 "({contacts}: the dump of compute pair/gran/local)")
        self.keywords = parse_keywords(liggghts)
        self.wall_keywords = parse_keywords(wall_keywords or liggghts, "wall_keywords") \
            if wall_contacts is not None else None
        if contacts is None:
            self.walls_said = "no contacts read"
            return
        if "id" not in self.amap:
            raise UserError(f"{atoms}: contacts need the atoms' id column")
        self.cmap = layout(self.keywords, dump_header(contacts)[0], contacts)
        self._need(self.cmap, contacts, ("id1", "id2"), "liggghts")
        self.wmap = None
        if wall_contacts is not None:
            self.wmap = layout(self.wall_keywords, dump_header(wall_contacts)[0],
                               wall_contacts, wall=True, param="wall_keywords")
            self._need(self.wmap, wall_contacts, ("id1", "cpx"), "wall_keywords")
            self.walls_said = (f"mesh walls: the contacts of {wall_contacts} (compute "
                               "wall/gran/local), wall code 1")
        else:
            self.walls_said = ("no wall contacts given (compute wall/gran/local, mesh walls "
                               "only): primitive walls' contacts cannot be dumped by "
                               "LIGGGHTS; their force enters only as per-atom columns "
                               "named bx by bz (fix wall/gran ... store_force yes: "
                               "f_force_ID[1] [2] [3])")
            log.info("%s: %s", contacts, self.walls_said)
        window = dict(steps=options.get("steps"), named_steps=options.get("named_steps",
                                                                          False))
        pair = DumpReader(contacts, sorted(set(self.cmap.values())), **window)
        walls = DumpReader(wall_contacts, sorted(set(self.wmap.values())), **window) \
            if self.wmap is not None else None
        self.contacts = _Contacts(pair, walls)

    @staticmethod
    def _need(cmap, path, names, param):
        force = all(f"f{x}" in cmap for x in _XYZ) or (
            all(f"fn{x}" in cmap for x in _XYZ))
        what = {"id1": "id", "id2": "id", "cpx": "pos (the contact point)"}
        missing = [what[n] for n in names if n not in cmap] + ([] if force else
                                                              ["force"])
        if missing:
            raise ParameterError(param, f"{literal(path)}: {{param}} has no {missing[0]}; "
                                 f"granavg needs id, force (or force_normal) and, for wall "
                                 "contacts, pos: add them to the compute line and dump "
                                 "again")

    def describe(self) -> dict:
        out = super().describe()
        out.update({"contact_columns": getattr(self, "cmap", None),
                    "liggghts": {"keywords": " ".join(self.keywords),
                                 "wall_keywords": " ".join(self.wall_keywords or ()),
                                 "wall_columns": getattr(self, "wmap", None),
                                 "walls": self.walls_said}})
        return out

    def _rows(self, fc, atoms, walls):
        box = Box.of(fc)
        if box.tilted:
            raise UserError(f"{fc.path}: a tilted box; granavg reads LIGGGHTS' contacts in "
                            "orthogonal boxes only")
        raw = fc.as_dict()
        pair = self._pair(fc, {k: raw[v] for k, v in self.cmap.items()}, atoms, box)
        fw = getattr(fc, "walls", None)
        if fw is None:
            return pair
        wraw = fw.as_dict()
        wall = self._wall(fw, {k: wraw[v] for k, v in self.wmap.items()}, atoms, box)
        return {k: np.concatenate([pair[k], wall[k]]) for k in pair}

    def _located(self, fc, c, atoms, names):
        rows = []
        for name in names:
            i, found = lookup(atoms["id"], c[name])
            if not found.all():
                k = int(np.argmin(found))
                raise UserError(f"{fc.path}:{fc.line + k}: atom id {int(c[name][k])} is not "
                                f"in {self.atoms.path} at timestep {fc.timestep}; use the "
                                "atom and contact dumps of one run")
            rows.append(i)
        return rows

    def _pair(self, fc, c, atoms, box):
        check_integers(fc.path, fc, c, ("id1", "id2"))
        i1, i2 = self._located(fc, c, atoms, ("id1", "id2"))
        if "x1" in c:
            d = np.column_stack([c[f"{x}1"] - c[f"{x}2"] for x in _XYZ])
        else:
            d = np.column_stack([atoms[x][i1] - atoms[x][i2] for x in _XYZ])
        r1, r2 = atoms["radius"][i1], atoms["radius"][i2]
        if all(f"fn{x}" in c for x in _XYZ):
            reach = sum(np.abs(atoms[x][i1]) + np.abs(atoms[x][i2]) for x in _XYZ)
            self._normal(fc, c, _minimum_image(d, box), reach)
        return self._converted(fc, c, _minimum_image(d, box), c["id1"], c["id2"], r1, r2,
                               np.zeros(len(i1), int))

    def _wall(self, fw, c, atoms, box):
        check_integers(fw.path, fw, c, ("id1", "mesh"))
        (i1,) = self._located(fw, c, atoms, ("id1",))
        x = np.column_stack([c[f"{a}1"] if f"{a}1" in c else atoms[a][i1] for a in _XYZ])
        d = _minimum_image(x - np.column_stack([c[f"cp{a}"] for a in _XYZ]), box)
        return self._converted(fw, c, d, c["id1"], c["mesh"], atoms["radius"][i1],
                               np.zeros(len(i1)), np.ones(len(i1), int))

    def _normal(self, fc, c, d, reach):
        """Refuse ``force_normal`` columns that are not along the line of centres d: the
        keywords name other columns (the total force, a torque). Allowed: the printed
        digits' error, :data:`CONSISTENCY` of the force and of the direction of d, whose
        centres (of size ``reach``) are rounded as finely."""
        fn = np.column_stack([c[f"fn{x}"] for x in _XYZ])
        length = np.sqrt(np.sum(d * d, axis=1))
        size = np.sqrt(np.sum(fn * fn, axis=1))
        across = np.cross(fn, d / np.maximum(length, 1e-300)[:, None])
        off = np.sqrt(np.sum(across * across, axis=1)) > \
            CONSISTENCY * size * (1 + reach / np.maximum(length, 1e-300))
        if off.any():
            k = int(np.flatnonzero(off)[0])
            raise ParameterError("liggghts", f"{fc.path}:{fc.line + k}: the normal force "
                                 f"({', '.join(f'{v:g}' for v in fn[k])}) is not along the "
                                 f"line of the centres (timestep {fc.timestep}); "
                                 f"{{param}} {literal(' '.join(self.keywords))} names other "
                                 "columns than the compute line that wrote the dump: give "
                                 "its keywords")

    def _converted(self, fc, c, d, id1, id2, r1, r2, wall2):
        """granavg's contact columns of one dump's rows (d = x_1 - x_2, shape (n, 3))."""
        length = np.sqrt(np.sum(d * d, axis=1))
        overlap = c.get("delta")
        if overlap is not None:
            off = np.abs(r1 + r2 - length - overlap) > CONSISTENCY * (r1 + r2)
            if off.any():
                k = int(np.flatnonzero(off)[0])
                raise UserError(f"{fc.path}:{fc.line + k}: delta {overlap[k]:g} but the "
                                f"radii and centres give {r1[k] + r2[k] - length[k]:g} "
                                f"(timestep {fc.timestep}); the keywords name the wrong "
                                "columns, or the atom dump is of another run")
        dist = length if overlap is None else r1 + r2 - overlap
        u = d / length[:, None]
        if all(f"fn{x}" in c for x in _XYZ):
            fn = np.column_stack([c[f"fn{x}"] for x in _XYZ])
            ft = np.column_stack([c[f"ft{x}"] for x in _XYZ]) \
                if all(f"ft{x}" in c for x in _XYZ) else None
        else:
            f = np.column_stack([c[f"f{x}"] for x in _XYZ])
            fn = np.sum(f * u, axis=1)[:, None] * u
            ft = f - fn
        zeros = np.zeros(len(d), int)
        return contact_columns(id1, id2, d, dist, fn, ft, zeros, wall2, r1, r2)


#: LIGGGHTS' own options.
PAIR_KEYWORDS = Option("liggghts", "{contacts} is LIGGGHTS' dump local of compute "
                  "pair/gran/local: the keywords of its compute line, any order, e.g. 'pos "
                  "id force delta' ('default': none given)", "str", metavar="KEYWORDS")
WALL_CONTACTS = Option("wall_contacts", "LIGGGHTS' dump local of compute wall/gran/local "
                       "(mesh walls' contacts), at the same steps", "str", metavar="DUMP")
WALL_KEYWORDS = Option("wall_keywords", "the keywords of the compute wall/gran/local line "
                       "(default: those of {liggghts})", "str", metavar="KEYWORDS",
                       cli_name="liggghts-walls")

FORMAT = Format("liggghts", "LIGGGHTS: dump custom (atoms) and dump local of compute "
                "pair/gran/local (contacts, named by its keywords) and wall/gran/local "
                "(mesh walls)", lambda path: False, LiggghtsDumps,
                (ATOM_MAP, DT, UNITS, DIM, INERTIA, PAIR_KEYWORDS, WALL_CONTACTS, WALL_KEYWORDS,
                 "steps", "named_steps"),
                ("liggghts", "wall_contacts", "wall_keywords"))
