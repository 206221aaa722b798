"""Helpers shared by the test modules: the real CLI in a subprocess, the small Couette
cell's arguments, the LAMMPS decks of tests/decks run in-process, dumps read without
granavg, and configurations whose answer is known exactly.

Test modules import these from here (or from conftest.py), never from one another;
the session fixtures that run each deck once live in conftest.py."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from granavg.analysis.continuum import deformation_rate_and_spin
from granavg.engine.cell_average import CellAverage
from granavg.engine.spec import Averaging
from granavg.engine.cells.rings import Rings
from granavg.engine.fields import Fields
from granavg.engine.quantities import QUANTITIES
from granavg.engine.uncertainty.blocking import Replicates
from granavg.io.contacts import COLUMNS, contact_table, radius_by_id
from granavg.io.frames import Frame
from granavg.io.profiles_io import read_profiles
from granavg.sim.lammps_session import lammps_session, load_lammps
from granavg.sim.run_layout import DECK as COUETTE_DECK, cmdargs
from granavg.sim.scene import PAPER_HOOKE
from granavg.sim.simulate import deck_variables

DECKS = Path(__file__).parent / "decks"

# -- the real CLI, the small Couette cell --------------------------------------------------

#: The preset the small cell derives from: the plain gran/hooke/history law, grown from
#: random positions (the shipped sheared packings are of the full cell).
SMALL_PRESET = "paper-hooke"
#: A few hundred disks at the paper's area fraction (0.8136) in a smaller annulus,
#: sheared faster (Omega = 0.5 rad/s) for 4 s so the drag shows in a short run.
SMALL_CELL = ["R_i=0.04", "R_o=0.0826", "n_small=250", "n_large=40", "Omega=0.5",
              "t_grow=1", "t_relax=1", "t_end=4", "t_dump_start=1", "dump_dt=0.25",
              "restart_dt=1"]


def run_cli(*args, timeout=600, env=None, **kwargs):
    """Run ``python -m granavg ARGS`` for real (in ``env``, default this process'
    environment); returns the CompletedProcess."""
    env = dict(os.environ if env is None else env, PYTHONUNBUFFERED="1")
    return subprocess.run([sys.executable, "-m", "granavg", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, env=env, **kwargs)


def dump_positions(run):
    """The disks' (x, y) in every frame of a run's atom dump, ordered by id; shape
    (frames, disks, 2)."""
    from granavg.io.reader import DumpReader

    out = []
    for frame in DumpReader(Path(run) / "atoms.dump.gz"):
        a = frame.as_dict()
        order = np.argsort(a["id"])
        out.append(np.stack([a["x"][order], a["y"][order]], axis=1))
    return np.asarray(out)


def small_cell_args(out, *extra_sets, np=1):
    sets = [a for s in (*SMALL_CELL, *extra_sets) for a in ("--set", s)]
    return ["simulate", "--preset", SMALL_PRESET, "--out", out, "--no-progress", "--np", np, *sets]


def live_frame_and_virial(out, *sets):
    """Run the small cell in-process; at its last step return the frame (contact table
    built as granavg writes it), the trace of LAMMPS' summed per-atom pair stress of
    the disks (SI: N m in 2D), the disks' pair forces (N, by id) and their torques
    (N m, by id), all from the same LAMMPS state."""
    lammps = load_lammps()

    scene = PAPER_HOOKE.with_overrides([*SMALL_CELL, *sets])
    derived = scene.derive()
    out.mkdir()
    variables = deck_variables(out, derived, embedded=True, resume=None, start=None)
    with lammps_session(cmdargs(out, variables, 1)) as lmp:
        lmp.file(str(COUETTE_DECK))
        lmp.commands_string("""
            run 2000
            compute s mobile stress/atom NULL pair
            compute t mobile reduce sum c_s[1] c_s[2]
            thermo_style custom step c_t[1] c_t[2]
            run 0""")
        last = lmp.last_thermo()
        loc, arr = lammps.LMP_STYLE_LOCAL, lammps.LMP_TYPE_ARRAY
        raw = np.hstack([lmp.numpy.extract_compute("cprop", loc, arr),
                         lmp.numpy.extract_compute("cpair", loc, arr)])
        n = lmp.extract_global("nlocal")
        x = np.array(lmp.numpy.extract_atom("x")[:n])
        typ = np.array(lmp.numpy.extract_atom("type")[:n])
        ids = np.array(lmp.numpy.extract_atom("id")[:n], dtype=float)
        rad = np.array(lmp.numpy.extract_atom("radius")[:n])
        force = np.array(lmp.numpy.extract_atom("f")[:n, :2])
        torque = np.array(lmp.numpy.extract_atom("torque")[:n, 2])
        v = np.array(lmp.numpy.extract_atom("v")[:n, :2])
        omega = np.array(lmp.numpy.extract_atom("omega")[:n, 2])
    disk = typ <= 2
    order = np.argsort(ids[disk])
    atoms = {"id": ids[disk][order], "x": x[disk, 0][order], "y": x[disk, 1][order],
             "radius": rad[disk][order], "vx": v[disk, 0][order], "vy": v[disk, 1][order],
             "omegaz": omega[disk][order]}
    table = contact_table(raw, radius_by_id(ids, rad))
    frame = Frame(int(last["Step"]), 0.0, atoms, dict(zip(COLUMNS, table.T)))
    forces = dict(zip(ids[disk].astype(int), force[disk]))
    torques = dict(zip(ids[disk].astype(int), torque[disk]))
    return scene, derived, frame, last["c_t[1]"] + last["c_t[2]"], forces, torques


# -- tests/decks/pile_2d_lj.lmp: a 2D pile at rest, lj units, default %g dumps -----------

PILE2D_DECK = DECKS / "pile_2d_lj.lmp"
#: Its pair/local + property/local contact columns.
PILE2D_MAP = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
              "ftx=c_pl[5],fty=c_pl[6]")


def run_pile2d(out, units_header="no", floor="wall", kn=2000.0, precise="no"):
    """The user's deck in-process (``precise`` yes: per-atom forces, 17 digits);
    LAMMPS' summed pair virial (xx + yy) of the last dumped frame."""
    out.mkdir(parents=True, exist_ok=True)
    with lammps_session(["-log", str(out / "log.lammps"), "-var", "out", str(out),
                         "-var", "units_header", units_header, "-var", "floor", floor,
                         "-var", "kn", str(kn), "-var", "precise", precise]) as lmp:
        lmp.file(str(PILE2D_DECK))
        last = lmp.last_thermo()
    return last["c_t[1]"] + last["c_t[2]"]


