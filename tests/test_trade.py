"""The forecast of cost and accuracy (granavg.sim.trade) from the measured studies."""

import pytest

from granavg.sim import trade
from granavg.sim.scene import preset


def table(scene, classes, steps=None, name="test"):
    """A study of ``scene`` with settings (k_n, n, Omega, class[, v_base, base_every])."""
    rows = []
    for i, (k, n, om, c, *plate) in enumerate(classes):
        row = {"name": f"s{i}", "k_n": k, "n_per_tc": n, "Omega": om, "class": c}
        if plate:
            row.update(v_base=plate[0], base_every=plate[1])
        rows.append(row)
    return {"seconds_per_disk_step": steps or {"rolling": {"none": 3e-7}},
            "seconds_per_disk_frame": 2e-4, "time_spread": 0.1, "preset": name,
            "measured": "test", "machine": "test", "scene": scene.to_dict(), "settings": rows}


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


def test_the_plates_numerics_are_matched_too():
    """The plate's v_base and base_every are numerics of the study: a measured value has its
    class, an unmeasured one is not bracketed by settings at other values."""
    scene = preset("paper")
    study = table(scene, [*STUDY, (10.0, 50.0, 0.1, "5%", 3e-5, 10),
                          (10.0, 50.0, 0.1, "worse", 1e-4, 50)])
    assert trade.accuracy_class(scene.with_overrides(["v_base=3e-5"]).to_dict(),
                                study)[0] == "5%"
    assert trade.accuracy_class(scene.with_overrides(["base_every=50"]).to_dict(),
                                study)[0] == "worse"
    cls, why = trade.accuracy_class(scene.with_overrides(["base_every=200"]).to_dict(), study)
    assert cls == "not measured" and "base_every" in why
    stiffer = scene.with_overrides(["v_base=3e-5", "k_n=100"])      # k_n bracketed at v_base
    assert trade.accuracy_class(stiffer.to_dict(), study)[0] == "5%"


def test_another_scene_is_not_measured_whatever_its_settings():
    scene = preset("paper")
    study = table(scene, STUDY)
    other = scene.with_overrides(["n_small=250", "n_large=40", "k_n=1e4"])
    cls, why = trade.accuracy_class(other.to_dict(), study)
    assert cls == "not measured" and "n_small" in why and "n_large" in why
    rolling_free = scene.with_overrides(["mu_roll=0", "k_n=1e4"])
    assert trade.accuracy_class(rolling_free.to_dict(), study)[0] == "not measured"


def test_each_scene_is_judged_by_its_own_study():
    """With two studies, a scene gets the class of the one that measured it; without the
    plate the plate's numerics do not matter."""
    paper = table(preset("paper"), [(10.0, 50.0, 0.1, "10%")], name="paper")
    rolling = table(preset("paper-rolling"), [(10.0, 50.0, 0.1, "5%")], name="paper-rolling")
    assert trade.accuracy_class(preset("paper").to_dict(), [paper, rolling])[0] == "10%"
    plateless = preset("paper-rolling").with_overrides(["v_base=0.5", "base_every=7"])
    assert trade.accuracy_class(plateless.to_dict(), [paper, rolling])[0] == "5%"
    cls, why = trade.accuracy_class(preset("paper-hooke").to_dict(), [paper, rolling])
    assert cls == "not measured" and "paper-rolling" in why


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


def test_the_step_cost_of_each_law_and_plate_mode():
    """Measured combinations are their rates; others are the law's own rate plus what the
    plate adds with rolling resistance, interpolated in 1/N between renewal intervals."""
    steps = {"rolling": {"none": 3e-7, "0": 9e-7, "1": 8e-7, "10": 5e-7, "50": 4e-7},
             "plain": {"10": 3e-7}}
    t = [table(preset("paper"), STUDY, steps)]
    rate = trade.seconds_per_disk_step
    assert rate(t, True, "10") == 5e-7 and rate(t, True, "0") == 9e-7
    assert rate(t, False, "10") == 3e-7
    assert rate(t, False, "none") == pytest.approx(3e-7 - 2e-7)      # the plate's 2e-7 out
    assert rate(t, False, "50") == pytest.approx(1e-7 + 1e-7)
    assert rate(t, True, "20") == pytest.approx(3e-7 + 1e-7 + 1e-7 * (1 / 20 - 1 / 50) /
                                                (1 / 10 - 1 / 50))
    assert rate(t, True, "1000") == pytest.approx(4e-7)             # clamped at N = 50
    assert trade.plate_mode(0.0, 10) == "none" and trade.plate_mode(0.005, 10) == "10"


