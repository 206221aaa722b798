"""Which column of a LAMMPS dump is which of granavg's: the atom columns by name or alias
(``x`` or ``xu``, ``radius`` or ``diameter``, ...) and the contact columns of ``dump
local`` (granavg's own, the deck's, or ``pair/local`` + ``property/local`` named by a
map), the dump's header (columns and units) and its dimension (2 or 3)."""

from __future__ import annotations

import itertools
import logging
import re

import numpy as np

from granavg.errors import ParameterError, UserError, literal, named
from granavg.io import binary_dump, yaml_dump
from granavg.io.dumpfile import open_text
from granavg.io.formats import ATOM_MAP
from granavg.io.frames import row_at
from granavg.io.reader import DumpReader, first_file

log = logging.getLogger(__name__)

ATOM_ALIASES = {"x": ("x", "xu", "xs", "xsu"), "y": ("y", "yu", "ys", "ysu"),
                "z": ("z", "zu", "zs", "zsu"),
                "radius": ("radius", "diameter"), "vx": ("vx",), "vy": ("vy",), "vz": ("vz",),
                "omegax": ("omegax",), "omegay": ("omegay",), "omegaz": ("omegaz",),
                "id": ("id",), "type": ("type",), "mass": ("mass",),
                "fx": ("fx",), "fy": ("fy",), "fz": ("fz",),
                "bx": (), "by": (), "bz": ()}   # a body force on each atom: named only
#: Atom columns that exist only in 3D.
ONLY_3D = ("z", "vz", "omegax", "omegay", "fz", "bz")
SCALED = ("xs", "xsu", "ys", "ysu", "zs", "zsu")


def granavg_columns(dim: int) -> tuple:
    """granavg's own contact columns in ``dim`` dimensions (without the optional
    couple, :func:`couple_columns`)."""
    xyz = "xyz"[:dim]
    return ("id1", "id2", "wall", *(f"fn{x}" for x in xyz), *(f"ft{x}" for x in xyz),
            *(f"n{x}" for x in xyz), "overlap")


def couple_columns(dim: int) -> tuple:
    """The contact couple's columns (on atom 1, N m in SI): ``mz`` in 2D, ``mx my mz``
    in 3D."""
    return ("mz",) if dim == 2 else ("mx", "my", "mz")


def rolling_columns(dim: int) -> tuple:
    """``pair granular``'s outputs the couple is formed from: the rolling force
    ``frx fry [frz]`` (pair/local p5 p6 p7) and, in 3D, the twisting torque ``twist``
    (p9)."""
    return (*(f"fr{x}" for x in "xyz"[:dim]), *(("twist",) if dim == 3 else ()))


def parse_map(text) -> dict:
    """``a=b,c=d`` -> {a: b, c: d} (None: {}); one-line refusal for a malformed map."""
    return ATOM_MAP.parse(text or "")


def dump_header(path):
    """The column names of a dump's first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line, and
    its ``ITEM: UNITS`` as ``(style, "file:line")`` (None if the dump does not say)."""
    path = first_file(path)
    if binary_dump.is_binary(path):
        return binary_dump.header(path)
    if yaml_dump.is_yaml(path):
        return yaml_dump.header(path)
    try:
        with open_text(path, "rb") as fh:
            return _columns_line(fh, path)
    except (OSError, EOFError) as exc:
        raise UserError(f"{path}: not readable ({exc})") from None


def _columns_line(fh, path):
    """Read a text dump up to its first ``ITEM: ATOMS`` / ``ITEM: ENTRIES`` line (within
    its first 1000 lines): (its column names, the ``ITEM: UNITS`` before it or None)."""
    units, previous = None, ""
    for k, raw in enumerate(fh):
        line = raw.decode("ascii", "replace")
        if previous.startswith("ITEM: UNITS"):
            units = (line.strip(), f"{path}:{k + 1}")
        if line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
            return line.split()[2:], units
        if k > 1000:
            break
        previous = line
    raise UserError(f"{path}: no 'ITEM: ATOMS' or 'ITEM: ENTRIES' header; give a LAMMPS "
                    "dump custom (atoms) or dump local (contacts)")


