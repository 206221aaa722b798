"""The Couette cell scene: geometry, contact law, schedule; presets and validation.

Every quantity is in SI units (m, s, kg, N, rad/s). A :class:`Scene` is what a user
chooses (``--preset`` plus ``--set key=value``); :meth:`Scene.derive` turns it into the
numbers LAMMPS needs (masses, damping, time step, step counts) and refuses, with one
line, a scene that cannot run soundly.

Why these constants (the paper gives none): see ``docs/scene.md``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from granavg.sim.contact_law import (ContactLaw, LammpsCoefficients, disk_mass, effective_mass,
                                     max_stable_timestep, restitution, to_lammps)
from granavg.errors import ParameterError, UserError, literal

#: Highest area fraction accepted: random close packing of bidisperse disks is about
#: 0.84 (O'Hern et al. 2003); above it disks cannot fit without large overlaps.
MAX_AREA_FRACTION = 0.84
#: Fewest time steps per small-small contact duration accepted (accuracy bound; the
#: Verlet stability limit of the contact law is checked as well).
MIN_STEPS_PER_CONTACT = 10.0
#: gravity for the base-plate friction (m/s^2), as in the deck
G = 9.81
#: bound of the base plate's damping per step, lambda dt = mu_base g dt / v_base: the
#: explicit step of its linear part (v < v_base) is stable only below 2; above, each disk's
#: half-step velocity flips sign every step (measured, docs/stability.md: 1.8 sound, 2.2
#: jitters by 3e-8 m a step, or 6e-7 m with the coefficient renewed every 10 steps, 4
#: blows up with it)
MAX_BASE_DAMPING = 2.0
#: bound of the contacts' dashpot per step, gamma_n dt = -2 ln(e_n) / n_per_tc: a disk
#: damped by several contacts at once is integrated soundly only below it (measured in the
#: paper packing, docs/stability.md: 0.51 sound, 0.55 the disks' energy grows 30-fold,
#: 1.1 blows up, whatever e_n and n_per_tc give it); two disks alone allow more
MAX_DASHPOT_DAMPING = 0.5
#: the plate's coefficient renewed at most every this many contact times (base_every /
#: n_per_tc): measured sound at 1 (the study's base_every = 50, docs/sweep); at 4 and 20
#: the bulk pressure lies above the stiff limit by more than 5%, and past 10 steps a
#: renewal saves nothing (docs/stability.md)
MAX_RENEWAL_CONTACTS = 1.0


@dataclass(frozen=True)
class Scene:
    """Everything that defines a Couette run (SI units).

    Geometry (paper, section 2): ``R_i``, ``R_o`` ring radii (m), ``h`` disk height (m),
    ``d_s``, ``d_l`` diameters (m), ``n_small``, ``n_large`` counts, ``rho_p`` material
    density (kg/m^3), ``Omega`` inner-ring angular velocity (rad/s, counter-clockwise);
    ``size_spread``: each disk's diameter is its nominal one times 1 + size_spread u, u
    uniform in [-1, 1] (0 = the paper's two sizes exactly).
    Contact law: ``law`` (:class:`~granavg.sim.contact_law.ContactLaw`; its fields ``k_n``,
    ``e_n``, ... are set like scene keys); ``n_per_tc`` time steps per contact duration
    (dt = t_c / n).
    Base plate: ``mu_base`` (0 = none) Coulomb friction of every disk with the plate it
    slides on, F = -mu_base m g v / sqrt(v^2 + v_base^2) (g = 9.81 m/s^2; linear below
    ``v_base`` m/s, which keeps it smooth for the integrator): evaluated each step
    (``base_every`` 0), or applied as c v with the coefficient c = -mu_base m g /
    sqrt(v^2 + v_base^2) renewed every ``base_every`` steps (cheaper).
    Walls: rings of glued disks of diameter ``wall_d`` (m, 0 = d_s) whose centres are
    ``wall_spacing * wall_d`` apart, touching R_i and R_o from outside the annulus.
    Schedule: preparation (insert at ``grow_from`` times the diameter, grow over
    ``t_grow`` s with viscous damping time ``t_damp`` s, relax ``t_relax`` s), then shear
    for ``t_end`` s; dumps (frames for averaging) every ``dump_every`` steps (0 = about
    ``dump_dt`` s) from ``t_dump_start`` s; restart files every ``restart_dt`` s of shear.
    Start: ``packing`` names a set of shipped sheared packings
    (:mod:`granavg.sim.packings`): the run shears the one grown from ``seed`` instead of
    preparing a new packing ('' = prepare one).
    Averaging: ``discard_rotations`` inner-ring rotations of shear (the transient) are left
    out of the averages by default (t_min = discard_rotations 2 pi / Omega, s).
    Output: ``contacts`` (contact forces computed and dumped), ``dumps`` (dump files
    written; 0 with in-situ averaging only), ``gzip``.
    """

    R_i: float = 0.1032
    R_o: float = 0.2524
    h: float = 0.006
    d_s: float = 0.00742
    d_l: float = 0.00899
    n_small: int = 2538
    n_large: int = 407
    rho_p: float = 1060.0
    size_spread: float = 0.0
    Omega: float = 0.1
    law: ContactLaw = ContactLaw()
    mu_base: float = 0.0
    v_base: float = 0.001
    base_every: int = 0
    n_per_tc: float = 50.0
    wall_d: float = 0.0
    wall_spacing: float = 0.9
    grow_from: float = 0.5
    t_grow: float = 5.0
    t_relax: float = 5.0
    t_damp: float = 0.5
    t_end: float = 500.0
    t_dump_start: float = 0.0
    dump_every: int = 0
    dump_dt: float = 2.0
    restart_dt: float = 25.0
    discard_rotations: float = 2.0
    seed: int = 20011
    packing: str = ""
    contacts: bool = True
    dumps: bool = True
    gzip: bool = True

    def with_overrides(self, pairs) -> "Scene":
        """Return a copy with ``key=value`` strings applied (``--set``), type-checked."""
        known = {f.name: f.type for f in (*fields(self), *fields(ContactLaw))
                 if f.name != "law"}
        changes = {}
        for pair in pairs:
            key, sep, text = pair.partition("=")
            key = key.strip()
            if not sep:
                raise ParameterError("overrides", f"{{param}} {literal(repr(pair))}: expected "
                                     "key=value, e.g. {param} k_n=100")
            if key not in known:
                raise ParameterError("overrides", f"{{param}} {literal(key)}: unknown key; "
                                     f"known keys: {', '.join(known)}")
            changes[key] = _parse(key, text.strip(), known[key])
        return Scene.from_dict({**self.to_dict(), **changes})

    def to_dict(self) -> dict:
        """Every scene value, the contact law's included, under its ``--set`` key."""
        flat = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "law"}
        return {**flat, **dataclasses.asdict(self.law)}

    @classmethod
    def from_dict(cls, values: dict) -> "Scene":
        """Inverse of :meth:`to_dict` (for instance from a run's manifest)."""
        law_keys = {f.name for f in fields(ContactLaw)}
        law = ContactLaw(**{k: v for k, v in values.items() if k in law_keys})
        return cls(law=law, **{k: v for k, v in values.items() if k not in law_keys})

    def derive(self) -> "Derived":
        """Derived numbers for LAMMPS, after refusing scenes that cannot run soundly."""
        _check_geometry(self)
        m_s = disk_mass(self.d_s, self.rho_p, self.h)
        m_l = disk_mass(self.d_l, self.rho_p, self.h)
        coeffs = to_lammps(self.law, effective_mass(m_s, m_s))
        dt = coeffs.t_c / self.n_per_tc
        dt_safe = min(coeffs.t_c / MIN_STEPS_PER_CONTACT,
                      max_stable_timestep(coeffs, effective_mass(m_s, m_s)))
        if dt > dt_safe:
            raise UserError(
                f"time step dt = t_c/{self.n_per_tc:g} = {dt:.3g} s is above the safe bound "
                f"{dt_safe:.3g} s of the contact law (t_c = {coeffs.t_c:.3g} s); "
                f"set n_per_tc >= {coeffs.t_c / dt_safe:.3g}")
        if coeffs.gamma_n * dt >= MAX_DASHPOT_DAMPING:
            raise UserError(
                f"restitution e_n = {self.law.e_n:.3g} damps each contact at gamma_n dt = "
                f"{coeffs.gamma_n * dt:.3g} per step of dt = t_c/{self.n_per_tc:g}: a packing "
                f"is integrated soundly only below {MAX_DASHPOT_DAMPING:g} per step (above, "
                "the disks' energy grows or they blow up; docs/stability.md); set n_per_tc "
                f"> {coeffs.gamma_n * coeffs.t_c / MAX_DASHPOT_DAMPING:.3g} or raise e_n")
        if self.mu_base * G * dt / self.v_base >= MAX_BASE_DAMPING:
            raise UserError(
                f"base friction mu_base = {self.mu_base:g} with v_base = {self.v_base:.3g} m/s "
                f"damps at mu_base g / v_base = {self.mu_base * G / self.v_base:.3g} 1/s, "
                f"{self.mu_base * G * dt / self.v_base:.3g} per step of dt = {dt:.3g} s: the "
                f"plate's law is integrated soundly only below {MAX_BASE_DAMPING:g} per step "
                f"(above, the disks jitter or blow up; docs/stability.md); set v_base > "
                f"{self.mu_base * G * dt / MAX_BASE_DAMPING:.3g} m/s or raise n_per_tc")
        if self.mu_base > 0 and self.base_every > MAX_RENEWAL_CONTACTS * self.n_per_tc:
            raise UserError(
                f"base_every = {self.base_every} renews the plate's friction coefficient every "
                f"{self.base_every / self.n_per_tc:.3g} contact times (t_c = "
                f"{self.n_per_tc:g} steps): measured sound only up to "
                f"{MAX_RENEWAL_CONTACTS:g} (beyond, the bulk pressure drifts above the stiff "
                "limit and no time is saved; docs/stability.md); set base_every <= "
                f"{math.floor(MAX_RENEWAL_CONTACTS * self.n_per_tc)}")
        n_shear = int(round(self.t_end / dt))
        dump_every = self.dump_every or max(1, int(round(self.dump_dt / dt)))
        return Derived(
            scene=self, coeffs=coeffs, dt=dt, m_small=m_s, m_large=m_l,
            wall_d=self.wall_d or self.d_s,
            area_fraction=area_fraction(self),
            n_grow=max(1, int(round(self.t_grow / dt))),
            n_relax=max(1, int(round(self.t_relax / dt))),
            n_shear=n_shear,
            n_dump_start=int(math.ceil(self.t_dump_start / dt / dump_every)) * dump_every,
            dump_every=dump_every,
            restart_every=max(dump_every,
                              int(round(self.restart_dt / dt / dump_every)) * dump_every),
            dt_safe=dt_safe,
        )


