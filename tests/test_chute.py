"""A steady 3D chute flow of our own deck (lammps_inputs/chute_3d.lmp at 24 degrees):
the momentum balance of steady uniform flow, -S_xz / S_zz = tan(theta) at every bulk
depth within 2 errors, and the rheology's friction there equal to tau / P from the
stress components by hand, to round-off (workflows/rheology.py runs the sweep)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

WORKFLOWS = Path(__file__).resolve().parents[1] / "workflows"
sys.path.insert(0, str(WORKFLOWS))
import rheology as sweep  # noqa: E402

import granavg  # noqa: E402

pytestmark = pytest.mark.slow

THETA = 24.0


@pytest.fixture(scope="module")
def chute(tmp_path_factory):
    """600 spheres on a 6 d x 6 d base (about 14 d deep), 4 s of flow at 24 degrees,
    then 20 frames over 1 s (about 70 s)."""
    out = tmp_path_factory.mktemp("chute") / "run"
    sweep.run_deck("chute_3d.lmp", out, theta=THETA, n=600, side=6, duration=1.0,
                   frames=20)
    return sweep.chute_fields(out, THETA)


def test_the_stress_ratio_is_tan_theta_at_every_bulk_depth(chute):
    inner = sweep.bulk(chute)
    assert inner.sum() >= 5
    ratio, error = sweep.stress_ratio(chute)
    tan = math.tan(math.radians(THETA))
    assert np.all(np.abs(ratio[inner] - tan) < 2 * error[inner]), (ratio[inner], error[inner])
    # the check can fail: the gravity of another angle misses it
    other = math.tan(math.radians(THETA + 3))
    assert np.any(np.abs(ratio[inner] - other) > 2 * error[inner])


def test_the_friction_is_tau_over_p_from_the_stress_components(chute):
    rheo = granavg.rheology(chute, diameter=sweep.D, density=sweep.RHO)
    inner = sweep.bulk(chute)
    by_hand = sweep.friction_by_hand(chute)
    mu = rheo.values["friction"]
    assert np.all(np.isfinite(mu[inner]))
    assert np.allclose(mu[inner], by_hand[inner], rtol=1e-12, atol=0)
    I = rheo.values["inertial_number"][inner]
    assert np.all((I > 0.01) & (I < 1.0)), I
