"""Frames a user can hold (granavg.open): a lazy sequence of the shipped pile's frames
(a LAMMPS dump pair) and of a 2D dump series, indexed, sliced and selected by time; the
fields of a selection against granavg.average over the same frames by t_min and t_max;
damaged frames refused by the gate as in an average."""

import gzip
import re

import numpy as np
import pytest

import granavg
from granavg.errors import UserError
from granavg.examples import pile_3d

CELLS = {"slabs": "z", "range": (0, 0.024), "bins": 12}
G = (0.0, 0.0, -9.81)


def pile(tmp_path, copies=4):
    """The shipped pile's 3 frames ``copies`` times (12 frames, 0.005 s apart), plain
    text: more frames than a reader reads ahead."""
    out = {}
    for name in ("atoms", "contacts"):
        text = gzip.decompress(getattr(pile_3d, name).read_bytes()).decode()
        frames = re.sub(r"ITEM: (UNITS|TIME)\n\S+\n", "", text).split("ITEM: TIMESTEP\n")[1:]
        path = tmp_path / f"{name}.dump"
        path.write_text("".join(
            f"ITEM: TIMESTEP\n{int(f.split(chr(10), 1)[0]) + 1500 * k}\n{f.split(chr(10), 1)[1]}"
            for k in range(copies) for f in frames))
        out[name] = path
    return out


@pytest.fixture
def frames(tmp_path):
    p = pile(tmp_path)
    return granavg.open(p["atoms"], contacts=p["contacts"], contact_map=pile_3d.contact_map,
                        dt=1e-5, units="si")


def test_len_index_and_slices_follow_the_files(frames):
    assert len(frames) == 12
    steps = 49000 + 500 * np.arange(12)
    assert np.array_equal(frames.timesteps, steps)
    assert np.allclose(frames.times, steps * 1e-5, rtol=1e-14)
    tenth = frames[::10]
    assert len(tenth) == 2 and np.array_equal(tenth.timesteps, steps[::10])
    assert [f.timestep for f in tenth] == list(steps[::10])
    assert frames[-1].timestep == steps[-1] and frames[3].timestep == steps[3]
    assert frames[2:8][1].timestep == steps[3]
    with pytest.raises(IndexError):
        frames[12]


def test_a_frame_holds_named_columns_its_box_and_time(frames):
    frame = frames[5]
    atoms, contacts = frame.to_pandas("atoms"), frame.to_pandas("contacts")
    assert len(atoms) == 755 and {"x", "y", "z", "radius", "vx", "id"} <= set(atoms)
    assert {"id1", "id2", "fnx", "nz", "overlap"} <= set(contacts)
    assert np.isclose(frame.time, 0.515)
    assert np.allclose(np.subtract(frame.box.hi, frame.box.lo)[:2], 0.016)
    # the same atoms as the sixth frame a plain pass over all frames gives
    sixth = list(frames)[5]
    assert np.array_equal(sixth.atoms["x"], frame.atoms["x"])


def test_a_time_selection_is_inclusive_within_the_time_tolerance(frames):
    assert np.array_equal(frames.between(0.5, 0.52).timesteps, [50000, 50500, 51000, 51500,
                                                                52000])
    assert len(frames.between(0.5 + 1e-12, 0.52 - 1e-12)) == 5
    assert len(frames.between(0.5 + 1e-6, None)) == 9
    assert len(frames.between(1.0, 2.0)) == 0


@pytest.mark.parametrize("select, t_min, t_max", [
    (lambda f: f.between(0.5, 0.52), 0.5, 0.52),
    (lambda f: f[4:], 0.51, None),
    (lambda f: f, None, None),
])
def test_the_fields_of_a_selection_equal_averaging_the_files_over_its_times(
        frames, select, t_min, t_max):
    """To round-off: the same frames, read the same way (every value and error)."""
    picked = granavg.average(select(frames), cells=CELLS, gravity=G)
    files = granavg.average(frames.atoms, contacts=frames.contacts,
                            contact_map=pile_3d.contact_map, dt=1e-5, units="si",
                            t_min=t_min, t_max=t_max, cells=CELLS, gravity=G)
    assert picked.n_frames == files.n_frames == len(select(frames))
    assert set(picked.values) == set(files.values)
    for k in files.values:
        scale = max(np.nanmax(np.abs(files.values[k])), 1e-300)
        assert np.allclose(picked.values[k], files.values[k], rtol=0, atol=1e-12 * scale,
                           equal_nan=True), k
        assert np.allclose(picked.sem[k], files.sem[k], rtol=1e-12, atol=1e-12 * scale,
                           equal_nan=True), k


def test_a_strided_selection_averages_its_own_frames(frames):
    """Every third frame: the average of those frames (their mean density), not of all."""
    third = frames[::3]
    fields = granavg.average(third, cells=CELLS, quantities=["nu"])
    assert fields.n_frames == 4
    assert fields.meta["files"]["selected"] == {"frames": 4, "first_timestep": 49000,
                                                 "last_timestep": 53500}


def test_options_of_the_files_belong_to_open(frames):
    with pytest.raises(Exception, match="granavg.open"):
        granavg.average(frames, cells=CELLS, dt=1e-5)


def test_a_damaged_frame_is_refused_when_it_is_read(tmp_path):
    """A NaN position in the seventh frame: the index and the first frames are fine;
    that frame, alone or in a pass, is refused in one line naming the file and line."""
    p = pile(tmp_path)
    lines = p["atoms"].read_text().splitlines(keepends=True)
    heads = [k for k, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")]
    k = heads[6] + 11
    words = lines[k].split()
    words[2] = "nan"
    lines[k] = " ".join(words) + "\n"
    p["atoms"].write_text("".join(lines))
    frames = granavg.open(p["atoms"], contacts=p["contacts"],
                          contact_map=pile_3d.contact_map, dt=1e-5, units="si")
    assert len(frames) == 12 and frames[5].timestep == 51500
    for bad in (lambda: frames[6], lambda: list(frames), lambda: granavg.average(
            frames[4:], cells=CELLS)):
        with pytest.raises(UserError, match=rf"atoms.dump:{k + 1}\b.*(NaN|nan|finite)"):
            bad()


def test_a_negative_step_is_refused(frames):
    with pytest.raises(Exception, match="forward in time"):
        frames[::-1]
