"""A scale study as functions of profiles: the same frames coarse-grained with one
smoothing kernel at several widths w, each field's change from one width to the next
against the error of that change, and the plateau - the widths over which a field stops
depending on w.

A change is judged at the interior nodes only: those at least the larger width's cutoff
(the kernel's support radius; 3 w for Gauss) from both ends of the cells' line, where
the kernel's support lies inside the cells; nearer an end a field keeps depending on w
(the support reaches past the packing). The error of a change comes from the two
profiles' paired replicates (the same time blocks and sectors of the same frames:
their noise largely cancels in the difference); where the replicates do not pair, from
the two standard errors as if independent, which overstates it - the study says which.
"""

from __future__ import annotations

import numpy as np

from granavg.engine.uncertainty.blocking import Replicates

#: A step from one width to the next is flat where no interior node's change exceeds
#: this many errors of the change. A field that does not depend on w exceeds it at one
#: node by chance with probability 0.0027: a step over 20 independent nodes fails about
#: one time in 20 (fewer: the nodes' kernels overlap, and their changes correlate).
FLAT = 3.0


def interior(cells, cutoff: float) -> np.ndarray:
    """Nodes at least ``cutoff`` from both ends of the cells' line (every node where the
    cells do not form a line), shape (n,) bool."""
    line = cells.position()
    edges = getattr(cells, "edges", None)
    if line is None or edges is None:
        return np.ones(cells.n, bool)
    x = np.asarray(line[1], float)
    return (x - edges[0] >= cutoff) & (edges[-1] - x >= cutoff)


def change_errors(a, b, name: str):
    """The error of ``b.values[name] - a.values[name]`` per node, shape (n,), and
    whether it came from paired replicates (else from the two errors as independent)."""
    ra, rb = a.replicates, b.replicates
    if (ra is not None and rb is not None and ra.kind == rb.kind and ra.parts == rb.parts
            and ra.n == rb.n and name in ra.values and name in rb.values):
        diff = Replicates(ra.kind, {name: rb.values[name] - ra.values[name]}, ra.parts)
        err = diff.profile_errors()[name]
        if np.all(np.isfinite(err) | ~np.isfinite(b.values[name] - a.values[name])):
            return err, True
    return np.hypot(a.sem[name], b.sem[name]), False


def steps(widths, profiles, cutoffs, names):
    """Each field's change from each width to the next.

    Parameters
    ----------
    widths : sequence of float, shape (K,)
        Increasing kernel widths.
    profiles : sequence of Fields, shape (K,)
        The profiles at each width (the same cells and frames).
    cutoffs : sequence of float, shape (K,)
        The kernel's support radius at each width.
    names : sequence of str
        Value columns to judge.

    Returns
    -------
    dict of name -> list of dict, length K - 1
        ``w_from``, ``w_to``, ``nodes`` (interior nodes judged), ``max_sigmas``
        (largest |change| / error over them), ``max_change`` (largest |change|, the
        field's unit), ``paired`` (the errors from paired replicates).
    """
    out = {}
    for name in names:
        rows = []
        for k in range(len(widths) - 1):
            a, b = profiles[k], profiles[k + 1]
            inside = interior(b.cells, cutoffs[k + 1])
            change = b.values[name] - a.values[name]
            err, paired = change_errors(a, b, name)
            # a field zero at both widths (the walls' force density inside) tells nothing
            ok = inside & np.isfinite(change) & np.isfinite(err) & \
                ((a.values[name] != 0) | (b.values[name] != 0))
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.abs(change[ok]) / err[ok]
            z = np.where(change[ok] == 0, 0.0, z)
            rows.append({"w_from": float(widths[k]), "w_to": float(widths[k + 1]),
                         "nodes": int(ok.sum()),
                         "max_sigmas": float(z.max()) if ok.any() else float("nan"),
                         "max_change": float(np.abs(change[ok]).max()) if ok.any()
                         else float("nan"), "paired": bool(paired)})
        out[name] = rows
    return out


def plateau(rows, flat: float = FLAT):
    """The longest run of consecutive flat steps (:data:`FLAT`; the first of equal
    length): (w_from, w_to), or None where no step is flat or none could be judged."""
    best, start, run = None, None, 0
    for k, r in enumerate(rows + [None]):
        good = r is not None and r["nodes"] > 0 and r["max_sigmas"] <= flat
        if good:
            start = k if run == 0 else start
            run += 1
        elif run:
            if best is None or run > best[1]:
                best = (start, run)
            run = 0
    if best is None:
        return None
    return rows[best[0]]["w_from"], rows[best[0] + best[1] - 1]["w_to"]
