"""One MPI rank of an in-situ run: ``mpirun -np N python -m granavg.pipeline.mpi_rank RUN_DIR``.

Started by :func:`granavg.sim.simulate.simulate` (``--np N --average ...``, module
:attr:`InSituAverage.RANK_MODULE`); every rank runs LAMMPS through its Python module on
the shared communicator, rank 0 gathers each frame, writes the contact dump and feeds
the in-situ averages. The run directory's manifest says what to run.
"""

from __future__ import annotations

import sys
from pathlib import Path

from granavg.io.run_directory import read_manifest
from granavg.pipeline.insitu import InSituAverage
from granavg.sim.embedded import run_embedded
from granavg.sim.lammps_session import load_lammps
from granavg.sim.scene import Scene
from granavg.sim.simulate import deck_variables


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0])
    load_lammps()                                   # preloads libmpi for mpi4py too
    from mpi4py import MPI

    manifest = read_manifest(out)
    derived = Scene.from_dict(manifest["scene"]).derive()
    variables = deck_variables(out, derived, embedded=True, resume=None,
                                start=manifest.get("start"))
    progress = None if "bar" in argv[1:] else False      # as granavg.sim.mpi says
    run_embedded(out, derived, manifest, variables, manifest["execution"]["omp"], progress,
                 comm=MPI.COMM_WORLD, insitu=InSituAverage)
    return 0


if __name__ == "__main__":
    sys.exit(main())
