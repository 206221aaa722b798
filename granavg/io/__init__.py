"""Formats: input files -> frames (:mod:`granavg.io.formats` finds every format: LAMMPS
dumps, CSV tables; :mod:`granavg.io.frames` the frame type and its checks,
:mod:`granavg.io.contacts` the one contact conversion), granavg's run dumps and run
directories, profile tables, units, and validation at the way in."""
