"""Frames of a granavg run directory's dumps: granavg's own per-atom and contact
formats (:mod:`granavg.io.contacts`), SI units, time from ``ITEM: TIME`` or the
manifest's dt."""

from __future__ import annotations

import numpy as np

from granavg.engine.kernels import lookup
from granavg.io.frames import Frame, PairedDumps, check_atoms, check_contacts


class RunDumps(PairedDumps):
    """A run's atom dump paired with its contact dump (see :class:`PairedDumps`); rows
    that do not touch (overlap <= 0) are dropped and counted."""

    def frame(self, fa, fc) -> Frame:
        atoms = check_atoms(self.atoms.path, fa)
        contacts = self._contacts(fc, atoms) if fc is not None else None
        return Frame(fa.timestep, self.time(fa), atoms, contacts)

    def _contacts(self, fc, atoms) -> dict:
        rows = check_contacts(self.contacts.path, fc)
        if "id" in atoms and "id1" in rows:
            _, known = lookup(atoms["id"], rows["id1"])
            if "id2" in rows and "wall" in rows:
                _, found2 = lookup(atoms["id"], rows["id2"])
                known &= found2 | (rows["wall"] != 0)
            self.unknown_ids(fc, rows, known)
        keep = rows["overlap"] > 0 if "overlap" in rows else None
        if keep is not None and not keep.all():
            self.dropped["contacts_not_touching"] += int(np.sum(~keep))
            rows = {k: v[keep] for k, v in rows.items()}
        return rows