#: The first frame's rows read to tell a 3D dump at once, by z differing among them
#: (:func:`dimension`; where they all share one z, the whole frame is read).
Z_SAMPLE = 1000


def _first_z(path, zcol, rows: int = Z_SAMPLE) -> np.ndarray:
    """The z of the first ``rows`` atoms of a text dump's first frame, read from its
    text; empty where the frame holds none, the dump is not text or the rows do not
    read (the whole frame's reading then says why)."""
    path = first_file(path)
    if binary_dump.is_binary(path) or yaml_dump.is_yaml(path):
        return np.empty(0)
    try:
        with open_text(path, "rb") as fh:
            names, _ = _columns_line(fh, path)
            k = names.index(zcol)
            z = []
            for raw in itertools.islice(fh, rows):
                if raw.startswith(b"ITEM:"):
                    break
                z.append(float(raw.split()[k]))
        return np.array(z)
    except (OSError, EOFError, UserError, ValueError, IndexError):
        return np.empty(0)


def _one_each(explicit: dict, param: str) -> None:
    """Refuse a map that names one dump column for two of granavg's columns."""
    seen = {}
    for ours, col in explicit.items():
        if col in seen:
            raise ParameterError(param, f"{{param}} names {literal(col)} for both "
                                 f"{seen[col]} and {ours}; each needs a column of its own")
        seen[col] = ours


def resolve_atoms(path, explicit: dict, dim: int) -> dict:
    """Our atom name -> the dump's column, by the explicit map, then by alias."""
    names, _ = dump_header(path)
    unknown = [k for k in explicit if k not in ATOM_ALIASES]
    if unknown:
        raise ParameterError("atom_map", f"{{param}} {literal(unknown[0])}=...: granavg has "
                             f"no atom column {literal(repr(unknown[0]))}; name one of "
                             f"{' '.join(ATOM_ALIASES)}")
    _one_each(explicit, "atom_map")
    out = {}
    for ours, aliases in ATOM_ALIASES.items():
        if ours in explicit:
            if explicit[ours] not in names:
                raise UserError(f"{path}: column {explicit[ours]!r} (for {ours}) is not in the "
                                f"dump (columns: {' '.join(names)})")
            out[ours] = explicit[ours]
            continue
        if dim == 2 and ours in ONLY_3D:
            continue
        found = [a for a in aliases if a in names]
        if found:
            out[ours] = found[0]
    for need in ("x", "y", *(("z",) if dim == 3 else ()), "radius"):
        if need not in out:
            raise ParameterError("atom_map", f"{literal(path)}: no column for {need} "
                                 f"(columns: {literal(' '.join(names))}); dump it, or name "
                                 f"it with {{param}} {need}=COLUMN")
    return out


def resolve_contacts(path, explicit: dict, dim: int) -> dict:
    """Our contact name -> the dump's column (granavg's, the deck's raw, or a map)."""
    names, _ = dump_header(path)
    own = granavg_columns(dim)
    if not explicit and all(c in names for c in own):
        return {c: c for c in (*own, *couple_columns(dim)) if c in names}
    xyz = "xyz"[:dim]
    known = ("id1", "id2", *(f"d{x}" for x in xyz), "dist", *(f"fn{x}" for x in xyz),
             *(f"ft{x}" for x in xyz), "force", *couple_columns(dim), *rolling_columns(dim))
    unknown = [k for k in explicit if k not in known]
    if unknown:
        hint = " (a 2D dump: no z components)" if dim == 2 and unknown[0].endswith("z") \
            and unknown[0][:-1] + "x" in known else ""
        raise ParameterError("contact_map", f"{{param}} {literal(unknown[0])}=...: granavg "
                             f"has no contact column {literal(repr(unknown[0]))}{hint}; name "
                             f"one of {' '.join(known)}")
    out = {k: v for k, v in explicit.items()}
    for ours in known:
        if ours not in out and ours in names:
            out[ours] = ours
    for ours, col in out.items():
        if col not in names:
            raise UserError(f"{path}: column {col!r} (for {ours}) is not in the dump "
                            f"(columns: {' '.join(names)})")
    _check_couple(path, out, dim)
    _one_each(explicit, "contact_map")
    missing = [c for c in ("id1", "id2", *(f"d{x}" for x in xyz), "dist") if c not in out]
    if not all(f"fn{x}" in out for x in xyz) and "force" not in out:
        missing.append("force (or " + ", ".join(f"fn{x}" for x in xyz) + ")")
    if missing:
        example = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
                   "ftx=c_pl[5],fty=c_pl[6]") if dim == 2 else (
                   "id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
                   "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]")
        unnamed = re.compile(r"^c_.+\[\d+\]$")
        if not explicit and names and all(unnamed.match(n) for n in names):
            raise ParameterError("contact_map", f"{literal(path)}: no column for "
                                 f"{missing[0]}: its columns ({names[0]} .. {names[-1]}) are "
                                 "unnamed; LIGGGHTS' compute pair/gran/local: give its "
                                 "keywords ({liggghts} 'pos id force delta'); LAMMPS' "
                                 "pair/local and property/local: map them with {param}, e.g. "
                                 f"{literal(example)}")
        raise ParameterError("contact_map", f"{literal(path)}: no column for {missing[0]}; "
                             "map the pair/local and property/local columns with {param}, "
                             f"e.g. {literal(example)}")
    return out


