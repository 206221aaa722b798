"""The forecast of cost and accuracy (granavg.sim.trade) from the measured study."""

import pytest

from granavg.sim import trade
from granavg.sim.scene import preset


def table(scene, classes):
    """A study of ``scene`` with settings (k_n, n, Omega, class)."""
    return {"seconds_per_disk_step": 3e-7, "seconds_per_disk_frame": 2e-4, "time_spread": 0.1,
            "measured": "test", "machine": "test", "scene": scene.to_dict(),
            "settings": [{"name": f"s{i}", "k_n": k, "n_per_tc": n, "Omega": om, "class": c}
                         for i, (k, n, om, c) in enumerate(classes)]}


STUDY = [(10.0, 50.0, 0.1, "10%"), (100.0, 50.0, 0.1, "5%"), (2.5, 50.0, 0.1, "worse"),
         (10.0, 25.0, 0.1, "worse"), (2.5, 25.0, 0.1, "10%")]


@pytest.mark.parametrize("k, n, om, expected", [
    (100.0, 50.0, 0.1, "5%"),         # a measured setting
    (1000.0, 100.0, 0.05, "5%"),      # stiffer, finer and slower than a 5% setting
    (30.0, 50.0, 0.1, "10%"),         # between: the softer measured setting bounds it
    (10.0, 50.0, 0.2, "not measured"),    # faster than anything measured
    (2.0, 40.0, 0.1, "worse"),        # softer and coarser than a setting found wanting
    (10.0, 20.0, 0.1, "worse"),
    (10.0, 25.0, 0.1, "worse"),       # measured: its own class, though a 10% one bounds it
])
def test_a_setting_gets_the_class_of_the_measured_settings_that_bound_it(k, n, om, expected):
    scene = preset("paper")
    study = table(scene, STUDY)
    mine = scene.with_overrides([f"k_n={k}", f"n_per_tc={n}", f"Omega={om}"])
    assert trade.accuracy_class(mine.to_dict(), study)[0] == expected


def test_another_scene_is_not_measured_whatever_its_settings():
    scene = preset("paper")
    study = table(scene, STUDY)
    other = scene.with_overrides(["n_small=250", "n_large=40", "k_n=1e4"])
    cls, why = trade.accuracy_class(other.to_dict(), study)
    assert cls == "not measured" and "n_small" in why and "n_large" in why
    hooke = scene.with_overrides(["mu_roll=0", "k_n=1e4"])
    assert trade.accuracy_class(hooke.to_dict(), study)[0] == "not measured"


def test_a_scene_key_added_after_the_study_counts_at_its_default():
    """A study written before base friction existed ran without it: a scene without base
    friction keeps its class, one with it is another scene."""
    scene = preset("paper-rolling")
    study = table(scene, STUDY)
    study["scene"] = {k: v for k, v in study["scene"].items()
                      if k not in ("mu_base", "v_base", "base_every")}
    assert trade.accuracy_class(scene.to_dict(), study)[0] == "10%"      # STUDY's k_n = 10
    cls, why = trade.accuracy_class(scene.with_overrides(["mu_base=0.03"]).to_dict(), study)
    assert cls == "not measured" and "mu_base" in why


def test_the_wall_time_is_disk_steps_and_frames_at_the_measured_rates(monkeypatch):
    scene = preset("paper-rolling")
    study = table(scene, STUDY)
    monkeypatch.setattr(trade, "study", lambda: study)
    d = scene.derive()
    f = trade.expectation(d, prepared=True)
    n = scene.n_small + scene.n_large
    frames = d.n_shear // d.dump_every + 1
    assert f["wall_time_s"] == pytest.approx(n * (d.n_shear * 3e-7 + frames * 2e-4))
    grown = trade.expectation(d, prepared=False)          # the growth's steps count too
    assert grown["wall_time_s"] - f["wall_time_s"] == pytest.approx(
        n * (d.n_grow + d.n_relax) * 3e-7)
    assert "expected wall time" in trade.describe(f) and f["accuracy_class"] == "10%"
    study["seconds_per_disk_step_plain_law"] = 1e-7         # the plain law's own rate
    plain = trade.expectation(scene.with_overrides(["mu_roll=0"]).derive(), prepared=True)
    assert plain["wall_time_s"] == pytest.approx(n * (d.n_shear * 1e-7 + frames * 2e-4))
    based = trade.expectation(scene.with_overrides(["mu_base=0.03"]).derive(), prepared=True)
    extra = n * d.n_shear * 3e-7 * trade.BASE_FRICTION_EXTRA     # a fixed cost per disk-step
    assert based["wall_time_s"] == pytest.approx(f["wall_time_s"] + extra)
    plain_based = trade.expectation(scene.with_overrides(["mu_roll=0", "mu_base=0.03"]).derive(),
                                    prepared=True)
    assert plain_based["wall_time_s"] == pytest.approx(plain["wall_time_s"] + extra)
    renewed = trade.expectation(scene.with_overrides(["mu_base=0.03", "base_every=10"]).derive(),
                                prepared=True)                # the coefficient every 10 steps
    assert renewed["wall_time_s"] == pytest.approx(
        f["wall_time_s"] + extra * trade.BASE_FRICTION_EXTRA_RENEWED / trade.BASE_FRICTION_EXTRA)
    monkeypatch.setattr(trade, "study", lambda: None)
    assert "wall_time_s" not in trade.expectation(d, prepared=True)
