"""The input formats: each module of :mod:`granavg.io` that defines ``FORMAT`` (a
:class:`Format`) is one, found here without being listed anywhere else, so a new format
is one new file in ``granavg/io``.

A format turns an atoms file and, optionally, a contacts file into a *frame source*
(:mod:`granavg.io.frames`): an iterable of :class:`~granavg.io.frames.Frame` with
``units``, ``dropped``, ``format_name``, ``describe()`` (the options it was opened with,
for the sidecar) and ``box()`` (x and y bounds of the first frame, for cells that default
to it).

A format declares the options it takes (:class:`~granavg.engine.plugins.Option`: name,
help, kind, unit, flag); :func:`options` gathers them, and the command line's flags,
``--format``'s help and :func:`granavg.average`'s keywords follow from them. Options
that several formats take are declared once, here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from granavg.engine.plugins import Option, Registry
from granavg.errors import ParameterError, literal


#: Options several formats take.
ATOM_MAP = Option("atom_map", "our name=dump column, e.g. omegaz=c_spin[3],radius=c_r "
                  "(others by name or alias)", "map", metavar="MAP", cli_name="atom-columns")
CONTACT_MAP = Option(
    "contact_map", "our name=dump column of each contact column, for 2D pair/local + "
    "property/local e.g. id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],"
    "force=c_pl[4],ftx=c_pl[5],fty=c_pl[6] (3D: dz and ftz too). The contact couple as mz "
    "(3D: mx my mz) or as pair granular's rolling force frx fry [frz] (p5 p6 p7) and "
    "twisting torque twist (p9); without them the couples are taken as zero", "map",
    metavar="MAP", cli_name="contact-columns")
UNITS = Option("units", "LAMMPS units style of the dumps (si, lj, real, metal, cgs, "
               "electron, micro, nano) when they have no ITEM: UNITS header (dump_modify "
               "units yes); only labels the outputs", "str", metavar="STYLE")
DIM = Option("dim", "2 (disks) or 3 (spheres); default from the dump: 3 where the atoms' "
             "z differ", "int", choices=(2, 3))
DT = Option("dt", "time step, for files that hold no time (LAMMPS dumps without ITEM: "
            "TIME, VTK files; Yade's O.dt)", unit="the data's time unit")
WALL_TYPES = Option("wall_types", "atom types that are walls: left out of the packing, "
                    "their contacts with disks kept", "int", nargs="+", metavar="T")
INERTIA = Option("inertia", "how 2D particles turn (their moment of inertia for the spin "
                 "fields): disk, m a^2/2, or sphere, 2/5 m a^2 (LAMMPS' fix nve/sphere "
                 "without disc); default: spheres where the mass column scales as a^3, else "
                 "disks; 3D: spheres", "str", choices=("disk", "sphere"))


@dataclass(frozen=True)
class Format:
    """One input format.

    Attributes
    ----------
    name : str
        What ``--format`` calls it.
    description : str
    claims : callable
        ``claims(path) -> bool``: whether a file looks like this format.
    open : callable
        ``open(atoms, contacts=None, **options)`` -> frame source.
    options : tuple of Option or str
        The keyword options ``open`` takes (others given are refused): the user's, as
        :class:`~granavg.engine.plugins.Option` (the command line's flags and the API's
        keywords follow from them), and internal ones by name (``steps``, a dask
        worker's window).
    selected_by : tuple of str
        Options that name this format when no format is named (their files look like
        another format's: LIGGGHTS' atoms are LAMMPS dumps).
    """

    name: str
    description: str
    claims: Callable
    open: Callable
    options: tuple = ()
    selected_by: tuple = ()

    @property
    def accepts(self) -> tuple:
        """The names of every option ``open`` takes."""
        return tuple(o if isinstance(o, str) else o.name for o in self.options)


#: The formats, by name.
FORMATS = Registry("granavg.io", "FORMAT", lambda f: isinstance(f, Format), lambda f: f.name,
                   group="granavg.formats")


def available() -> dict:
    """Every format, by name (modules of granavg.io that define ``FORMAT``)."""
    return FORMATS.all()


def options() -> dict:
    """The user's options of every format, by name (each declared once: two formats
    that take one option share its declaration)."""
    out = {}
    for f in available().values():
        for o in f.options:
            if isinstance(o, str):
                continue
            if out.get(o.name, o) != o:
                raise ValueError(f"format {f.name!r} declares option {o.name!r} anew; "
                                 "share the declaration of granavg.io.formats")
            out[o.name] = o
    return out


def catalogue() -> str:
    """The formats in words, for ``--format``'s help."""
    return ", ".join(sorted(available()))


def choose(atoms, fmt: str | None = None, given=()) -> Format:
    """The format ``fmt``; else the one an option in ``given`` selects
    (:attr:`Format.selected_by`); else the first that claims the atoms file (one-line
    refusals)."""
    known = available()
    selected = [f for f in known.values() if any(k in f.selected_by for k in given)]
    if fmt is None and selected:
        return selected[0]
    if fmt is not None:
        if fmt not in known:
            raise ParameterError("fmt", f"{{param}} {literal(fmt)}: unknown; choose from "
                                 f"{', '.join(sorted(known))}")
        return known[fmt]
    claiming = [f for f in known.values() if f.claims(Path(atoms))]
    if not claiming:
        raise ParameterError("fmt", f"{literal(atoms)}: not a format granavg reads "
                             f"({', '.join(sorted(known))}); name the format ({{param}} "
                             "NAME), or give a LAMMPS dump")
    return claiming[0]


def open_frames(atoms, contacts=None, *, fmt: str | None = None, **options):
    """The frame source of ``atoms`` (and ``contacts``) in format ``fmt``, or in the
    first format that claims the atoms file; options left at None are not passed."""
    given = {k: v for k, v in options.items() if v not in (None, (), [], {})}
    chosen = choose(atoms, fmt, given)
    foreign = [k for k in given if k not in chosen.accepts]
    if foreign:
        takes = [f"{{{o.name}}}" for o in chosen.options if not isinstance(o, str)]
        raise ParameterError(foreign[0], f"{literal(atoms)}: the {chosen.name} format takes "
                             f"no {{param}} option (it takes: {', '.join(takes) or 'none'})")
    return chosen.open(atoms, contacts, **given)
