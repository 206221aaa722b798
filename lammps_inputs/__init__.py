"""The LAMMPS decks, shipped inside granavg's wheel as ``granavg.lammps_inputs``; in a
source tree they stay in ``lammps_inputs/`` and run with plain ``lmp -in``."""
