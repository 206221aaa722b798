"""Simulation: the scene and contact law, the LAMMPS deck driver (embedded, MPI; a
running LAMMPS hands its frames to a sink it is given), realisations on dask and the
reference DEM. It averages nothing itself."""
