"""The gate every frame passes (granavg.engine.gate), on frames built in memory whose
answer is known: a clean frame of touching disks passes; each damage is refused in one
line that says where (file:line, file and row, a scene's body) and what."""

import numpy as np
import pytest

from granavg.engine.gate import Gate, Origin, inspect
from granavg.errors import UserError
from granavg.io.box import Box
from granavg.io.frames import Frame

R = 0.5                       # the disks' radius
L = 10.0                      # the periodic box's edge along x


def frame(step=1, time=None, box=True, origin=None, **edits):
    """Three disks of radius R in a row along x at 0.5, 1.4 and 9.55 (the third touches
    the first across the periodic face at x = 0 = L): contacts 1-2 and 3-1, overlaps 0.1
    and 0.05, unit normals; ``edits`` replace columns (``atoms_x=...``, ``contacts_nx=...``)."""
    atoms = {"id": np.array([1.0, 2.0, 3.0]), "x": np.array([0.5, 1.4, 9.55]),
             "y": np.array([2.0, 2.0, 2.0]), "radius": np.full(3, R),
             "vx": np.zeros(3), "vy": np.zeros(3)}
    contacts = {"id1": np.array([1.0, 3.0]), "id2": np.array([2.0, 1.0]),
                "wall": np.zeros(2), "nx": np.array([1.0, 1.0]), "ny": np.zeros(2),
                "fnx": np.array([-1.0, -0.5]), "fny": np.zeros(2),
                "overlap": np.array([0.1, 0.05])}
    for key, value in edits.items():
        table, name = key.split("_", 1)
        (atoms if table == "atoms" else contacts)[name] = np.asarray(value, float)
    b = Box((0.0, 0.0, 0.0), (L, 4.0, 1.0), periodic=(True, False, False)) if box else None
    return Frame(step, step * 0.1 if time is None else time, atoms, contacts, box=b,
                 origin=origin)


def refused(f, *needles, dim=2):
    with pytest.raises(UserError) as info:
        inspect(f, dim)
    message = str(info.value)
    assert "\n" not in message and all(n in message for n in needles), message
    return message


def test_a_clean_frame_passes_and_keeps_its_numbers():
    f = frame()
    inspect(f, 2)
    assert f.contacts["nx"].tolist() == [1.0, 1.0] and f.rows[1].tolist() == [1, 0]


@pytest.mark.parametrize("edit, needles", [
    (dict(atoms_vx=[0, np.nan, 0]), ["vx is nan", "atom row 2"]),
    (dict(atoms_vy=[0, 0, 1e200]), ["vy is 1e+200", "beyond 1e+150"]),
    (dict(atoms_vx=[0, -np.inf, 0]), ["vx is -inf"]),
    (dict(atoms_id=[1, 1, 3]), ["atom id 1 appears twice", "atom row 2"]),
    (dict(atoms_id=[1, 2.5, 3]), ["id 2.5 is not an integer"]),
    (dict(atoms_radius=[R, 0.0, R]), ["radius 0 is not positive"]),
    (dict(contacts_fnx=[np.nan, -0.5]), ["fnx is nan", "contact row 1"]),
    (dict(contacts_id2=[7, 1]), ["atom id 7 is not among the frame's atoms"]),
    (dict(contacts_id2=[1, 1]), ["atom 1 is in contact with itself"]),
    (dict(contacts_wall=[0, 3]), ["wall code 3 is not 0, 1 or 2"]),
    (dict(contacts_nx=[1.0, 0.99]), ["is not a unit vector", "contact row 2"]),
    (dict(contacts_overlap=[0.1, 0.5]), ["the overlap 0.5 of atoms 3 and 1",
                                         "(0.05)", "contact row 2"]),
], ids=["nan", "huge", "inf", "duplicate-id", "half-id", "radius-zero", "nan-force",
        "unknown-atom", "itself", "wall-code", "normal-not-unit", "overlap-not-centres"])
def test_each_damage_is_refused_naming_the_row(edit, needles):
    refused(frame(**edit), *needles)


