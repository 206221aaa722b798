"""The one layer that wires the others: frame sources (:mod:`granavg.io`, a running
LAMMPS of :mod:`granavg.sim`), cells and averaging (:mod:`granavg.engine`), outputs and
analysis (:mod:`granavg.analysis`), for every path - run directories, anyone's dumps, in
situ, dask, ensembles, reports.

- :mod:`granavg.pipeline.description`: one typed description of an average, every
  default computed once;
- :mod:`granavg.pipeline.averaging`: runs, ensembles and dumps -> profiles (files);
- :mod:`granavg.pipeline.on_dask`: the same on dask workers;
- :mod:`granavg.pipeline.insitu`, :mod:`granavg.pipeline.mpi_rank`: averages fed by a
  running LAMMPS;
- :mod:`granavg.pipeline.simulation`: simulations with or without in-situ averages;
- :mod:`granavg.pipeline.reporting`: profiles -> analysis -> figures and report;
- :mod:`granavg.pipeline.session`: one command as a process: logging, signals as clean
  stops;
- :mod:`granavg.pipeline.commands`: the command line's commands, as functions of its
  options;
- :mod:`granavg.pipeline.api`: the Python API (``granavg.average``, ``granavg.read``).
"""
