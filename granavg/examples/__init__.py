"""Small real data sets shipped with granavg, for the documentation's examples and a
first average: LAMMPS runs of decks in the repository, made by
``workflows/make_examples.py`` (SI units).

>>> from granavg import examples
>>> examples.couette_2d.run.name       # a run directory of granavg simulate
'couette_2d'
>>> sorted(examples.pile_3d.contact_map)[:3]
['dist', 'dx', 'dy']

- :data:`couette_2d`: the Couette cell of the test suite (290 disks between R_i = 0.04 m
  and R_o = 0.0826 m, the inner ring turning at 0.5 rad/s), 13 frames every 0.25 s of
  shear: a run directory (manifest and dumps), as ``granavg simulate`` writes it.
- :data:`pile_3d`: the last 3 frames of a pile of about 750 spheres at rest on a floor
  (tests/decks/pile_3d_si.lmp, k_n = 20 N/m), periodic in x and y, dumped as a user
  dumps (default %g, ``compute pair/local`` + ``property/local`` contacts), with the
  column map that names its contact columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

DATA = Path(__file__).parent / "data"


@dataclass(frozen=True)
class Example:
    """A shipped data set: its dumps (and run directory), the column map of its contact
    dump where it needs one, and what it is."""

    name: str
    atoms: Path
    contacts: Path
    about: str
    run: Path | None = None
    contact_map: dict = field(default_factory=dict)


couette_2d = Example(
    "couette_2d", DATA / "couette_2d" / "atoms.dump.gz",
    DATA / "couette_2d" / "contacts.dump.gz",
    "2D Couette cell, 290 disks, 13 frames of shear (the paper-hooke preset of granavg "
    "simulate)",
    run=DATA / "couette_2d")

pile_3d = Example(
    "pile_3d", DATA / "pile_3d" / "atoms.dump.gz", DATA / "pile_3d" / "contacts.dump.gz",
    "3D pile of about 750 spheres at rest, periodic in x and y, 3 frames "
    "(tests/decks/pile_3d_si.lmp)",
    contact_map={"id1": "c_pp[1]", "id2": "c_pp[2]", "dist": "c_pl[1]", "dx": "c_pl[2]",
                 "dy": "c_pl[3]", "dz": "c_pl[4]", "force": "c_pl[5]", "ftx": "c_pl[6]",
                 "fty": "c_pl[7]", "ftz": "c_pl[8]"})
