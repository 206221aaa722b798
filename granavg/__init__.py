"""granavg: from DEM simulations of granular matter to continuum fields.

Implements Luding et al., Comput. Methods Appl. Mech. Engrg. 191 (2001) 21-28. Layers,
data flowing one way: :mod:`granavg.sim` (LAMMPS runs), :mod:`granavg.io` (file
formats -> frames), :mod:`granavg.engine` (frames -> profiles), :mod:`granavg.analysis`
(profiles -> checks, figures, report), wired only by :mod:`granavg.pipeline`; the CLI is
a shell around it. Importing granavg loads neither LAMMPS nor MPI
(:func:`granavg.sim.lammps_session.load_lammps` does, when a run needs them).
"""

__version__ = "0.1.0"
