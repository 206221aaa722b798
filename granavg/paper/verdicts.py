"""The verdicts of the paper's claims and what they are measured against: the paper's
own numbers, the tolerances, and the rules that turn a number with its error into
``reproduced``, ``not reproduced`` or ``inconclusive``."""

from __future__ import annotations

import numpy as np

PAPER = {"v0_over_omega_Ri": 0.645, "s_m": 0.0127, "exp_sigma_rr": 0.0,
         "exp_sigma_phiphi": 0.0, "exp_sigma_rphi": -2.0, "exp_sigma_phir": -2.0}
#: Twice the standard error: what "beyond the error" means in a verdict.
Z = 2.0
#: The paper's "almost consistent" (Eq. 10): exponents within this of 0 and -2.
EXPONENT_TOLERANCE = 0.3
#: Angle (deg) between major axes above which tensors count as not co-linear.
COLINEAR_DEG = 5.0
#: The paper's bound on the fabric anisotropy (Fig. 3).
ANISOTROPY_LIMIT = 0.2
#: Decades of decay the paper reports ("two orders of magnitude"); "about" two.
DECADES = 1.5
#: How close the band's s and v0 must come to the paper's (relative).
S_TOLERANCE, V0_TOLERANCE = 0.15, 0.10
ESTIMATOR_TEXT = ("ln v_phi fitted over the finer rings from one mean diameter off the inner "
                  "wall (the first layer left out) to the last ring before v_phi falls "
                  "below 3 standard errors or the outer half's rms, weighted 1/(e^2 + "
                  "tau^2) with e the relative error and tau the scatter beyond it "
                  "(docs/analysis.md)")
#: Bulk EoM residual, relative to the stress scale, below which the equations close.
EOM_LIMIT = 0.1
#: The spins' balance closes: every ring's |residual| below SPIN_LIMIT of the
#: stress scale, walls included, and the bulk's median below SPIN_BULK_LIMIT.
SPIN_LIMIT, SPIN_BULK_LIMIT = 0.1, 0.02
#: The power balance closes: the energy left unbalanced within 2% of the inner wall's
#: power, or within Z errors where those are larger.
POWER_LIMIT = 0.02
#: Relative deviation from the linear-spring identity accepted by the identity check.
IDENTITY_TOLERANCE = 0.05


def bulk(n):
    """Slice of the middle half of n rings."""
    return slice(n // 4, n - n // 4)


def verdict(value, err, limit, above=True):
    """``reproduced`` if value lies beyond ``limit`` on the claimed side by more than Z
    errors, ``not reproduced`` if it lies on the other side by more than Z errors,
    ``inconclusive`` otherwise (also when the error is unknown)."""
    if not np.isfinite(value):
        return "inconclusive"
    margin = (value - limit) if above else (limit - value)
    if not np.isfinite(err):
        return "inconclusive"
    if margin > Z * err:
        return "reproduced"
    if margin < -Z * err:
        return "not reproduced"
    return "inconclusive"


def both(*verdicts):
    """All reproduced -> reproduced; any not reproduced -> not reproduced; else
    inconclusive."""
    if all(v == "reproduced" for v in verdicts):
        return "reproduced"
    if any(v == "not reproduced" for v in verdicts):
        return "not reproduced"
    return "inconclusive"


def closes(value, err, limit):
    """A balance closes (``reproduced``) if |value| is within ``limit`` or Z errors,
    fails (``not reproduced``) beyond both, undecided without an error."""
    if not (np.isfinite(value) and np.isfinite(err)):
        return "inconclusive"
    return "reproduced" if abs(value) <= max(limit, Z * err) else "not reproduced"
