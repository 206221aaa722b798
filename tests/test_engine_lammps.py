"""The engine on a real LAMMPS run: exact sum rule, and LAMMPS' own virial."""

import json

import numpy as np
import pytest

from granavg.engine.cell_average import CellAverage
from granavg.engine.spec import Averaging
from granavg.engine.cells.rings import Rings
from granavg.sim.lammps_session import lammps_session, load_lammps
from granavg.engine.body_forces import base_plate
from granavg.engine.requirements import groups_for
from granavg.io.reader import DumpReader
from granavg.io.run_dumps import RunDumps
from granavg.sim.scene import PAPER_HOOKE
from granavg.sim.run_layout import DECK, cmdargs
from granavg.sim.simulate import deck_variables

from .helpers import SMALL_CELL, live_frame_and_virial


def frames_of(run):
    m = json.loads((run / "manifest.json").read_text())
    pairs = RunDumps(DumpReader(run / "atoms.dump.gz"), DumpReader(run / "contacts.dump.gz"),
                       dt=m["derived"]["dt_s"])
    return m, list(pairs)


def covering_rings(frame, h, n=15):
    """Rings spanning every disk whole, so the weights of each disk sum to 1."""
    a = frame.atoms
    r = np.hypot(a["x"], a["y"])
    return Rings(np.linspace((r - a["radius"]).min() * 0.999, (r + a["radius"]).max() * 1.001,
                             n + 1), h)


def direct_sums(frame, h):
    """sum_p sum_c f (x) l (l = (a - delta/2) n, to the contact point) and sum_p V^p
    sum_c n (x) n in each disk's polar basis, written independently of
    granavg.engine.kernels (complex numbers rotate into the basis)."""
    a, c = frame.atoms, frame.contacts
    row = {int(i): k for k, i in enumerate(a["id"])}
    z = a["x"] + 1j * a["y"]
    rot = np.conj(z / np.abs(z))                 # multiplies a vector into (r, phi)
    sig, fab = np.zeros((2, 2)), np.zeros((2, 2))
    for k in range(len(c["id1"])):
        f = complex(c["fnx"][k] + c["ftx"][k], c["fny"][k] + c["fty"][k])
        n = complex(c["nx"][k], c["ny"][k])
        sides = [(row[int(c["id1"][k])], f, n)]
        if c["wall"][k] == 0:
            sides.append((row[int(c["id2"][k])], -f, -n))
        for p, fp, np_ in sides:
            fl, nl = fp * rot[p], np_ * rot[p]
            lv = (a["radius"][p] - 0.5 * c["overlap"][k]) * nl
            sig += np.outer([fl.real, fl.imag], [lv.real, lv.imag])
            fab += np.pi * h * a["radius"][p] ** 2 * np.outer([nl.real, nl.imag],
                                                               [nl.real, nl.imag])
    return sig, fab