@dataclass(frozen=True)
class Derived:
    """Numbers derived from a :class:`Scene` (SI units; counts are time steps)."""

    scene: Scene
    coeffs: LammpsCoefficients
    dt: float
    m_small: float
    m_large: float
    wall_d: float
    area_fraction: float
    n_grow: int
    n_relax: int
    n_shear: int
    n_dump_start: int
    dump_every: int
    restart_every: int
    dt_safe: float

    @property
    def blowup_speed(self) -> float:
        """Speed (m/s) that no disk of a sound run approaches: 10 x the larger of the
        outer edge of the inner ring's speed Omega R_o and the speed 0.2 d_s omega_n a
        small disk gets from an overlap of 0.2 d_s (omega_n = sqrt(k_n/m_s))."""
        s = self.scene
        v_contact = 0.2 * s.d_s * math.sqrt(self.coeffs.kn / self.m_small)
        return 10.0 * max(s.Omega * s.R_o, v_contact)

    @property
    def ke_max(self) -> float:
        """Blow-up bound of the disks' kinetic energy, J: all of them at
        :attr:`blowup_speed`."""
        s = self.scene
        mass = s.n_small * self.m_small + s.n_large * self.m_large
        return 0.5 * mass * self.blowup_speed ** 2

    @property
    def period(self) -> float:
        """Rotation period of the inner ring T = 2 pi / Omega (s)."""
        return 2.0 * math.pi / self.scene.Omega

    @property
    def t_discard(self) -> float:
        """Default start of the averages, s: ``discard_rotations`` periods of shear."""
        return self.scene.discard_rotations * self.period

    def restitutions(self) -> dict:
        """Normal restitution of each pair kind for the single LAMMPS gamma_n."""
        c, ms, ml = self.coeffs, self.m_small, self.m_large
        pairs = {"small-small": effective_mass(ms, ms), "small-large": effective_mass(ms, ml),
                 "large-large": effective_mass(ml, ml), "small-wall": ms, "large-wall": ml}
        return {k: restitution(c.kn, c.gamma_n, m) for k, m in pairs.items()}

    def lammps_variables(self) -> dict:
        """The deck's variables (``-var name value``), all in SI units."""
        s, c = self.scene, self.coeffs
        return {
            "R_i": s.R_i, "R_o": s.R_o, "h": s.h, "d_s": s.d_s, "d_l": s.d_l,
            "n_small": s.n_small, "n_large": s.n_large, "rho_area": s.rho_p * s.h,
            "Omega": s.Omega, "kn": c.kn, "kt": c.kt, "gamma_n": c.gamma_n,
            "gamma_t": c.gamma_t, "mu": c.mu, "mu_wall": c.mu_wall, "dt": self.dt,
            "mu_roll": c.mu_roll, "k_roll": c.k_roll, "gamma_roll": c.gamma_roll,
            "mu_base": s.mu_base, "v_base": s.v_base, "base_every": s.base_every,
            "x_gamma_t": c.gamma_t / c.gamma_n if c.gamma_n else 0.0,
            "wall_d": self.wall_d, "wall_spacing": s.wall_spacing, "size_spread": s.size_spread,
            "grow_from": s.grow_from, "n_grow": self.n_grow, "n_relax": self.n_relax,
            "damp_gamma": self.m_small / s.t_damp, "n_shear": self.n_shear,
            "n_dump_start": self.n_dump_start, "dump_every": self.dump_every,
            "restart_every": self.restart_every, "seed": s.seed,
            "ke_max": self.ke_max, "halt_every": 100,
        }


