"""Frames of a granavg run directory's dumps: granavg's own per-atom and contact
formats (:mod:`granavg.io.contacts`), SI units, time from ``ITEM: TIME`` or the
manifest's dt."""

from __future__ import annotations

import numpy as np

from granavg.engine.kernels import lookup
from granavg.io.box import Box
from granavg.io.frames import Frame, PairedDumps, check_atoms, check_contacts


class RunDumps(PairedDumps):
    """A run's atom dump paired with its contact dump (see :class:`PairedDumps`); rows
    that do not touch (overlap <= 0) are dropped and counted."""

    def frame(self, fa, fc) -> Frame:
        atoms = check_atoms(self.atoms.path, fa)
        contacts, rows = self._contacts(fc, atoms) if fc is not None else (None, None)
        return Frame(fa.timestep, self.time(fa), atoms, contacts, rows, box=Box.of(fa),
                     origin=self.origin(fa, fc))

    def _contacts(self, fc, atoms) -> tuple:
        """The contact columns and, where both ids and the wall codes are there, the
        contacts' rows among the atoms (:attr:`Frame.rows`), looked up once for the check
        and the engine."""
        cols = check_contacts(self.contacts.path, fc)
        rows = None
        if "id" in atoms and "id1" in cols:
            i1, found1 = lookup(atoms["id"], cols["id1"])
            found2 = np.ones(len(i1), bool)
            if "id2" in cols and "wall" in cols:
                i2, found2 = lookup(atoms["id"], cols["id2"])
                pair = np.asarray(cols["wall"]) == 0
                found2 = found2 | ~pair
                rows = (i1, np.where(pair, i2, -1))
            self.unknown_ids(fc, cols, found1, found2)
        keep = cols["overlap"] > 0 if "overlap" in cols else None
        if keep is not None and not keep.all():
            self.dropped["contacts_not_touching"] += int(np.sum(~keep))
            cols = {k: v[keep] for k, v in cols.items()}
            rows = rows and (rows[0][keep], rows[1][keep])
        return cols, rows

