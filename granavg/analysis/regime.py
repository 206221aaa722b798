"""The flow's regime, from any fields: whether the dynamic stress is still small beside
the static stress (quasi-static, the regime the paper describes), for the ``average``
command's warning and the paper's claim."""

from __future__ import annotations

import logging

import numpy as np

from granavg.engine.quantities import columns

log = logging.getLogger(__name__)

#: Dynamic over static stress above which the flow is no longer quasi-static (the paper
#: describes the quasi-static regime only); granavg warns.
QUASI_STATIC_LIMIT = 0.1


def dynamic_over_static(p) -> np.ndarray:
    """|dynamic stress| / |static stress| per cell (Frobenius norms), shape (n_cells,)."""
    def norm(name):
        return np.sqrt(sum(np.asarray(p.values[c]) ** 2 for c in columns(name, p.cells.axes)))
    with np.errstate(invalid="ignore", divide="ignore"):
        return norm("dsigma") / norm("sigma")


def warn_if_inertial(p) -> float | None:
    """Log a warning when the dynamic stress is no longer small against the static
    stress in some cell (at some time); returns the largest ratio (None without both
    stresses)."""
    axes = p.cells.axes
    if not all(c in p.values for c in (*columns("sigma", axes), *columns("dsigma", axes))):
        return None
    each = [p.at(j) for j in range(len(p.times))] if p.in_time else [p]   # every time
    ratio = float(np.nanmax([np.nanmax(dynamic_over_static(f)) for f in each]))
    if ratio > QUASI_STATIC_LIMIT:
        what = "reaches %.2f of the static stress (above %.2f)" % (ratio, QUASI_STATIC_LIMIT) \
            if np.isfinite(ratio) else "is not zero where the static stress is (cells " \
            "without contacts)"
        log.warning("dynamic stress %s: the flow is inertial, outside the quasi-static "
                    "regime the paper describes; lower Omega or stiffen k_n", what)
    return ratio
