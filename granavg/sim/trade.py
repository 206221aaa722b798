"""What a simulation will cost and how accurate it will be, from the measured studies.

The speed/accuracy studies (``workflows/sweep.py``, docs/sweep/) measured, on a 2-core
machine, the cost of LAMMPS steps and frames and, for one scene each, how far each
setting of the numerics (k_n, n = t_c/dt, Omega, and the base plate's v_base and
``base_every``) lands from the stiff, fine-step limit. The ``trade*.json`` files beside
this module hold what they measured (``sweep.py OUT --ship`` writes them): ``trade.json``
the `paper` scene (rolling resistance, the plate near its Coulomb limit; issue 40),
``trade-paper-rolling.json`` the `paper-rolling` scene without the plate (2026-11-23).
:func:`expectation` turns them into a forecast for a scene: the expected wall time of one
LAMMPS process and the accuracy class of its settings. It is a forecast, not a
measurement: another machine scales the time, and a class holds only for the scene its
study measured (geometry, disks, material, packings); any other scene is "not measured".
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from granavg.sim.scene import Scene

#: the studies, newest scene first
STUDY_FILES = (Path(__file__).with_name("trade.json"),
               Path(__file__).with_name("trade-paper-rolling.json"))
#: scene fields that must equal a study's for its accuracy classes to apply
SAME_SCENE = ("R_i", "R_o", "n_small", "n_large", "d_s", "d_l", "rho_p", "e_n", "mu",
              "mu_wall", "mu_roll", "kt_over_kn", "size_spread", "packing", "mu_base")
#: the numerics a study measured besides (k_n, n_per_tc, Omega): the plate's law
PLATE_NUMERICS = ("v_base", "base_every")
CLASSES = {"5%": "no headline number showed a bias above 5% of the stiff limit",
           "10%": "no headline number showed a bias above 10% of the stiff limit",
           "worse": "some headline number showed a bias above 10% of the stiff limit"}


@lru_cache(maxsize=1)
def studies() -> tuple:
    """The measured studies (``trade*.json``) this install has, newest scene first."""
    return tuple(json.loads(p.read_text()) for p in STUDY_FILES if p.exists())


def plate_mode(mu_base: float, base_every: int) -> str:
    """The key of a plate law in a study's step costs: ``none`` (no plate), ``0`` (the law
    in full each step) or ``N`` (its coefficient renewed every N steps)."""
    return "none" if mu_base <= 0 else str(int(base_every))


def seconds_per_disk_step(tables, rolling: bool, mode: str) -> float:
    """Seconds of one disk-step for a contact law (``pair granular`` with rolling
    resistance, or plain ``gran/hooke/history``) and a plate mode (:func:`plate_mode`).

    A combination a study measured is its measured rate (the newest study's). Otherwise,
    within the newest study that measured the law (rates of two studies, measured on other
    days, are never subtracted), the rate is the law's own measured rate plus what the
    plate adds between its modes with rolling resistance (the plate's cost does not depend
    on the contact law: the deck's atom-style variables are evaluated per disk). A renewal
    interval not measured is interpolated linearly in 1/N between the measured ones
    (clamped at their ends)."""
    law = "rolling" if rolling else "plain"
    for t in tables:
        rate = t["seconds_per_disk_step"].get(law, {}).get(mode)
        if rate is not None:
            return rate
    rates = next((t["seconds_per_disk_step"] for t in tables
                  if t["seconds_per_disk_step"].get(law)), tables[0]["seconds_per_disk_step"])
    roll = rates.get("rolling") or rates[law]
    base_roll = roll.get("none", min(roll.values()))
    extra = {k: v - base_roll for k, v in roll.items()}

    def plate_extra(m):
        if m in extra:
            return extra[m]
        if m == "none":
            return 0.0
        renewed = sorted((1.0 / int(k), e) for k, e in extra.items() if k not in ("none", "0"))
        if not renewed:
            return max(extra.values())
        x, y = np.array(renewed).T
        return float(np.interp(1.0 / max(int(m), 1), x, y))

    own = rates.get(law) or roll
    k0 = "none" if "none" in own else next(iter(own))
    return own[k0] - plate_extra(k0) + plate_extra(mode)


def wall_time(n_steps: int, n_disks: int, n_frames: int, tables, rolling: bool = True,
              mu_base: float = 0.0, base_every: int = 0) -> float:
    """Expected wall time (s) of one single-threaded LAMMPS process: ``n_steps`` steps of
    ``n_disks`` disks and ``n_frames`` frames taken (contact dump, in-situ averaging), at
    the studies' measured rates (:func:`seconds_per_disk_step`; per disk-frame: the newest
    study's)."""
    step = seconds_per_disk_step(tables, rolling, plate_mode(mu_base, base_every))
    return n_disks * (n_steps * step + n_frames * tables[0]["seconds_per_disk_frame"])


def _differs(scene: dict, table: dict) -> list:
    ref = {**Scene().to_dict(), **table["scene"]}   # keys added since the study: defaults
    return [k for k in SAME_SCENE if scene.get(k) != ref.get(k)]


def accuracy_class(scene: dict, tables) -> tuple[str, str]:
    """The accuracy class of ``scene``'s settings and why: (class, reason).

    ``tables``: the studies (a study, or a sequence of them). The study of the same scene
    decides. A measured setting has its own class. Otherwise, with the plate's numerics
    (v_base, base_every) of some measured settings, a scene at least as stiff (k_n), fine
    (n) and slow (Omega) as one of them is given that setting's class (the best such);
    one at most as stiff, fine and slow as a setting measured "worse" is "worse";
    anything else, or another scene, is "not measured". The class is about the bias of the
    settings; the statistical error depends on run length and realisations and comes
    with every number of the report."""
    tables = [tables] if isinstance(tables, dict) else list(tables)
    if not tables:
        return "not measured", "no speed/accuracy study in this install"
    nearest = min(tables, key=lambda t: len(_differs(scene, t)))
    differs = _differs(scene, nearest)
    if differs:
        return "not measured", (f"the studies measured other scenes (the nearest, "
                                f"{nearest.get('preset', 'docs/sweep')}'s, differs in "
                                f"{', '.join(differs)})")
    table = nearest
    plated = scene.get("mu_base", 0.0) > 0
    ref = {**Scene().to_dict(), **table["scene"]}

    def key(s):
        plate = tuple(s.get(k, ref[k]) for k in PLATE_NUMERICS) if plated else ()
        return (s["k_n"], s["n_per_tc"], s["Omega"]), plate

    (k, n, om), plate = key(scene)
    settings = [(s, *key(s)) for s in table["settings"]]
    for s, knum, p in settings:
        if (knum, p) == ((k, n, om), plate):
            return s["class"], (f"the measured setting '{s['name']}' ({CLASSES[s['class']]}"
                                f"{_resolved(s)})")
    rank = {"5%": 0, "10%": 1, "worse": 2}
    alike = [(s, knum) for s, knum, p in settings if p == plate]
    better = [s for s, (sk, sn, so) in alike if k >= sk and n >= sn and om <= so]
    if better:
        best = min(better, key=lambda s: rank[s["class"]])
        if best["class"] != "worse":
            return best["class"], (f"at least as stiff, fine and slow as the measured setting "
                                   f"'{best['name']}' ({CLASSES[best['class']]}"
                                   f"{_resolved(best)})")
    for s, (sk, sn, so) in alike:
        if s["class"] == "worse" and k <= sk and n <= sn and om >= so:
            return "worse", (f"at most as stiff, fine and slow as the measured setting "
                             f"'{s['name']}' ({CLASSES['worse']})")
    what = "k_n, n and Omega" + (" at this v_base and base_every" if plated else "")
    return "not measured", f"no measured setting brackets these {what}"


def _resolved(setting: dict) -> str:
    """What a measured setting's class vouches for: a pass, no bias above the study's
    resolution of that setting (the smallest bias its comparisons could show); and the
    verdict of the settings at its k_n pooled, where the study judged one."""
    text = ""
    if setting["class"] != "worse":
        res = setting.get("resolution")
        text = ("; biases below the study's resolution cannot be seen" +
                (f": {100 * res:.0f}% on its noisiest number" if res else ""))
    if setting.get("pooled"):
        text += f"; {setting['pooled']}"
    return text


def expectation(derived, *, prepared: bool, np_ranks: int = 1, omp_threads: int = 1) -> dict:
    """The forecast for a run of ``derived`` (a :class:`granavg.sim.scene.Derived`):
    expected wall time (s, one process) and accuracy class, for the manifest and the log.

    ``prepared``: the run shears a given packing (no growth phase)."""
    tables = studies()
    if not tables:
        return {"what": "no speed/accuracy study in this install (granavg/sim/trade*.json)"}
    s = derived.scene
    steps = derived.n_shear + (0 if prepared else derived.n_grow + derived.n_relax)
    frames = derived.n_shear // derived.dump_every + 1 if derived.dump_every else 0
    seconds = wall_time(steps, s.n_small + s.n_large, frames, tables,
                        rolling=derived.coeffs.mu_roll > 0, mu_base=s.mu_base,
                        base_every=s.base_every)
    cls, why = accuracy_class(s.to_dict(), tables)
    return {"wall_time_s": seconds, "accuracy_class": cls, "accuracy_reason": why,
            "parallel": np_ranks * omp_threads > 1,
            "assumes": f"{tables[0]['machine']}, no other job running",
            "what": f"forecast from {tables[0]['measured']} ({tables[0]['machine']}); wall "
                    "time of one single-threaded LAMMPS process, within about "
                    f"{100 * max(t['time_spread'] for t in tables):.0f}% there"}


#: The dump interval, in contact durations t_c, that gave a median momentum residual in
#: time of 1% of rho g at bulk nodes on the column collapse (lammps_inputs/collapse_2d.lmp
#: dumped every step and thinned: 1% between 4 and 7 steps of t_c/50; docs/time.md):
#: the forecast before a run takes it, and scales it with order 1 for other targets.
CALIBRATED_INTERVAL_TC = 0.13


def dump_interval(t_c: float, dt: float, dump_every: int, target: float = 0.01) -> dict:
    """The dump interval that fields in time need for a median residual ``target`` of
    the momentum balance in time, forecast before a run from its contact duration
    ``t_c`` (s), against the run's own (``dump_every`` steps of ``dt``): for the
    manifest and the log. Calibrated on one scene, the collapse; after the run
    ``granavg average`` forecasts it from the data themselves
    (:func:`granavg.analysis.time_balance.interval_forecast`)."""
    interval = CALIBRATED_INTERVAL_TC * t_c * target / 0.01
    steps = max(1, int(interval / dt))
    return {"target": target, "interval_s": interval, "every_steps": steps,
            "in_contact_durations": interval / t_c,
            "run_dumps_every_s": dump_every * dt,
            "run_in_contact_durations": dump_every * dt / t_c,
            "what": f"{CALIBRATED_INTERVAL_TC:g} t_c for a median residual of 1% of rho g, "
                    "measured on the 2D column collapse (docs/time.md), scaled with order "
                    "1; another scene's collisions may move it several-fold either way: "
                    "granavg average forecasts it from the run's own frames"}


def describe_dump_interval(f: dict) -> str:
    """One log line for :func:`dump_interval`."""
    return (f"fields in time: a median momentum residual of {f['target']:g} needs frames "
            f"every {f['interval_s']:.3g} s ({f['every_steps']} steps, "
            f"{f['in_contact_durations']:.2g} contact durations; forecast, {f['what']}); "
            f"this run dumps every {f['run_dumps_every_s']:.3g} s "
            f"({f['run_in_contact_durations']:.3g} contact durations)")


def describe(forecast: dict) -> str:
    """One log line for a forecast."""
    if "wall_time_s" not in forecast:
        return forecast["what"]
    t = forecast["wall_time_s"]
    when = f"{t / 60:.1f} min" if t >= 60 else f"{t:.0f} s"
    more = " (more processes: less; the study timed one)" if forecast["parallel"] else ""
    assumes = forecast.get("assumes", "")
    return (f"expected wall time {when} on the study's machine{more}"
            + (f" ({assumes}; other jobs on the cores: longer)" if assumes else "")
            + "; expected accuracy: "
            f"{forecast['accuracy_class']} - {forecast['accuracy_reason']}")
