"""Damaged LIGGGHTS output, case by case (tests/damage.py): the mesh-floor pile of
tests/decks/pile_liggghts.lig run once by Debian's liggghts (dump custom atoms, dump local
of compute pair/gran/local and wall/gran/local, ``pos id force delta``). Each case copies
the clean dumps, damages one, and averages them with the real command line: refused in
one line (exit 2) naming the file and the frame (line or time step), no output left; a
cut contact dump either keeps its complete frames, said in a warning, or is refused."""

import shutil

import numpy as np
import pytest

from .damage import (TextDump, accepted, average, out_path, refused, run_liggghts,
                     same_numbers, shared_run)

pytestmark = [
    pytest.mark.skipif(shutil.which("liggghts") is None,
                       reason="liggghts not installed: apt-get install -y liggghts"),
    pytest.mark.slow]

KEYWORDS = "pos id force delta"
#: LIGGGHTS' columns of pos id force delta: c_ID[1..13].
POS1, POS2, ID1, ID2, FORCE = (1, 2, 3), (4, 5, 6), 7, 8, (10, 11, 12)


@pytest.fixture(scope="module")
def mesh(tmp_path_factory):
    """The pile's directory (one LIGGGHTS run per session, about a minute)."""
    return shared_run(tmp_path_factory, "damage_liggghts_mesh", run_liggghts)


def options(d, out, keywords=KEYWORDS, contacts="contacts.dump"):
    return ("--atoms", d / "atoms.dump", "--contacts", d / contacts, "--wall-contacts",
            d / "walls.dump", "--liggghts", keywords, "--dt", 1e-5, "--units", "si",
            "--slabs", "z", "--range", 0, 0.048, "--bins", 8, "--out", out)


@pytest.fixture(scope="module")
def clean(mesh, tmp_path_factory):
    out = tmp_path_factory.mktemp("damage_liggghts_clean") / "p.csv"
    return accepted(average(*options(mesh, out)), out)


def _copy(mesh, tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    for name in ("atoms.dump", "contacts.dump", "walls.dump"):
        shutil.copy(mesh / name, d / name)
    return d


def col(k):
    return f"c_cpgl[{k}]"


# -- contacts that are not the atoms' ------------------------------------------------------

def _another_run(c):
    """Every contact's ids renumbered by a fixed permutation of the atoms' ids: each row's
    positions are those of other atoms (as a contact dump of another run of the same
    pile); frame 0 is the first damaged."""
    ids = sorted({int(c.get(k, col(ID1))) for f in range(len(c.frame_starts()))
                  for k in c.rows(f)} | {int(c.get(k, col(ID2))) for f in
                                         range(len(c.frame_starts())) for k in c.rows(f)})
    perm = dict(zip(ids, np.random.default_rng(3).permutation(ids)))
    for f in range(len(c.frame_starts())):
        for k in c.rows(f):
            for j in (ID1, ID2):
                c.set(k, col(j), int(perm[int(c.get(k, col(j)))]))
    return 0


def _shifted(c):
    """Frame 2: atom 1's position 0.5 mm higher in every row."""
    for k in c.rows(2):
        c.set(k, col(POS1[2]), repr(c.get(k, col(POS1[2])) + 5e-4))
    return 2


@pytest.mark.parametrize("damage", [_another_run, _shifted],
                         ids=["contacts-of-another-run", "contact-pos-shifted"])
def test_contacts_whose_positions_are_not_the_atoms_are_refused(mesh, clean, tmp_path,
                                                                damage):
    d = _copy(mesh, tmp_path)
    c = TextDump.read(d / "contacts.dump")
    frame = damage(c)
    c.write(d / "contacts.dump")
    rows, step = c.rows(frame), c.step(frame)
    out = out_path(tmp_path)
    lines = tuple(f"{d / 'contacts.dump'}:{k + 1}:" for k in range(rows[0] - 9, rows[-1] + 1))
    refused(average(*options(d, out)), out, str(d / "contacts.dump"),
            lines + (f"timestep {step}",), clean=clean)


# -- the keywords ----------------------------------------------------------------------------

@pytest.mark.parametrize("keywords", ["pos id force_normal delta", "pos id torque delta"],
                         ids=["force_normal-for-force", "torque-for-force"])
def test_keywords_of_the_right_count_but_not_the_computes_are_refused(mesh, clean, tmp_path,
                                                                     keywords):
    """13 values as the dump holds, but not those of the compute line that wrote it (the
    total force taken as its normal part, or as a torque): refused naming --liggghts
    and the dump."""
    d = _copy(mesh, tmp_path)
    out = out_path(tmp_path)
    refused(average(*options(d, out, keywords=keywords)), out, "--liggghts",
            "contacts.dump", clean=clean)


# -- damaged values and files ----------------------------------------------------------------

def test_nan_in_a_contact_force_is_refused_naming_its_line(mesh, clean, tmp_path):
    d = _copy(mesh, tmp_path)
    c = TextDump.read(d / "contacts.dump")
    k = c.rows(2)[10]
    c.set(k, col(FORCE[0]), "nan")
    bad = c.write(d / "contacts.dump")
    out = out_path(tmp_path)
    refused(average(*options(d, out)), out, f"{bad}:{k + 1}:", ("NaN", "nan"), clean=clean)


def test_a_contact_dump_cut_mid_frame(mesh, clean, tmp_path):
    """Cut inside a row of the last frame: either the four complete frames are averaged
    (as all three dumps ending there) with a warning naming the cut file, or it is
    refused in one line naming the file and the cut frame."""
    d = _copy(mesh, tmp_path)
    c = TextDump.read(d / "contacts.dump")
    last = c.rows(4)[len(c.rows(4)) // 2]
    step = c.step(4)
    c.lines = c.lines[:last] + [c.lines[last][:20]]
    bad = c.write(d / "contacts.dump")
    out = out_path(tmp_path)
    proc = average(*options(d, out))
    if proc.returncode != 0:
        refused(proc, out, str(bad), (str(step), f"{bad}:"))
        return
    warned = [ln for ln in proc.stderr.splitlines() if str(bad) in ln]
    assert warned, f"WEAK message: no warning names the cut file: {proc.stderr[-600:]}"
    ref = tmp_path / "ref"
    ref.mkdir()
    for name in ("atoms.dump", "contacts.dump", "walls.dump"):
        t = TextDump.read(mesh / name)
        t.keep_frames(4)
        t.write(ref / name)
    r = out_path(tmp_path, "ref.csv")
    same_numbers(proc, out, accepted(average(*options(ref, r)), r))
    print(f"observed: {warned[0]}")
