"""Runs under ``mpirun``: plain ``lmp`` ranks running the whole deck (its raw contact
dump converted afterwards), or granavg's own python ranks for in-situ averaging."""

from __future__ import annotations

import logging
import shlex
import subprocess
import sys
import time
from pathlib import Path

from granavg.errors import LammpsError
from granavg.io.contacts import (COLUMNS, FORMAT, RAW_COLUMNS, RAW_ROLLING, contact_table,
                                 radius_by_id)
from granavg.io.dumpfile import open_text, write_frame
from granavg.io.lammps_data import read_data
from granavg.io.reader import DumpReader
from granavg.sim.lammps_session import executable, lammps_env
from granavg.sim.run_layout import (CONTACTS, CONTACTS_RAW, DECK, SHEARED, cmdargs, dump_ext,
                                   shear_bar)
from granavg.sim.run_monitor import Overlaps
from granavg.sim.scene import Derived

log = logging.getLogger(__name__)


def run_mpi_python(out, derived: Derived, np_ranks, progress, module):
    """``mpirun -np N python -m MODULE OUT``: LAMMPS and granavg on every rank (the
    in-situ sink's rank entry, e.g. :mod:`granavg.pipeline.mpi_rank`, gathers each frame
    to rank 0)."""
    cmd = [executable("mpirun"), "-np", str(np_ranks), sys.executable, "-m", module,
           str(out), "quiet" if progress is False else "bar"]
    log.info("running %s", shlex.join(cmd))
    proc = subprocess.run(cmd, env=lammps_env(), stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["no message"]
        raise LammpsError(f"mpirun granavg ranks exited with code {proc.returncode}: "
                          f"{tail[0]} (details in {out / 'log.lammps'})")


def run_mpi(out, derived: Derived, variables, np_ranks, omp, progress):
    cmd = [executable("mpirun"), "-np", str(np_ranks), executable("lmp"),
           "-in", str(out / "deck" / DECK.name), *cmdargs(out, variables, omp)]
    log.info("running %s", shlex.join(cmd))
    logfile = out / "log.lammps"
    start = int(variables["restart_step"])
    with open(out / "mpirun.out", "ab") as sink, shear_bar(derived, start, progress) as bar:
        proc = subprocess.Popen(cmd, stdout=sink, stderr=subprocess.STDOUT, env=lammps_env())
        try:
            done = start
            while proc.poll() is None:
                time.sleep(0.5)
                step = _last_thermo_step(logfile)
                if step is not None and step > done:
                    bar.update((step - done) * derived.dt)
                    done = step
        except BaseException:
            proc.terminate()
            proc.wait()
            raise
    if proc.returncode != 0:
        raise LammpsError(f"mpirun lmp exited with code {proc.returncode}: "
                          f"{_last_error(out)} (details in {logfile})")
    if derived.scene.contacts:
        convert_raw_contacts(out / CONTACTS_RAW.format(ext=dump_ext(derived.scene)),
                             out / CONTACTS.format(ext=dump_ext(derived.scene)), derived)


def convert_raw_contacts(raw_path: Path, out_path: Path, derived: Derived) -> None:
    """Convert a LAMMPS-written ``contacts_raw`` dump into granavg's contact dump.

    Appends to ``out_path`` (a resumed run continues the file) and removes the raw file.
    The radii come from the run's ``sheared.data`` (sizes do not change during shear).
    """
    sheared = read_data(out_path.parent / SHEARED)
    radius = radius_by_id(sheared["id"], sheared["radius"])
    overlaps = Overlaps(derived)
    with open_text(out_path, "at") as fh:
        for frame in DumpReader(raw_path):
            names = RAW_COLUMNS + [c for c in RAW_ROLLING if c in frame.columns]
            raw = frame.data[:, [frame.columns.index(c) for c in names]]
            table = contact_table(raw, radius)
            overlaps.add(table, frame.timestep)
            write_frame(fh, frame.timestep, frame.time, COLUMNS, table, frame.box, FORMAT)
    raw_path.unlink()
    overlaps.record(out_path.parent)


def _last_thermo_step(logfile: Path):
    try:
        with open(logfile, "rb") as fh:
            fh.seek(max(0, logfile.stat().st_size - 4096))
            tail = fh.read().decode(errors="replace").splitlines()
    except FileNotFoundError:
        return None
    for line in reversed(tail):
        parts = line.split()
        if len(parts) == 4 and parts[0].isdigit():
            return int(parts[0])
    return None


def _last_error(out) -> str:
    text = ""
    for name in ("log.lammps", "mpirun.out"):
        path = out / name
        if path.exists():
            text += path.read_text(errors="replace")
    errors = [line.strip() for line in text.splitlines() if "ERROR" in line]
    return errors[-1] if errors else "no ERROR line in the log"
