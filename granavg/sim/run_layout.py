"""What a run writes, shared by the LAMMPS driver and the reference DEM: dump names, the
dump schedule and the shear progress bar (SI units)."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from tqdm.auto import tqdm

from granavg.sim.scene import Derived, Scene

ATOMS = "atoms.{ext}"
CONTACTS = "contacts.{ext}"
CONTACTS_RAW = "contacts_raw.{ext}"
#: The packing at the end of shear (LAMMPS data file; ``--start`` shears it further).
SHEARED = "sheared.data"


def _deck() -> Path:
    """The Couette deck: ``lammps_inputs/couette.lmp`` of a source tree, or the copy
    inside the installed wheel (package ``granavg.lammps_inputs``)."""
    source = Path(__file__).resolve().parents[2] / "lammps_inputs" / "couette.lmp"
    if source.exists():
        return source
    from importlib.resources import files
    return Path(str(files("granavg.lammps_inputs") / "couette.lmp"))



DECK = _deck()


def cmdargs(out, variables, omp) -> list:
    args = ["-log", str(out / "log.lammps")]
    if omp > 1:
        args += ["-sf", "omp", "-pk", "omp", str(omp)]
    for key, value in variables.items():
        if key != "restart_step":
            args += ["-var", key, value]
    return args


def dump_ext(scene: Scene) -> str:
    """The dumps' extension: ``dump.gz`` or, with ``gzip`` off, ``dump``."""
    return "dump.gz" if scene.gzip else "dump"


def is_dump_step(step, d: Derived) -> bool:
    """Whether the deck dumps at this shear step."""
    return step >= d.n_dump_start and step % d.dump_every == 0


@contextmanager
def shear_bar(derived: Derived, start_step, progress):
    """A tqdm bar over simulated shear time (s), hidden off a terminal."""
    bar = tqdm(total=round(derived.n_shear * derived.dt, 6), initial=start_step * derived.dt,
               unit="s", desc="shear (simulated s)", disable=None if progress is None
               else not progress, bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s "
               "[{elapsed}<{remaining}]")
    try:
        yield bar
    finally:
        bar.close()