def test_a_normal_within_printing_passes_unchanged_and_beyond_it_is_refused():
    """|n| - 1 = 1e-5 (6 printed digits) passes, the frame unchanged (the gate changes
    no frame: one averaged twice gives the same); 1e-3 is damage."""
    f = frame(contacts_nx=[1.0, 1.0 + 1e-5])
    inspect(f, 2)
    assert f.contacts["nx"][1] == 1.0 + 1e-5
    refused(frame(contacts_nx=[1.0, 1.0 + 1e-3]), "not a unit vector")


def test_overlaps_across_the_periodic_face_pass_and_without_a_box_are_not_judged():
    """Pair 3-1 touches only through the face at x = L: its image is found; without a
    box the periodic axes are unknown and the overlap is not judged."""
    inspect(frame(), 2)
    inspect(frame(box=False, contacts_overlap=[0.1, 0.5]), 2)
    far = frame(contacts_overlap=[0.1 + 2e-3 * 2 * R, 0.05])       # beyond GEOMETRY
    refused(far, "the overlap")
    near = frame(contacts_overlap=[0.1 + 0.5e-3 * 2 * R, 0.05])     # within it
    inspect(near, 2)


def test_stored_contact_positions_must_be_the_atoms():
    """x1 x2 as LIGGGHTS' pos: equal to the atoms' (periodic image allowed)."""
    ok = frame(contacts_x1=[0.5, 9.55 - L], contacts_x2=[1.4, 0.5])
    inspect(ok, 2)
    refused(frame(contacts_x1=[0.5, 9.0], contacts_x2=[1.4, 0.5]), "x1 9 but atom 3",
            "another run or time step")


def test_where_a_refusal_points():
    """file:line where rows are lines; file, timestep and row where not (binary); a
    scene's body by its id."""
    lines = frame(atoms_vx=[0, np.nan, 0], origin={"atoms": Origin("a.dump", 10)})
    assert refused(lines).startswith("a.dump:11: vx is nan (timestep 1)")
    rows = frame(atoms_vx=[0, np.nan, 0], origin={"atoms": Origin("a.bin")})
    assert refused(rows).startswith("a.bin (timestep 1, atom row 2): vx is nan")
    scene = frame(atoms_radius=[R, -R, R], origin={"atoms": Origin("the scene", scene="S")})
    message = refused(scene)
    assert message.startswith("the scene at step 1, body 2: radius -0.5") and \
        message.endswith(": S")


def admit_all(*frames):
    gate = Gate(2)
    for f in frames:
        gate.admit(f)


def test_time_steps_and_times_must_increase():
    admit_all(frame(1), frame(2))
    with pytest.raises(UserError, match="timestep 1 does not follow timestep 1"):
        admit_all(frame(1), frame(1))
    with pytest.raises(UserError, match="time 0.05.* does not follow time 0.1"):
        admit_all(frame(1), frame(2, time=0.05))


def test_every_frame_carries_the_same_columns():
    second = frame(2)
    del second.atoms["vy"]
    with pytest.raises(UserError, match="lacks the column vy, unlike the first frame"):
        admit_all(frame(1), second)


def box_frame(step, lo, hi, periodic=(True, False, False), x=None):
    f = frame(step)
    f.box = Box((lo, 0.0, 0.0), (hi, 4.0, 1.0), periodic=periodic)
    if x is not None:
        f.atoms["x"] = np.asarray(x, float)
    return f


def test_a_periodic_box_deforms_only_with_its_atoms_inside():
    """A box shrinking with its atoms (fix deform) passes; one whose atoms lie outside
    it (damaged box lines: half as wide, atoms as before) is refused; flags that change
    are refused."""
    admit_all(box_frame(1, 0, L), box_frame(2, 0, 0.9 * L, x=[0.5, 1.4, 8.55]),
              box_frame(3, 0, 0.8 * L, x=[0.5, 1.4, 7.55]))
    with pytest.raises(UserError, match="atoms lie up to 4.55 outside it"):
        admit_all(box_frame(1, 0, L), box_frame(2, 0, L / 2))
    with pytest.raises(UserError, match="periodic along x y, where the first frame is "
                                        "periodic along x"):
        admit_all(box_frame(1, 0, L), box_frame(2, 0, L, periodic=(True, True, False)))


def test_a_box_that_is_not_finite_or_has_no_extent_is_refused():
    f = frame()
    f.box = Box((0.0, 0.0, 0.0), (L, 0.0, 1.0), periodic=(True, False, False))
    refused(f, "the box bounds", "hi > lo")