def frames(path):
    """(header lines, column names, rows) of every frame, read here without granavg."""
    text = Path(path).read_text()
    out = []
    for block in text.split("ITEM: TIMESTEP\n")[1:]:
        lines = ("ITEM: TIMESTEP\n" + block).splitlines()
        k = next(i for i, ln in enumerate(lines) if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")))
        end = next((i for i in range(k + 1, len(lines)) if lines[i].startswith("ITEM:")),
                   len(lines))
        body = [ln for ln in lines[k + 1:end] if ln.strip()]
        out.append((lines[:k], lines[k].split()[2:], np.array([ln.split() for ln in body], float)))
    return out


# -- tests/decks/pile_3d_si.lmp: a 3D pile at rest, SI units, default %g dumps -----------

PILE3D_DECK = DECKS / "pile_3d_si.lmp"
#: Its contact columns (pair/local with dz); also those of pour_3d_lj.lmp.
MAP3 = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],"
        "force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]")


def run_pile3d(out, series="no", kn=100.0, heavy=1.0, bidisperse="no", precise="no",
               floor="wall", binary="no", yaml="no"):
    """The user's deck in-process (``heavy``: the odd ids' material that many times as
    dense; ``bidisperse`` yes: odd ids large, type 2; ``precise`` yes: per-atom forces
    and 17 digits; ``floor`` spheres: a layer of fixed type-3 spheres; ``binary`` yes:
    also atoms.bin, LAMMPS' binary atom dump; ``yaml`` yes: also atoms.yaml, its dump
    yaml); LAMMPS' summed pair virial (xx + yy + zz) of the last dumped frame."""
    out.mkdir(parents=True, exist_ok=True)
    with lammps_session(["-log", str(out / "log.lammps"), "-var", "out", str(out),
                         "-var", "series", series, "-var", "kn", str(kn),
                         "-var", "heavy", str(heavy), "-var", "bidisperse",
                         bidisperse, "-var", "precise", precise, "-var", "floor",
                         floor, "-var", "binary", binary, "-var", "yaml", yaml]) as lmp:
        lmp.file(str(PILE3D_DECK))
        last = lmp.last_thermo()
    return last["c_t[1]"] + last["c_t[2]"] + last["c_t[3]"]


def average_pile3d(pile_dir, dest, *extra, atoms="atoms.dump", contacts="contacts.dump"):
    """``granavg average`` of a 3D pile's dumps (in ``pile_dir``) with their contact
    columns; the profiles read back."""
    proc = run_cli("average", "--atoms", pile_dir / atoms, "--contacts", pile_dir / contacts,
                   "--contact-columns", MAP3, "--out", dest, "--no-progress", *extra)
    assert proc.returncode == 0, proc.stderr
    return read_profiles(dest)


