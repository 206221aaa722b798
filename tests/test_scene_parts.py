"""What leaving out contact output changes (docs/scene.md, "model only what a scene
requires"): output never feeds back into the dynamics. (The other parts' effects are the
speed/accuracy study's, docs/sweep; `--quantities`' is tests/test_balance.py's.)"""

import numpy as np

from granavg.sim.scene import preset
from granavg.sim.simulate import simulate

from .conftest import SMALL_CELL, SMALL_PRESET, dump_positions


def test_leaving_out_contact_output_leaves_the_trajectory_alone(tmp_path):
    """contacts=0 (no contact dump, no stress or fabric fields) runs the very same
    disks: the positions of every frame are bit-identical to those of the run with the
    contact dump, which is written besides."""
    runs = {}
    for c in (0, 1):
        sc = preset(SMALL_PRESET).with_overrides([*SMALL_CELL, "t_end=1", "t_dump_start=0.5",
                                                 "dump_dt=0.25", f"contacts={c}"])
        simulate(sc, tmp_path / f"c{c}", progress=False)
        runs[c] = dump_positions(tmp_path / f"c{c}")
    assert list((tmp_path / "c1").glob("contacts.dump*"))
    assert not list((tmp_path / "c0").glob("contacts.dump*"))
    assert runs[0].shape == runs[1].shape and len(runs[0]) >= 2
    np.testing.assert_array_equal(runs[0], runs[1])
