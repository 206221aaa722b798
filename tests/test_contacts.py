"""The contact-table kernel: overlap, normal, wall flag, and the disk always first."""

import numpy as np

from granavg.io.contacts import COLUMNS, RAW_COLUMNS, contact_table, radius_by_id

# radius by atom id: small disks 5-8, a large disk 9 (4 and 6 mm), wall disks 1 and 3
R = radius_by_id([1, 3, 5, 6, 7, 8, 9], [0.003, 0.003, 0.004, 0.004, 0.004, 0.004, 0.005])


def raw_row(id1, id2, t1, t2, x1, x2, fn_on_1, ft_on_1):
    d = np.subtract(x1, x2)
    return [id1, id2, t1, t2, d[0], d[1], np.hypot(*d), *fn_on_1, *ft_on_1]


def test_disk_disk_row_keeps_its_order_and_gets_overlap_and_normal():
    row = raw_row(7, 9, 1, 2, (0.0, 0.0), (0.0, 0.0085), (0.0, -2.0), (0.5, 0.0))
    out = dict(zip(COLUMNS, contact_table([row], R)[0]))
    assert (out["id1"], out["id2"], out["wall"]) == (7, 9, 0)
    assert np.isclose(out["overlap"], 0.004 + 0.005 - 0.0085)
    assert np.allclose([out["nx"], out["ny"]], [0, 1])           # from 1 towards 2
    assert np.allclose([out["fnx"], out["fny"], out["ftx"], out["fty"]], [0, -2, 0.5, 0])


def test_wall_first_rows_are_swapped_so_forces_act_on_the_disk():
    # LAMMPS listed the outer-wall disk (type 4) first; the force on it is +x
    row = raw_row(3, 8, 4, 1, (0.0065, 0.0), (0.0, 0.0), (1.5, 0.0), (0.0, 0.2))
    out = dict(zip(COLUMNS, contact_table([row], R)[0]))
    assert (out["id1"], out["id2"], out["wall"]) == (8, 3, 2)
    assert np.allclose([out["fnx"], out["fny"], out["ftx"], out["fty"]], [-1.5, 0, 0, -0.2])
    assert np.allclose([out["nx"], out["ny"]], [1, 0])           # disk -> wall disk
    assert np.isclose(out["overlap"], 0.004 + 0.003 - 0.0065)


def test_inner_wall_flag_and_non_contacts_dropped():
    rows = [raw_row(1, 5, 3, 1, (0, 0), (0.0069, 0), (-1, 0), (0, 0)),   # inner wall
            raw_row(5, 6, 1, 1, (0, 0), (0.0081, 0), (0, 0), (0, 0))]    # gap: not a contact
    out = contact_table(rows, R)
    assert out.shape == (1, len(COLUMNS)) and out[0, 2] == 1


def test_empty_frame():
    assert contact_table(np.empty((0, len(RAW_COLUMNS))), R).shape == (0, len(COLUMNS))


def test_overlap_uses_each_atoms_own_radius():
    """Disks of one type may differ in size (size_spread): the overlap is r_1 + r_2 - dist
    of the two atoms themselves, and a pair touching only by its own sizes is kept."""
    radius = radius_by_id([5, 6], [0.0036, 0.0041])
    row = raw_row(5, 6, 1, 1, (0, 0), (0.0076, 0), (0, 0), (0, 0))
    out = dict(zip(COLUMNS, contact_table([row], radius)[0]))
    assert np.isclose(out["overlap"], 0.0036 + 0.0041 - 0.0076)
    assert np.isnan(radius_by_id([2], [0.001])[1])


def test_atom_ids_are_found_alike_through_a_table_and_by_sorted_search():
    """Dense ids go through a table indexed by id, sparse ones (here 10^7 apart) through
    a sorted search: the same rows, and unknown ids (absent, negative, beyond the
    largest) are not found; float columns (as dumps are read) and integers alike."""
    from granavg.engine.kernels import lookup
    rng = np.random.default_rng(4)
    ids = rng.permutation(np.arange(1, 1001))
    wanted = np.concatenate([rng.choice(ids, 300), [0, -3, 1001, 5000]])
    truth = {int(i): k for k, i in enumerate(ids)}
    for scale in (1, 10**7):                           # table / search
        for kind in (float, np.int64):
            rows, found = lookup((ids * scale).astype(kind), (wanted * scale).astype(kind))
            assert list(found) == [int(w) in truth for w in wanted]
            assert [truth[int(w)] for w in wanted[found]] == list(rows[found])