# -- any deck of tests/decks with its variables (pour_3d_lj.lmp, tilted_lj.lmp) -----------

def run_user_deck(deck, out, **variables):
    """A deck in-process; the last thermo line."""
    out.mkdir(parents=True, exist_ok=True)
    args = ["-log", str(out / "log.lammps"), "-screen", "none", "-var", "out", str(out)]
    for k, v in variables.items():
        args += ["-var", k, str(v)]
    with lammps_session(args) as lmp:
        lmp.file(str(DECKS / deck))
        return lmp.last_thermo()


def cli(capsys, *args):
    """``granavg ARGS`` in this process: (exit code, stderr lines)."""
    from granavg.cli import main

    code = main([str(a) for a in args])
    return code, capsys.readouterr().err.splitlines()


def frame_lines(path):
    """The frames of a dump as lists of lines."""
    lines = Path(path).read_text().splitlines(keepends=True)
    starts = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: TIMESTEP")]
    return [lines[a:b] for a, b in zip(starts, starts[1:] + [len(lines)])]


def last_rows(path):
    """The last frame's rows as an array, and its column names."""
    f = frame_lines(path)[-1]
    head = next(k for k, ln in enumerate(f) if ln.startswith("ITEM: ATOMS"))
    return np.array([ln.split() for ln in f[head + 1:]], float), f[head].split()[2:]


# -- configurations whose answer is known exactly ------------------------------------------

#: The cubic crystal's material density (kg/m^3).
CUBIC_RHO_P = 2500.0


def cubic_crystal(a=0.002, delta=5e-5, k=100.0, n=14):
    """Spheres of radius a on a simple cubic lattice of spacing 2a - delta, every
    touching pair pushed apart by k delta along the line of centres (no friction)."""
    s = 2 * a - delta
    g = (np.arange(n) - (n - 1) / 2) * s
    x, y, z = (c.ravel() + 1e-7 for c in np.meshgrid(g, g, g, indexing="ij"))
    ids = np.arange(1, len(x) + 1, dtype=float)
    pos = np.column_stack([x, y, z])
    i, j = [], []
    idx = np.arange(len(x)).reshape(n, n, n)
    for ax in range(3):
        sl = [slice(None)] * 3
        lo, hi = list(sl), list(sl)
        lo[ax], hi[ax] = slice(0, -1), slice(1, None)
        i.append(idx[tuple(lo)].ravel())
        j.append(idx[tuple(hi)].ravel())
    i, j = np.concatenate(i), np.concatenate(j)
    d = pos[j] - pos[i]
    dist = np.linalg.norm(d, axis=1)
    nrm = d / dist[:, None]
    f = -k * delta * nrm                                  # on the first, away from j
    atoms = {"id": ids, "x": x, "y": y, "z": z, "radius": np.full(len(x), a),
             "vx": np.zeros(len(x)), "vy": np.zeros(len(x)), "vz": np.zeros(len(x)),
             "omegax": np.zeros(len(x)), "omegay": np.zeros(len(x)),
             "omegaz": np.zeros(len(x))}
    contacts = {"id1": ids[i], "id2": ids[j], "wall": np.zeros(len(i)),
                **{f"fn{c}": f[:, k] for k, c in enumerate("xyz")},
                **{f"ft{c}": np.zeros(len(i)) for c in "xyz"},
                **{f"n{c}": nrm[:, k] for k, c in enumerate("xyz")},
                "overlap": 2 * a - dist}
    return Frame(0, 0.0, atoms, contacts)


#: The hexagonal crystal's disk height (m) and material density (kg/m^3).
HEX_H, HEX_RHO_P = 0.006, 1060.0
#: Every quantity group but the body forces (none in the crystals).
NO_BODY = [g for g in QUANTITIES if "body" not in QUANTITIES[g].blocks]


