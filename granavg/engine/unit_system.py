"""The units a profile is in: a system of base units and the unit of every column.

The engine computes in whatever consistent units its frames carry: lengths, times,
masses and forces of one system give stresses in force/length^2 (f l / V with V a
length^3), densities in mass/length^3 and so on. A :class:`UnitSystem` names the base
units so that the sidecar can say what each column is in; it converts nothing.
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

    def of(self, column: str) -> str:
        """The unit of a profile column (value or ``_sem``), ``1`` for pure numbers.

        >>> SI.of("sigma_rphi"), SI.of("v_x_sem"), SI.of("nu")
        ('Pa', 'm/s', '1')
        """
        name = column[:-4] if column.endswith("_sem") else column
        head = name.split("_")[0]
        if name.endswith("_power"):                       # power densities
            return f"{self.force}/({self.length}^2 {self.time})"
        if name.startswith(("temperature", "temperature_rot")):
            return f"({self.length}/{self.time})^2"
        if name == "spin_density":
            return f"{self.mass}/({self.length} {self.time})"
        if head in ("ekin", "erot", "dmu") and self.momentum_flux:
            return self.momentum_flux if head != "dmu" else f"{self.momentum_flux} {self.length}"
        if head in ("mu", "dmu"):                         # couple stresses
            return f"{self.force}/{self.length}"
        if head in ("ekin", "erot", "lever") or name.startswith(("couple_density",
                                                                  "boundary_couple")):
            return self.stress                            # energy and moment densities
        if head == "dsigma" and self.momentum_flux:
            return self.momentum_flux
        if head in ("sigma", "dsigma"):
            return self.stress
        if head in ("boundary", "body"):
            return f"{self.force}/{self.length}^3"
        if head == "rho":
            return f"{self.mass}/{self.length}^3"
        if head == "v":
            return f"{self.length}/{self.time}"
        if head == "omega":
            return f"rad/{self.time}"
        if head == "V":
            return self.volume
        if name in ("r", "x", "y", "z") or name.endswith(("_lo", "_hi")):
            return self.length
        return "1"          # nu, coordination, F_*, eps_*, counts

    def describe(self) -> dict:
        """The sidecar's ``unit_system`` entry."""
        return {"style": self.style, "length": self.length, "time": self.time,
                "mass": self.mass, "force": self.force, "stress": self.stress,
                "note": self.note, "momentum_flux": self.momentum_flux}

    def columns(self, names) -> dict:
        """The sidecar's ``columns`` entry: the unit of each column."""
        return {c: self.of(c) for c in names}


#: granavg's own scenes.
SI = UnitSystem("SI", "m", "s", "kg", "N", "Pa")