def _check_couple(path, cmap, dim):
    """A contact couple is mapped whole: all of its own columns, or all of the rolling
    force's (the twisting torque may come with it, or alone), not both."""
    own = [c for c in couple_columns(dim) if c in cmap]
    roll = [c for c in rolling_columns(dim)[:dim] if c in cmap]
    if (own and roll) or 0 < len(own) < len(couple_columns(dim)) or 0 < len(roll) < dim or \
            (own and "twist" in cmap):
        given = [c for c in (*couple_columns(dim), *rolling_columns(dim)) if c in cmap]
        raise ParameterError(
            "contact_map", f"{literal(path)}: the contact couple needs all of "
            f"{literal(' '.join(couple_columns(dim)))} (the couple on atom 1) or of "
            f"{literal(' '.join(rolling_columns(dim)))} (pair granular's p5 p6"
            f"{' p7, p9' if dim == 3 else ''}), not {literal(' '.join(given))}")


def dimension(path, explicit_map, dim=None) -> tuple:
    """The dump's dimension and why: ``dim`` if given (3 needs a z column), else 3 where
    the z coordinates of the first frame that holds atoms differ, 2 where there is no z
    column or they all share one (a 2D LAMMPS run writes z = 0). Frames with no atom (a
    pour before its first insertion) are passed over.

    Returns
    -------
    dim : int
    why : str
        The reason, for messages that depend on it ("has no z column", ...).
    """
    names, _ = dump_header(path)
    zcol = explicit_map.get("z") or next((a for a in ATOM_ALIASES["z"] if a in names), None)
    if dim not in (None, 2, 3):
        raise ParameterError("dim", f"{{param}} {dim}: give 2 or 3")
    if dim == 3 and zcol is None:
        raise ParameterError("dim", f"{literal(path)}: {{param}} 3 needs a z column "
                             f"(columns: {literal(' '.join(names))}); dump z, or name it "
                             "with {atom_map} z=COLUMN")
    if dim == 3 or (dim is not None and zcol is None):
        return dim, "given"
    if zcol is None:
        return 2, f"{first_file(path)} has no z column"
    if dim is None:
        z = _first_z(path, zcol)
        if len(z) and np.ptp(z) > 0:
            return 3, "z differs"               # the whole first frame not parsed for it
    frame = next((f for f in DumpReader(path, [zcol], readers=1) if len(f.data)), None)
    if frame is None:
        raise UserError(f"{path}: no frame holds an atom; give a dump of a run with atoms")
    z = frame.column(zcol)
    if dim == 2:
        if np.ptp(z) > 0:
            log.warning(named("%s: {dim} 2, but the atoms' z differ (by up to %g in the "
                              "first frame with atoms): they are averaged as disks in the "
                              "x-y plane"), path, np.ptp(z))
        return 2, "given"
    if np.ptp(z) > 0:
        return 3, "z differs"
    return 2, (f"every atom of the first frame with atoms ({row_at(frame.path, frame, 0)}, "
               f"timestep {frame.timestep}) has z = {z[0]:g}")