def hex_crystal(a=0.004, delta=1e-4, k=10.0, extent=0.12):
    """A hexagonal crystal of disks of radius a, spacing 2a - delta, every touching pair
    pushed apart by a normal force k*delta (no friction), centred on the axis."""
    s = 2 * a - delta
    i, j = np.meshgrid(np.arange(-60, 61), np.arange(-70, 71))
    x = (s * (i + 0.5 * (j % 2))).ravel()
    y = (s * np.sqrt(3) / 2 * j).ravel()
    keep = np.hypot(x, y) < extent
    x, y = x[keep] + 1e-7, y[keep] + 2e-7          # no disk exactly on the axis
    ids = np.arange(1, len(x) + 1, dtype=float)
    dx = x[None, :] - x[:, None]
    dy = y[None, :] - y[:, None]
    dist = np.hypot(dx, dy)
    p, q = np.nonzero(np.triu((dist < 2 * a) & (dist > 0)))
    n = np.column_stack([dx[p, q], dy[p, q]]) / dist[p, q][:, None]
    fn = -k * delta * n                                # on the first disk, away from q
    atoms = {"id": ids, "x": x, "y": y, "radius": np.full(len(x), a),
             "vx": np.zeros(len(x)), "vy": np.zeros(len(x)), "omegaz": np.zeros(len(x))}
    contacts = {"id1": ids[p], "id2": ids[q], "wall": np.zeros(len(p)),
                "fnx": fn[:, 0], "fny": fn[:, 1], "ftx": np.zeros(len(p)),
                "fty": np.zeros(len(p)), "nx": n[:, 0], "ny": n[:, 1],
                "overlap": 2 * a - dist[p, q]}
    return Frame(0, 0.0, atoms, contacts)


def ring_average(frames, rings, groups=NO_BODY, block_time=1.0, branch="contact"):
    return CellAverage(frames, rings, groups, HEX_RHO_P,
                       Averaging.of(t_min=0.0, block_time=block_time, branch=branch)
                       ).run(progress=False)


# -- synthetic Couette profiles with the paper's physics (the claims' checks) ------------

SCENE = {"R_i": 0.1032, "R_o": 0.2524, "h": 0.006, "d_s": 0.00742, "d_l": 0.00899,
         "n_small": 2538, "n_large": 407, "rho_p": 1060.0, "Omega": 0.1, "k_n": 10.0}
D_MEAN = (2538 * 0.00742 + 407 * 0.00899) / 2945
PI_H = np.pi * SCENE["h"]


def rotate(theta, major, minor):
    """Components rr, rphi, phir, phiphi of a symmetric tensor with eigenvalues
    (major, minor), the major axis at angle theta (rad) from e_r; arrays over rings."""
    c, s = np.cos(theta), np.sin(theta)
    rr = major * c**2 + minor * s**2
    pp = major * s**2 + minor * c**2
    rp = (major - minor) * c * s
    return rr, rp, rp, pp