def area_fraction(s: Scene) -> float:
    """Expected area of all disks over the annulus area pi (R_o^2 - R_i^2): the paper's
    0.8134 (a uniform size spread s raises the mean d^2 by the factor 1 + s^2 / 3)."""
    disks = math.pi / 4 * (s.n_small * s.d_s**2 + s.n_large * s.d_l**2)
    return disks * (1 + s.size_spread**2 / 3) / (math.pi * (s.R_o**2 - s.R_i**2))


def _check_geometry(s: Scene) -> None:
    bad = [k for k, v in s.to_dict().items() if isinstance(v, (int, float))
           and not isinstance(v, bool) and not math.isfinite(v)]
    problems = [
        (not bad, f"{bad[0]} = {getattr(s, bad[0])}: every value must be finite" if bad
         else ""),
        (0 < s.R_i < s.R_o, f"need 0 < R_i < R_o (got R_i={s.R_i}, R_o={s.R_o} m)"),
        (min(s.h, s.d_s, s.d_l, s.rho_p, s.Omega) > 0, "h, d_s, d_l, rho_p, Omega must be > 0"),
        (s.n_small >= 0 and s.n_large >= 0 and s.n_small + s.n_large > 0,
         "need at least one disk"),
        (s.R_o - s.R_i > 2 * max(s.d_s, s.d_l), "the annulus must be wider than two diameters"),
        (0 < s.grow_from <= 1, "grow_from must be in (0, 1]"),
        (0 <= s.size_spread <= 0.3, "size_spread must be in [0, 0.3]"),
        (s.mu_base >= 0 and s.v_base > 0, "need mu_base >= 0 and v_base > 0"),
        (0 <= s.base_every <= 1000, "base_every must be from 0 (each step) to 1000 steps"),
        (0 < s.wall_spacing <= 0.9, "wall_spacing must be in (0, 0.9] wall diameters"
         " (gaps would let disks through)"),
        (min(s.t_grow, s.t_relax, s.t_damp, s.t_end, s.dump_dt, s.restart_dt) > 0
         and s.t_dump_start >= 0, "times must be > 0 (t_dump_start >= 0)"),
        (s.t_dump_start < s.t_end, f"t_dump_start={s.t_dump_start} s must be < t_end={s.t_end} s"),
        (s.discard_rotations >= 0, "discard_rotations must be >= 0"),
        (s.n_per_tc > 0 and s.dump_every >= 0, "n_per_tc must be > 0, dump_every >= 0"),
    ]
    for ok, msg in problems:
        if not ok:
            raise ParameterError("overrides", f"scene: {literal(msg)}; fix the {{param}} "
                                 "value")
    nu = area_fraction(s)
    if nu > MAX_AREA_FRACTION:
        raise UserError(
            f"scene: {s.n_small}+{s.n_large} disks cover an area fraction {nu:.3f} of the "
            f"annulus, above random close packing ({MAX_AREA_FRACTION}); they cannot fit. "
            f"Use fewer disks or a larger R_o")