def test_the_wall_time_is_disk_steps_and_frames_at_the_measured_rates(monkeypatch):
    scene = preset("paper")
    study = table(scene, STUDY, {"rolling": {"none": 3e-7, "10": 5e-7}, "plain": {"none": 1e-7}})
    monkeypatch.setattr(trade, "studies", lambda: (study,))
    d = scene.derive()
    f = trade.expectation(d, prepared=True)
    n = scene.n_small + scene.n_large
    frames = d.n_shear // d.dump_every + 1
    assert f["wall_time_s"] == pytest.approx(n * (d.n_shear * 5e-7 + frames * 2e-4))
    grown = trade.expectation(d, prepared=False)          # the growth's steps count too
    assert grown["wall_time_s"] - f["wall_time_s"] == pytest.approx(
        n * (d.n_grow + d.n_relax) * 5e-7)
    assert "expected wall time" in trade.describe(f) and f["accuracy_class"] == "10%"
    plain = trade.expectation(scene.with_overrides(["mu_roll=0"]).derive(), prepared=True)
    assert plain["wall_time_s"] == pytest.approx(n * (d.n_shear * 3e-7 + frames * 2e-4))
    monkeypatch.setattr(trade, "studies", lambda: ())
    assert "wall_time_s" not in trade.expectation(d, prepared=True)


@pytest.mark.parametrize("name", ["paper", "demo"])
def test_the_shipped_study_forecasts_a_measured_class_for_the_presets(name):
    """What issue 40 asked: the scenes users run today get a measured accuracy class and a
    cost from the study of that scene (granavg/sim/trade.json)."""
    scene = preset(name)
    f = trade.expectation(scene.derive(), prepared=True)
    assert f["accuracy_class"] in trade.CLASSES, f["accuracy_reason"]
    assert "measured setting" in f["accuracy_reason"]
    assert 0 < f["wall_time_s"] < 3600


def test_the_fast_preset_keeps_the_class_its_study_measured():
    f = trade.expectation(preset("fast").derive(), prepared=True)
    assert f["accuracy_class"] in trade.CLASSES and "'k_n=2.5'" in f["accuracy_reason"]


def test_the_shipped_study_names_its_pool_and_its_cheapest_accurate_stiffness():
    """The preset's k_n = 10 N/m settings are judged with the others at that k_n (the
    band's s is shared by them: docs/sweep); stiffer springs measured in the 5% class are
    forecast so, with the resolution the class vouches for."""
    f = trade.expectation(preset("demo").derive(), prepared=True)
    assert f["accuracy_class"] == "5%" and "settings pooled: s " in f["accuracy_reason"]
    stiff = trade.expectation(preset("paper").with_overrides(["k_n=100"]).derive(),
                              prepared=True)
    assert stiff["accuracy_class"] == "5%" and "'k_n=100'" in stiff["accuracy_reason"]
    assert "resolution cannot be seen: " in stiff["accuracy_reason"]


def test_step_costs_of_two_studies_are_never_subtracted_from_each_other():
    """The newer study measured the plate but not the law without it, the older one the
    law without the plate on a faster-stepping day: a combination neither measured comes
    from one study's own rates, so the plate never costs less than nothing."""
    new = table(preset("paper"), STUDY, {"rolling": {"0": 2.9e-7, "10": 2.3e-7,
                                                     "50": 2.28e-7}, "plain": {"10": 1.04e-7}})
    old = table(preset("paper-rolling"), STUDY, {"rolling": {"none": 3.0e-7},
                                                 "plain": {"none": 9.5e-8}})
    rate = trade.seconds_per_disk_step
    assert rate([new, old], True, "none") == 3.0e-7                 # measured (older study)
    assert rate([new, old], False, "none") == 9.5e-8
    plain = [rate([new, old], False, m) for m in ("50", "20", "10", "1", "0")]
    assert plain[2] == 1.04e-7
    assert all(a <= b for a, b in zip(plain, plain[1:]))          # rarer renewal: cheaper
    assert plain[0] == pytest.approx(1.04e-7 - 0.2e-8)            # within the new study
    assert plain[-1] == pytest.approx(1.04e-7 + 0.6e-7)
