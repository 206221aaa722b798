"""granavg: from DEM simulations of granular matter to continuum fields.

Implements Luding et al., Comput. Methods Appl. Mech. Engrg. 191 (2001) 21-28, and the
coarse-graining that generalises it. In Python::

    import granavg
    fields = granavg.average("runs/demo", cells={"bins": 20})      # a run directory
    fields = granavg.average("atoms.dump", contacts="contacts.dump",
                             contact_map={...}, cells={"slabs": "z", "bins": 12})
    fields.to_xarray(), fields.to_pandas(), fields.units, fields.plot("nu")

:func:`average` (any source over any cells), :func:`read` (fields written before),
:func:`open` (the frames of files, a lazy sequence), :func:`rheology` (the local
rheology of fields) with :func:`fit_mu_I` and :func:`fit_phi_I` (constitutive fits),
:class:`Fields`, :mod:`granavg.cells` (the kinds of cells), :mod:`granavg.examples`
(small real data sets). Layers, data flowing one way: :mod:`granavg.sim` (LAMMPS runs),
:mod:`granavg.io` (file formats -> frames), :mod:`granavg.engine` (frames -> fields),
:mod:`granavg.analysis` (fields -> checks, figures, report), wired only by
:mod:`granavg.pipeline`; the CLI is a shell around it. Importing granavg loads neither
LAMMPS nor MPI, nor anything above until it is used.
"""

import importlib

__version__ = "0.1.0"

#: What ``granavg.<name>`` is, imported when first used.
_LAZY = {"average": ("granavg.pipeline.api", "average"),
         "read": ("granavg.pipeline.api", "read"),
         "rheology": ("granavg.pipeline.api", "rheology"),
         "fit_mu_I": ("granavg.analysis.rheology", "fit_mu_I"),
         "fit_phi_I": ("granavg.analysis.rheology", "fit_phi_I"),
         "open": ("granavg.io.trajectory", "open"),
         "Fields": ("granavg.engine.fields", "Fields"),
         "cells": ("granavg.cells", None),
         "examples": ("granavg.examples", None)}

__all__ = ["average", "read", "open", "rheology", "fit_mu_I", "fit_phi_I", "Fields", "cells",
           "examples", "__version__"]


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'granavg' has no attribute {name!r}")
    module, attr = _LAZY[name]
    found = importlib.import_module(module)
    return found if attr is None else getattr(found, attr)


def __dir__():
    return sorted(__all__)
