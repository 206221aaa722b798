"""What a simulation will cost and how accurate it will be, from the measured study.

The speed/accuracy study (``workflows/sweep.py``, docs/sweep/) measured, on a 2-core
machine, the cost of LAMMPS steps and frames and, for the `paper-rolling` scene, how far each
setting of (k_n, n = t_c/dt, Omega) lands from the stiff, fine-step limit. ``trade.json``
beside this module holds what it measured (``sweep.py OUT --ship`` writes it).
:func:`expectation` turns that into a forecast for a scene: the expected wall time of one
LAMMPS process and the accuracy class of its settings. It is a forecast, not a
measurement: another machine scales the time, and the class holds only for the scene
the study measured (``paper-rolling``'s geometry, disks, contact law and packings, without
base-plate friction; anything else, the ``paper`` preset included, is "not measured").
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

from granavg.sim.scene import Scene

STUDY = Path(__file__).with_name("trade.json")
#: scene fields that must equal the study's for its accuracy classes to apply
SAME_SCENE = ("R_i", "R_o", "n_small", "n_large", "d_s", "d_l", "rho_p", "e_n", "mu",
              "mu_wall", "mu_roll", "kt_over_kn", "size_spread", "packing", "mu_base", "v_base",
              "base_every")
#: what base-plate friction adds to a disk-step (the deck's atom-style variables,
#: evaluated every step; the same whatever the contact law), in units of a disk-step of
#: ``pair granular`` with rolling resistance: the paper cell two runs at a time took 2.03
#: (1838 s against 907 s for 1.07 million steps) and 2.2 (1.88 against 0.85 ms per
#: step) times as long with it (docs/steady-state.md)
BASE_FRICTION_EXTRA = 1.1
#: the same with the friction's coefficient renewed every ``base_every`` > 0 steps (two
#: atom-style variables a step remain): measured at 10, the `paper` ensemble two runs at a
#: time took 422 s of LAMMPS against 526 s with the friction in full each step, the same
#: session (docs/steady-state.md, issue 28): (1 + 1.1) x 422 / 526 - 1
BASE_FRICTION_EXTRA_RENEWED = 0.68
CLASSES = {"5%": "no headline number showed a bias above 5% of the stiff limit (biases "
                  "below the study's resolution, 12-27%, cannot be seen)",
           "10%": "no headline number showed a bias above 10% of the stiff limit",
           "worse": "some headline number showed a bias above 10% of the stiff limit"}


@lru_cache(maxsize=1)
def study() -> dict | None:
    """The measured study (``trade.json``), or None if this install has none."""
    return json.loads(STUDY.read_text()) if STUDY.exists() else None


def wall_time(n_steps: int, n_disks: int, n_frames: int, table: dict,
              rolling: bool = True, base: bool = False, base_every: int = 0) -> float:
    """Expected wall time (s) of one single-threaded LAMMPS process: ``n_steps`` steps of
    ``n_disks`` disks and ``n_frames`` frames taken (contact dump, in-situ averaging),
    at the study's measured seconds per disk-step (of ``pair granular`` with rolling
    resistance, or of the plain ``gran/hooke/history`` law, 3.5 times faster here; plus
    :data:`BASE_FRICTION_EXTRA` rolling-law disk-steps with base-plate friction, or
    :data:`BASE_FRICTION_EXTRA_RENEWED` with its coefficient renewed every ``base_every``
    > 0 steps) and per disk-frame."""
    step = table["seconds_per_disk_step"] if rolling else \
        table.get("seconds_per_disk_step_plain_law", table["seconds_per_disk_step"])
    extra = BASE_FRICTION_EXTRA_RENEWED if base_every else BASE_FRICTION_EXTRA
    step += extra * table["seconds_per_disk_step"] if base else 0.0
    return n_disks * (n_steps * step + n_frames * table["seconds_per_disk_frame"])


def accuracy_class(scene: dict, table: dict) -> tuple[str, str]:
    """The accuracy class of ``scene``'s settings and why: (class, reason).

    A measured setting has its own class. Otherwise a scene at least as stiff (k_n), fine (n) and slow (Omega) as a measured setting is
    given that setting's class (the best such); one at most as stiff, fine and slow as a
    setting measured "worse" is "worse"; anything else, or another scene, is "not
    measured". The class is about the bias of the settings; the statistical error depends
    on run length and realisations and comes with every number of the report."""
    ref = {**Scene().to_dict(), **table["scene"]}   # keys added since the study: defaults
    differs = [k for k in SAME_SCENE if scene.get(k) != ref.get(k)]
    if differs:
        return "not measured", (f"the study measured one scene, docs/sweep/'s (this scene "
                                f"differs in {', '.join(differs)})")
    k, n, om = scene["k_n"], scene["n_per_tc"], scene["Omega"]
    for s in table["settings"]:
        if (s["k_n"], s["n_per_tc"], s["Omega"]) == (k, n, om):
            return s["class"], f"the measured setting '{s['name']}' ({CLASSES[s['class']]})"
    rank = {"5%": 0, "10%": 1, "worse": 2}
    better = [s for s in table["settings"]
              if k >= s["k_n"] and n >= s["n_per_tc"] and om <= s["Omega"]]
    if better:
        best = min(better, key=lambda s: rank[s["class"]])
        if best["class"] != "worse":
            return best["class"], (f"at least as stiff, fine and slow as the measured setting "
                                   f"'{best['name']}' ({CLASSES[best['class']]})")
    for s in table["settings"]:
        if s["class"] == "worse" and k <= s["k_n"] and n <= s["n_per_tc"] and om >= s["Omega"]:
            return "worse", (f"at most as stiff, fine and slow as the measured setting "
                             f"'{s['name']}' ({CLASSES['worse']})")
    return "not measured", "no measured setting brackets these k_n, n and Omega"


def expectation(derived, *, prepared: bool, np_ranks: int = 1, omp_threads: int = 1) -> dict:
    """The forecast for a run of ``derived`` (a :class:`granavg.sim.scene.Derived`):
    expected wall time (s, one process) and accuracy class, for the manifest and the log.

    ``prepared``: the run shears a given packing (no growth phase)."""
    table = study()
    if table is None:
        return {"what": "no speed/accuracy study in this install (granavg/sim/trade.json)"}
    s = derived.scene
    steps = derived.n_shear + (0 if prepared else derived.n_grow + derived.n_relax)
    frames = derived.n_shear // derived.dump_every + 1 if derived.dump_every else 0
    seconds = wall_time(steps, s.n_small + s.n_large, frames, table,
                        rolling=derived.coeffs.mu_roll > 0, base=s.mu_base > 0,
                        base_every=s.base_every)
    cls, why = accuracy_class(s.to_dict(), table)
    return {"wall_time_s": seconds, "accuracy_class": cls, "accuracy_reason": why,
            "parallel": np_ranks * omp_threads > 1,
            "what": f"forecast from {table['measured']} ({table['machine']}); wall time of "
                    "one single-threaded LAMMPS process, within about "
                    f"{100 * table['time_spread']:.0f}% there"}


def describe(forecast: dict) -> str:
    """One log line for a forecast."""
    if "wall_time_s" not in forecast:
        return forecast["what"]
    t = forecast["wall_time_s"]
    when = f"{t / 60:.1f} min" if t >= 60 else f"{t:.0f} s"
    more = " (more processes: less; the study timed one)" if forecast["parallel"] else ""
    return (f"expected wall time {when} on the study's machine{more}; expected accuracy: "
            f"{forecast['accuracy_class']} - {forecast['accuracy_reason']}")