def _parse(key, text, typ):
    try:
        if typ in ("bool", bool):
            if text.lower() not in ("1", "0", "true", "false", "yes", "no"):
                raise ValueError
            return text.lower() in ("1", "true", "yes")
        if typ in ("str", str):
            return text
        if typ in ("int", int):
            return int(text)
        return float(text)
    except ValueError:
        raise ParameterError("overrides", f"{{param}} {literal(key)}={literal(text)}: expected "
                             f"a {getattr(typ, '__name__', typ)}") from None


PAPER_HOOKE = Scene()
"""The paper's scene with the plain ``pair gran/hooke/history`` law, grown from random
positions, 500 s of shear (section 2). It relaxes for the whole run into a barely jammed
state (docs/steady-state.md)."""

PAPER_ROLLING = dataclasses.replace(PAPER_HOOKE, law=ContactLaw(mu_roll=0.3),
                                    packing="rolling-sheared", t_end=250.0,
                                    discard_rotations=0.1)
"""The paper's scene with rolling resistance and no base friction (issue 12,
docs/steady-state.md): the plain law plus rolling resistance (``pair granular``, mu_roll
= 0.3), sheared for 250 s from a shipped packing grown with the seed and already sheared
250 s with this law (:mod:`granavg.sim.packings`); the first tenth of a rotation (6.3 s:
the contact springs reload after the start from a data file) is left out of the
averages. Jammed and quasi-static, but ageing: its bulk pressure falls by about 6% over
the 250 s. The scene of the first speed/accuracy study (docs/sweep/paper-rolling)."""

