"""Fields in time on the transient decks of lammps_inputs/ (workflows/collapse.py,
workflows/silo.py): the balance laws in time on a real column collapse, with the deck's
own contact law and dumps as a user writes them, and the silo's mass flow rate two ways."""

import sys
from pathlib import Path

import numpy as np
import pytest

WORKFLOWS = Path(__file__).resolve().parents[1] / "workflows"
sys.path.insert(0, str(WORKFLOWS))
import collapse  # noqa: E402
import silo  # noqa: E402

import granavg  # noqa: E402
from granavg.analysis.time_balance import continuity, momentum  # noqa: E402

pytestmark = pytest.mark.slow

#: dt = t_c/200, so that the dumped dashpot forces lie within 1% of the ones that moved
#: the disks (docs/time.md); frames every 2 steps (5.2e-6 s) over 0.0605-0.0695 s.
STEPS_PER_TC, STEP = 200, 2
GRID = {"grid": (24, 10), "x_range": (0.0, 0.12), "y_range": (0.0, 0.05), "thickness": 0.002}


@pytest.fixture(scope="module")
def collapse_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("collapse") / "run"
    return collapse.run_deck(out, STEPS_PER_TC, duration=0.07, step=STEP)


def _fields(atoms, contacts, gravity=(0.0, -9.81), **extra):
    common = dict(collapse.COMMON, gravity=gravity, **extra)
    return granavg.average(atoms, contacts=contacts, cells=GRID, kernel="lucy", width=0.006,
                           t_min=collapse.DENSE[0], t_max=collapse.DENSE[1],
                           time_kernel="gauss", time_width=0.001,
                           times=collapse.BALANCE_TIMES, **common)


@pytest.fixture(scope="module")
def balance_fields(collapse_run):
    return _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump")


def test_continuity_closes_within_1_percent_at_every_node_and_time(balance_fields):
    c = continuity(balance_fields)
    assert c["claim"]["verdict"] == "holds", c["claim"]["evidence"]
    assert c["ratio"] < 0.01


def test_momentum_closes_within_2_percent_of_rho_g_at_bulk_nodes(balance_fields):
    m = momentum(balance_fields)
    assert m["claim"]["verdict"] == "holds", m["claim"]["evidence"]
    assert m["ratio"] < 0.02
    assert set(m["terms"]) == {"dmomentum_dt", "divsigma", "divdsigma", "body", "boundary"}
    for name in m["terms"]:
        assert name in m["claim"]["evidence"]
    assert m["bulk_nodes"] > 100


def test_without_gravity_the_momentum_claim_fails(collapse_run):
    f = _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump", gravity=None)
    m = momentum(f)
    assert m["claim"]["verdict"] == "violated", m["claim"]["evidence"]


def test_the_continuity_residual_falls_with_the_frame_interval_as_its_order_says(
        collapse_run, tmp_path):
    """Frames every 2, 8 and 32 steps of the same run (every 1st, 4th, 16th frame): the Gaussian's trapezoid rule is
    of order 2 on smooth motion (tests/test_time.py); a collision's kinks leave less."""
    ratios = []
    for every in (1, 4, 16):
        atoms = collapse.thin(collapse_run / "atoms.dump", tmp_path / f"a{every}", every)
        contacts = collapse.thin(collapse_run / "contacts.dump", tmp_path / f"c{every}", every)
        ratios.append(continuity(_fields(atoms, contacts))["ratio"])
    orders = np.log(np.array(ratios[1:]) / ratios[:-1]) / np.log(4)
    assert ratios[0] < ratios[1] < ratios[2], ratios
    assert orders.min() > 1.2, (ratios, orders)


def test_thinning_keeps_every_kth_whole_frame_of_both_dumps(collapse_run, tmp_path):
    whole = granavg.average(collapse_run / "atoms.dump", cells=GRID, quantities=["nu"],
                            wall_types=[2])
    atoms = collapse.thin(collapse_run / "atoms.dump", tmp_path / "a", 10)
    contacts = collapse.thin(collapse_run / "contacts.dump", tmp_path / "c", 10)
    f = granavg.average(atoms, contacts=contacts, cells=GRID, **collapse.COMMON)
    assert f.n_frames == -(-whole.n_frames // 10)


@pytest.fixture(scope="module")
def silo_run(tmp_path_factory):
    return silo.run_deck(tmp_path_factory.mktemp("silo") / "run", duration=0.25)


def test_the_silo_rate_from_the_fields_equals_the_particle_count_within_errors(silo_run):
    area = silo.box_area(silo_run)
    assert area == pytest.approx(0.028 ** 2, rel=1e-9)
    t, mass = silo.mass_above(silo_run, sum(silo.SLAB) / 2)
    counted, counted_err = silo.count_rate(t, mass, 0.1, 0.25)
    fields, fields_err, rates = silo.field_rate(silo_run, area, 0.1, 0.25)
    assert len(rates) == 6
    assert abs(fields - counted) <= 2 * np.hypot(fields_err, counted_err), \
        (fields, fields_err, counted, counted_err)
    assert 0 < fields_err < 0.1 * fields and 0 < counted_err < 0.1 * counted
    # the start-up is no steady discharge: its rate is told apart by the same errors
    start, _, _ = silo.field_rate(silo_run, area, 0.0, 0.05)
    assert abs(start - counted) > 2 * np.hypot(fields_err, counted_err), (start, counted)


def test_each_size_class_balances_in_time_with_the_force_between_them(collapse_run):
    """The collapse split at radius 1 mm (its diameters 1.6-2.4 mm): each size class obeys
    the continuity equation on its own (within 1% of its largest |d rho_s/dt|: measured
    1.8e-7), and its momentum balance in time, with the force between the classes, to
    the whole's accuracy: within 2% of the whole's rho g at the class' bulk nodes
    (measured 1.4% and 0.65%; of the class' own rho_s g: 2.5% and 1.0%, the dumped
    dashpot's share being larger against a smaller weight). Without that force the
    classes miss by 33 and 9 times their weight."""
    f = _fields(collapse_run / "atoms.dump", collapse_run / "contacts.dump",
                species="radius:0.001")
    assert f.species == ("all", "r<0.001", "r>=0.001")
    whole = f.of("all")
    g = np.hypot(whole.values["body_x"], whole.values["body_y"])
    for s in f.species[1:]:
        p = f.of(s)
        c = continuity(p)
        assert c["claim"]["verdict"] == "holds", (s, c["claim"]["evidence"])
        res = np.hypot(p.values["momentum_balance_x"], p.values["momentum_balance_y"])
        nu = p.values["nu"]
        bulk = nu >= 0.5 * np.nanmax(nu, axis=1, keepdims=True)
        assert bulk.sum() > 50
        assert np.nanmax(res[bulk] / g[bulk]) < 0.02, (s, np.nanmax(res[bulk] / g[bulk]))
        without = np.hypot(p.values["momentum_balance_x"] + p.values["f_inter_x"],
                           p.values["momentum_balance_y"] + p.values["f_inter_y"])
        body = np.hypot(p.values["body_x"], p.values["body_y"])
        assert np.nanmedian(without[bulk] / body[bulk]) > 1.0, s
