"""Simulation: the scene and contact law, the LAMMPS deck driver (embedded, MPI, in situ),
ensembles of realisations and the reference DEM."""