def fields(r, *, dilation=0.02, layering=0.03, bulk_layering=0.0, v_floor=1e-7,
           anisotropy=0.1, sigma_rr_exponent=0.0, dynamic=1.0, colinear=False,
           hertz=False, unbalanced=False, same_sign_rotation=False, s=0.0127,
           v0_ratio=0.645, first_layer=False, loose_couples=False):
    """Profile values of a steady, quasi-static Couette state over rings at r (SI).
    ``first_layer``: the disks touching the wall move as one block, at the exponential's
    velocity at the layer's centre (a staircase in rings finer than a disk)."""
    R_i, R_o, Om = SCENE["R_i"], SCENE["R_o"], SCENE["Omega"]
    x_in, x_out = r - R_i, R_o - r
    wall = np.minimum(x_in, x_out)
    nu = 0.82 - 0.2 * np.clip(1 - wall / D_MEAN, 0, 1)                 # excluded volume
    nu = nu - dilation * ((wall > D_MEAN) & (wall < 3 * D_MEAN))        # dilated zones
    nu = nu + layering * np.cos(2 * np.pi * wall / D_MEAN) * np.exp(-wall / (2 * D_MEAN))
    nu = nu + bulk_layering * np.cos(2 * np.pi * wall / D_MEAN)
    rho = SCENE["rho_p"] * nu
    v0 = v0_ratio * Om * R_i
    v = v0 * np.exp(-np.where(first_layer & (x_in < D_MEAN), D_MEAN / 2, x_in) / s) + v_floor
    W = deformation_rate_and_spin(r, v)[1]
    layer = np.floor(x_in / D_MEAN)
    star = np.where(layer == 0, 0.01, np.where(layer == 1, 0.01 if same_sign_rotation
                                                else -0.01, 0.0))
    omega = W + star
    trF = 3.0 * nu
    theta_F = -np.pi / 4 if not colinear else -np.pi / 3
    F = rotate(theta_F + 0 * r, trF / 2 * (1 + 2 * anisotropy), trF / 2 * (1 - 2 * anisotropy))
    # momentum balance: total T = sigma - dsigma with div T = 0 (T_rr, T_phiphi const)
    P0, A = 9.0, 0.03
    T = (-P0 * (r / r[0]) ** sigma_rr_exponent if unbalanced or sigma_rr_exponent else
         -P0 + 0 * r, A / r**2, A / r**2, -P0 + 0 * r)
    if sigma_rr_exponent:                      # keep the balance: T_phiphi = d(r T_rr)/dr
        T = (T[0], T[1], T[2], (1 + sigma_rr_exponent) * T[0])
    if unbalanced:
        T = (T[0], T[1], T[2], -P0 + 0 * r)
    fluct = 1e-4 * dynamic
    dsigma = (rho * fluct, 0 * r, 0 * r, rho * (v**2 * dynamic + fluct))
    sigma = tuple(t + d for t, d in zip(T, dsigma))
    if colinear:                                # sigma's major axis along F's
        mean = 0.5 * (sigma[0] + sigma[3])
        sigma = rotate(theta_F + 0 * r, mean * 1.4, mean * 0.6)
    # linear springs: sigma = k_n / (pi h) eps . F  ->  eps = (pi h / k_n) sigma . F^-1
    S = np.stack([np.stack([sigma[0], sigma[1]], -1), np.stack([sigma[2], sigma[3]], -1)], -2)
    Fm = np.stack([np.stack([F[0], F[1]], -1), np.stack([F[2], F[3]], -1)], -2)
    E = PI_H / SCENE["k_n"] * S @ np.linalg.inv(Fm)
    if hertz:                                   # stiffer than linear: eps shrinks with load
        E = E * 0.6
    eps = (E[:, 0, 0], E[:, 0, 1], E[:, 1, 0], E[:, 1, 1])
    out = {"nu": nu, "rho": rho, "v_r": 0 * r, "v_phi": v, "omega": omega,
           "coordination": trF / nu,
           # the spins at rest in the mean: a couple stress mu_r ~ 1/r passes no couple
           # (d(r mu_r)/dr = 0), sigma is symmetric; ``loose_couples``: the contacts pass
           # a net couple that nothing balances
           "mu_r": 1e-3 / r, "mu_phi": 0 * r,
           "couple_density": (0.3 * P0 if loose_couples else 0.0) + 0 * r}
    for name, t in (("F", F), ("sigma", sigma), ("dsigma", dsigma), ("eps", eps)):
        out.update({f"{name}_{k}": np.asarray(c, float) for k, c in
                    zip(("rr", "rphi", "phir", "phiphi"), t)})
    return out


#: The inner wall's power (W) in the synthetic state: 0.9 of it reaches the disks
#: through the wall's contacts, 0.6 is dissipated by the disks' contacts, 0.2 by the
#: base plate and 0.1 at the outer wall.
POWER = 1e-4


def powers(rings, leaky=False):
    """Power densities whose sum over the rings is nil (a steady state); ``leaky``: the
    disks' contacts dissipate 0.3 of the wall's power more than reaches them."""
    V, n = rings.volume, rings.n
    spread = np.full(n, 1.0 / V.sum())
    wall = np.zeros(n)
    wall[0], wall[-1] = 0.9 * POWER / V[0], -0.1 * POWER / V[-1]
    return {"contact_power": -(0.9 if leaky else 0.6) * POWER * spread,
            "wall_power": wall, "body_power": -0.2 * POWER * spread,
            "lever_power": 0 * spread}


def profiles(n, n_rep=6, noise=1e-3, seed=0, leaky=False, **kw):
    """Ensemble-like profiles: replicates = exact fields with relative noise, and the
    runs' time series of the inner wall's torque."""
    rings = Rings.count(n, SCENE["R_i"], SCENE["R_o"], SCENE["h"])
    exact = {**fields(rings.centre, **kw), **powers(rings, leaky)}
    rng = np.random.default_rng(seed + n)
    reps = {k: v[None] * (1 + noise * rng.standard_normal((n_rep, n))) for k, v in exact.items()}
    reps["nu"] = exact["nu"][None] + noise * rng.standard_normal((n_rep, n))
    rep = Replicates("runs", reps)
    values = {k: v.mean(axis=0) for k, v in reps.items()}
    sem = rep.profile_errors()
    meta = {"run_manifest": {"scene": SCENE}, "frames": {"n": 100}}
    t = np.tile(np.arange(20.0), n_rep)
    torque = -POWER / SCENE["Omega"] * (1 + noise * rng.standard_normal(t.size))
    series = {"t_s": t, "run": np.repeat(np.arange(n_rep), 20), "torque_in_Nm": torque}
    return Fields(rings, values, sem, np.array([""] * n, dtype=object), 100, meta, rep,
                    np.full(n, n_rep), series)