PAPER_STRONG_PLATE = dataclasses.replace(PAPER_ROLLING, mu_base=0.03,
                                         packing="rolling-base-sheared", t_end=50.0,
                                         dump_dt=1.0, restart_dt=12.5)
""":data:`PAPER_ROLLING`'s law with a strong, smooth friction against the base plate
(mu_base = 0.03, v_base = 1 mm/s; issue 12, docs/steady-state.md), sheared 50 s (frames
every second) from shipped packings already sheared 250 s with rolling resistance and
100 s more with this friction. Steady, jammed, the paper's v0, but a band half the
paper's width (s about 5-6 mm): the plate's Coulomb cap acts in the band. The ``paper``
preset until issue 28."""

PAPER = dataclasses.replace(PAPER_STRONG_PLATE, mu_base=0.005, v_base=1e-4, base_every=10,
                            packing="rolling-coulomb-sheared")
"""The default paper scene (issue 28, docs/steady-state.md): :data:`PAPER_ROLLING`'s law
(mu_roll = 0.3) with the base plate's friction near its Coulomb limit (mu_base = 0.005,
v_base = 0.1 mm/s: a drag of rate mu_base g / v_base on the creeping bulk, which stops the
packing's slow ageing, and a cap a sixth of :data:`PAPER_STRONG_PLATE`'s in the band),
sheared 50 s (0.8 rotation, frames every second) from shipped packings already sheared
250 s with rolling resistance, 100 s with the strong plate and 150 s with this one; the
first tenth of a rotation (6.3 s) is left out; the friction's coefficient is renewed
every 10 steps (``base_every``: 0.81 of the CPU time of the law each step, the same
fields; docs/sweep). Jammed, quasi-static and steady; its band (s about 8 mm by the
stated estimator) is still narrower than the paper's 12.7 mm, and at its k_n = 10 N/m
probably narrower than for stiff disks on the same plate (the speed/accuracy study,
docs/sweep: 23 +- 11%, at the edge of its 2-error rule; accuracy class 5%, resolved to
34%; 9.3 mm at k_n = 100, 3 times the cost).
The precision comes from realisations (four seeds: the four shipped packings)."""

FAST = dataclasses.replace(PAPER_ROLLING, law=dataclasses.replace(PAPER_ROLLING.law, k_n=2.5),
                           t_end=60.0, dump_dt=0.5, restart_dt=15.0)
"""The cheapest scene within 10% of the stiff limit in the speed/accuracy study
(docs/sweep/paper-rolling/), which measured the rolling-resistance scene without base
friction: springs four times softer than ``paper-rolling``'s (k_n = 2.5 N/m, same restitution: half the
steps per second of shear), 60 s from its shipped packings with frames every 0.5 s."""

DEMO = dataclasses.replace(PAPER, t_end=30.0, dump_dt=0.5, restart_dt=15.0)
"""What ``granavg demo`` runs: :data:`PAPER` for 30 s (one realisation, frames every
0.5 s)."""

PRESETS = {"paper": PAPER, "fast": FAST, "demo": DEMO, "paper-rolling": PAPER_ROLLING,
           "paper-strong-plate": PAPER_STRONG_PLATE, "paper-hooke": PAPER_HOOKE}


def preset(name: str) -> Scene:
    """The named preset scene; a one-line refusal for an unknown name."""
    try:
        return PRESETS[name]
    except KeyError:
        raise UserError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}") from None
