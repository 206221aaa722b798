"""The units a profile is in: a system of base units and the unit of every column.

The engine computes in whatever consistent units its frames carry: lengths, times,
masses and forces of one system give stresses in force/length^2 (f l / V with V a
length^3), densities in mass/length^3 and so on. A :class:`UnitSystem` names the base
units so that the sidecar can say what each column is in (each quantity declares its
physical dimension, :attr:`granavg.engine.quantities.Quantity.unit`); it converts
nothing.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class UnitSystem:
    """Names of a consistent system's base units and of its derived stress unit.

    Attributes
    ----------
    style : str
        Short name (LAMMPS' ``units`` style where there is one, e.g. ``si``, ``lj``).
    length, time, mass, force : str
        Unit names.
    stress : str
        Name of force/length^2 (stress, pressure) in this system.
    note : str
        One line on where the units come from, for the sidecar.
    momentum_flux : str, optional
        The unit of m v v / V where it is not the stress unit (LAMMPS' real, metal and
        electron styles: mass (length/time)^2 is not their energy unit); None where it is.
    """

    style: str
    length: str
    time: str
    mass: str
    force: str
    stress: str
    note: str = ""
    momentum_flux: str | None = None

    @property
    def label(self) -> str:
        """One line for the sidecar's ``units`` entry."""
        base = (f"{self.style} ({self.length}, {self.time}, {self.mass}, {self.force}, "
                f"{self.stress})")
        return f"{base}; {self.note}" if self.note else base

    @property
    def volume(self) -> str:
        return f"{self.length}^3"

    def unit(self, dimension: str) -> str:
        """The unit of a physical dimension written in the system's named units:
        ``{length}``, ``{time}``, ``{mass}``, ``{force}``, ``{stress}`` (force/length^2),
        ``{momentum_flux}`` (mass (length/time)^2 / length^3: the stress unit where that
        is the same), ``{couple_flux}`` (momentum_flux length), or ``1``.

        >>> SI.unit("{force}/{length}^3"), SI.unit("1/{time}"), SI.unit("{stress}/{length}")
        ('N/m^3', '1/s', 'Pa/m')
        """
        flux = self.momentum_flux or self.stress
        couple = (f"{self.momentum_flux} {self.length}" if self.momentum_flux else
                  f"{self.force}/{self.length}")
        return dimension.format(length=self.length, time=self.time, mass=self.mass,
                                force=self.force, stress=self.stress, momentum_flux=flux,
                                couple_flux=couple)

    def describe(self) -> dict:
        """The sidecar's ``unit_system`` entry."""
        return {"style": self.style, "length": self.length, "time": self.time,
                "mass": self.mass, "force": self.force, "stress": self.stress,
                "note": self.note, "momentum_flux": self.momentum_flux}

#: granavg's own scenes.
SI = UnitSystem("SI", "m", "s", "kg", "N", "Pa")