def test_sum_rule_over_rings_is_exact(small_run):
    m, frames = frames_of(small_run)
    h, frame = m["scene"]["h"], frames[len(frames) // 2]
    rings = covering_rings(frame, h)
    p = CellAverage([frame], rings, groups_for(None, True), m["scene"]["rho_p"],
                    Averaging.of(t_min=0.0, block_time=1.0)).run(False)
    V = rings.volume
    sig, fab = direct_sums(frame, h)
    for k, comp in enumerate(("rr", "rphi", "phir", "phiphi")):
        i, j = divmod(k, 2)
        assert np.sum(V * p.values[f"sigma_{comp}"]) == pytest.approx(sig[i, j], rel=1e-11)
        assert np.sum(V * p.values[f"F_{comp}"]) == pytest.approx(fab[i, j], rel=1e-11)
    total_disk_volume = np.sum(np.pi * h * frame.atoms["radius"] ** 2)
    assert np.sum(V * p.values["nu"]) == pytest.approx(total_disk_volume, rel=1e-12)


@pytest.mark.parametrize("sets", [(), ("mu_roll=0.2",)], ids=["gran-hooke-history",
                                                              "granular-rolling"])
def test_contact_rows_sum_to_lammps_forces_on_every_disk(tmp_path, sets):
    """Normal plus tangential force of the contact rows, summed per disk (minus on the
    second disk of a pair), equals LAMMPS' force on it: the pair/local columns mean the
    same for both contact laws (rolling resistance adds torque only)."""
    _, _, frame, _, forces, _ = live_frame_and_virial(tmp_path / "live", *sets)
    c = frame.contacts
    total = {i: np.zeros(2) for i in forces}
    f = np.column_stack([c["fnx"] + c["ftx"], c["fny"] + c["fty"]])
    for i1, i2, w, fc in zip(c["id1"].astype(int), c["id2"].astype(int), c["wall"], f):
        total[i1] += fc
        if w == 0:
            total[i2] -= fc
    scale = max(np.abs(v).max() for v in forces.values())
    assert np.sum(np.abs(c["ftx"]) > 0) > 100                  # friction is mobilised
    for i, fi in forces.items():
        assert np.allclose(total[i], fi, atol=1e-10 * scale), i


@pytest.mark.parametrize("branch", ["contact", "paper"])
def test_stress_trace_equals_lammps_virial(tmp_path, branch):
    """sum_k V_k tr sigma_k = sum_c l.f: with the contact-point branch vectors a pair
    gives f.n dist, LAMMPS' own virial term; Eq. 5 as printed gives f.n (r1 + r2), an
    overlap more. LAMMPS gives half of a wall pair to the wall disk. With those known
    geometric differences they agree to round-off."""
    scene, derived, frame, lmp_trace, _, _ = live_frame_and_virial(tmp_path / f"live_{branch}")
    rings = covering_rings(frame, scene.h)
    p = CellAverage([frame], rings, ["sigma"], scene.rho_p,
                    Averaging.of(t_min=0.0, block_time=1.0, branch=branch)).run(False)
    ours = np.sum(rings.volume * (p.values["sigma_rr"] + p.values["sigma_phiphi"]))
    c, a = frame.contacts, frame.atoms
    radius = dict(zip(a["id"].astype(int), a["radius"]))
    r1 = np.array([radius[int(i)] for i in c["id1"]])
    f_dot_n = (c["fnx"] + c["ftx"]) * c["nx"] + (c["fny"] + c["fty"]) * c["ny"]
    wall = c["wall"] > 0
    dist = np.where(wall, r1 + derived.wall_d / 2 - c["overlap"], np.nan)
    # disk-disk: (r1 + r2) - dist = overlap (nothing with the contact point);
    # disk-wall: our branch against half the distance
    shorten = 0.5 * c["overlap"] if branch == "contact" else 0.0
    pair_part = 0.0 if branch == "contact" else c["overlap"]
    correction = np.sum(np.where(wall, r1 - shorten - dist / 2, pair_part) * f_dot_n)
    assert np.sum(wall) > 10 and np.sum(~wall) > 100
    assert ours == pytest.approx(lmp_trace + correction, rel=1e-10)


def test_the_base_plate_force_is_what_lammps_applied(tmp_path):
    """The body force granavg gives each disk from its velocity (the deck's law,
    granavg.engine.body_forces.base_plate) equals LAMMPS' own per-atom force of the
    deck's fix addforce, to round-off, on a sheared cell with base-plate friction."""
    lammps = load_lammps()
    scene = PAPER_HOOKE.with_overrides([*SMALL_CELL, "mu_base=0.03", "v_base=0.002"])
    derived = scene.derive()
    out = tmp_path / "base"
    out.mkdir()
    variables = deck_variables(out, derived, embedded=True, resume=None, start=None)
    with lammps_session(cmdargs(out, variables, 1)) as lmp:
        lmp.file(str(DECK))
        lmp.command("run 2000")
        n = lmp.extract_global("nlocal")
        typ = np.array(lmp.numpy.extract_atom("type")[:n])
        v = np.array(lmp.numpy.extract_atom("v")[:n, :2])
        rad = np.array(lmp.numpy.extract_atom("radius")[:n])
        mass = np.array(lmp.numpy.extract_atom("rmass")[:n])
        fbx = np.array(lmp.numpy.extract_variable("fbx", "mobile", lammps.LMP_VAR_ATOM)[:n])
        fby = np.array(lmp.numpy.extract_variable("fby", "mobile", lammps.LMP_VAR_ATOM)[:n])
    disk = typ <= 2
    assert np.abs(v[disk]).max() > 10 * scene.v_base          # both regimes of the law
    assert np.abs(v[disk]).min() < scene.v_base
    term = base_plate(scene.mu_base, scene.v_base)
    atoms = {"x": np.zeros(disk.sum()), "radius": rad[disk], "vx": v[disk, 0],
             "vy": v[disk, 1]}
    gx, gy = term(atoms, lambda a: np.pi * scene.h * a * a, scene.rho_p)   # rho_p pi h a^2
    scale = np.abs(fbx[disk]).max()
    assert scale > 0
    assert np.allclose(gx, fbx[disk], rtol=1e-12, atol=1e-12 * scale)
    assert np.allclose(gy, fby[disk], rtol=1e-12, atol=1e-12 * scale)
    assert np.allclose(scene.rho_p * np.pi * scene.h * rad[disk] ** 2, mass[disk], rtol=1e-12)


def test_the_readers_contact_rows_are_the_engines(small_run, tmp_path):
    """The rows the run's reader looks up while it checks the ids (``Frame.rows``) are
    the ones the engine would look up itself, wall contacts and the dropped non-touching
    rows included, and a frame's sums are the same bits with them or without."""
    from dataclasses import replace

    from granavg.engine.frame_sums import frame_sums
    from granavg.engine.channels import BLOCKS
    from granavg.engine.kernels import lookup

    import gzip
    m = json.loads((small_run / "manifest.json").read_text())
    lines = gzip.open(small_run / "contacts.dump.gz", "rt").read().splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ENTRIES"))
    at = lines[head].split()[2:].index("overlap")        # every 5th row: not touching
    for k in range(head + 1, len(lines), 5):
        words = lines[k].split()
        if len(words) > at and not words[0].startswith("ITEM"):
            words[at] = "0"
            lines[k] = " ".join(words)
    (tmp_path / "contacts.dump").write_text("\n".join(lines) + "\n")
    source = RunDumps(DumpReader(small_run / "atoms.dump.gz"),
                      DumpReader(tmp_path / "contacts.dump"), dt=m["derived"]["dt_s"])
    frames = list(source)[-3:]
    assert source.dropped["contacts_not_touching"] > 0
    walls = 0
    for frame in frames:
        ids, c = frame.atoms["id"], frame.contacts
        i1, i2 = frame.rows
        pair = c["wall"] == 0
        assert np.array_equal(i1, lookup(ids, c["id1"])[0])
        assert np.array_equal(i2[pair], lookup(ids, c["id2"])[0][pair])
        assert np.all(i2[~pair] == -1) and np.array_equal(ids[i1], c["id1"])
        walls += int(np.sum(~pair))
        h = m["scene"]["h"]
        blocks = [b for b in BLOCKS if b not in ("body", "bpow")]
        with_rows = frame_sums(frame, covering_rings(frame, h), 1060.0, blocks)
        without = frame_sums(replace(frame, rows=None), covering_rings(frame, h), 1060.0,
                             blocks)
        assert np.array_equal(with_rows, without)
    assert walls > 0                        # wall contacts were among them
