"""LAMMPS' ``units`` styles as :class:`~granavg.engine.unit_system.UnitSystem`s.

A dump keeps the units it was written in: granavg converts nothing, it names them. The
style comes from the dump's ``ITEM: UNITS`` header (``dump_modify ... units yes``; LAMMPS
writes it in the first frame only) or from ``--units``. Stresses come out as
force/length^2 of the style (f l / V): for ``real`` and ``metal`` that is
(kcal/mol)/A^3 and eV/A^3, not LAMMPS' thermo pressure units (atm, bar).
"""

from __future__ import annotations

from granavg.engine.unit_system import UnitSystem
from granavg.errors import ParameterError, UserError, literal

#: style -> (length, time, mass, force, force/length^2), from LAMMPS' ``units`` page.
_STYLES = {
    "si": ("m", "s", "kg", "N", "Pa"),
    "cgs": ("cm", "s", "g", "dyne", "dyne/cm^2"),
    "lj": ("sigma", "tau", "m", "epsilon/sigma", "epsilon/sigma^3"),
    "real": ("Angstrom", "fs", "g/mol", "(kcal/mol)/Angstrom", "(kcal/mol)/Angstrom^3"),
    "metal": ("Angstrom", "ps", "g/mol", "eV/Angstrom", "eV/Angstrom^3"),
    "electron": ("Bohr", "fs", "amu", "Hartree/Bohr", "Hartree/Bohr^3"),
    "micro": ("um", "us", "pg", "pg um/us^2", "pg/(um us^2)"),
    "nano": ("nm", "ns", "ag", "ag nm/ns^2", "ag/(nm ns^2)"),
}
_NOTES = {"lj": "LAMMPS reduced units (sigma, tau, m, epsilon of the run)"}
#: Styles whose mass (length/time)^2 is not their energy unit (LAMMPS converts with
#: mvv2e): the dynamic stress m v v / V is not in their stress unit, nor m g a force.
MIXED = ("real", "metal", "electron")
#: What frames in a dump that does not say its units are labelled.
UNSTATED = UnitSystem(
    "unstated", "length", "time", "mass", "force", "force/length^2",
    "the dump does not say its units (no ITEM: UNITS; write it with 'dump_modify ID units "
    "yes', or name the units style when averaging): every value is in the units the dump "
    "was written in")


def lammps_units(style: str, where: str | None = None) -> UnitSystem:
    """The unit system of LAMMPS ``units STYLE``; a one-line error for an unknown style
    (naming ``where`` it was read, file:line, or the ``units`` parameter)."""
    key = str(style).strip().lower()
    if key not in _STYLES:
        what = f"unknown LAMMPS units style {style!r}; choose from {', '.join(_STYLES)}"
        if where is None:
            raise ParameterError("units", "{param}: " + literal(what))
        raise UserError(f"{where}: {what}")
    length, time, mass, force, stress = _STYLES[key]
    note = _NOTES.get(key, f"LAMMPS 'units {key}'")
    flux = f"{mass} ({length}/{time})^2/{length}^3" if key in MIXED else None
    if flux:
        note += ("; the dynamic stress is in mass (length/time)^2 / length^3, not the "
                 "stress unit, so the balance of forces is not formed")
    return UnitSystem("SI" if key == "si" else key, length, time, mass, force, stress, note,
                      flux)


def choose_units(header, option) -> UnitSystem:
    """The units of a dump: its header's (``(style, "file:line")`` or None) and the
    ``units`` parameter (str or None) must agree; neither: :data:`UNSTATED`."""
    if header is not None:
        style, where = header
        found = lammps_units(style, where)
        if option is not None and lammps_units(option).style != found.style:
            raise ParameterError("units", f"{literal(where)}: the dump says 'units "
                                 f"{literal(style)}' but {{param}} is {literal(option)}; drop "
                                 "{param} (the dump's header is what LAMMPS ran)")
        return found
    return lammps_units(option) if option is not None else UNSTATED
