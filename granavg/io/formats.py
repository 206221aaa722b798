"""The input formats: each module of :mod:`granavg.io` that defines ``FORMAT`` (a
:class:`Format`) is one, found here without being listed anywhere else, so a new format
is one new file in ``granavg/io``.

A format turns an atoms file and, optionally, a contacts file into a *frame source*
(:mod:`granavg.io.frames`): an iterable of :class:`~granavg.io.frames.Frame` with
``units``, ``dropped``, ``format_name``, ``describe()`` (the options it was opened with,
for the sidecar) and ``box()`` (x and y bounds of the first frame, for cells that default
to it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from granavg.engine.plugins import Registry
from granavg.errors import ParameterError, UserError, literal


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
    options : tuple of str
        The keyword options ``open`` takes (others given are refused).
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


#: The formats, by name.
FORMATS = Registry("granavg.io", "FORMAT", lambda f: isinstance(f, Format), lambda f: f.name)


def available() -> dict:
    """Every format, by name (modules of granavg.io that define ``FORMAT``)."""
    return FORMATS.all()


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
    foreign = [k for k in given if k not in chosen.options]
    if foreign:
        raise UserError(f"{atoms}: the {chosen.name} format takes no {foreign[0]} option "
                        f"(it takes: {', '.join(chosen.options) or 'none'})")
    return chosen.open(atoms, contacts, **given)
