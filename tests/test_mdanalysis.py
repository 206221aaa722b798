"""MDAnalysis and granavg read the same per-atom frames from a real run's dump."""

import gzip
import warnings

import numpy as np

from granavg.io.reader import DumpReader


def test_mdanalysis_and_granavg_read_identical_atom_frames(small_run, tmp_path):
    import MDAnalysis as mda

    plain = tmp_path / "atoms.dump"
    plain.write_bytes(gzip.decompress((small_run / "atoms.dump.gz").read_bytes()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")             # MDAnalysis warns about missing masses
        u = mda.Universe(str(plain), format="LAMMPSDUMP")
    ours = list(DumpReader(plain))
    assert len(u.trajectory) == len(ours) > 5
    for ts, frame in zip(u.trajectory, ours):
        assert ts.data["step"] == frame.timestep
        assert np.array_equal(u.atoms.ids, frame.column("id").astype(int))
        # MDAnalysis keeps float32 and moves the box's lower corner to the origin
        xyz = np.column_stack([frame.column(c) for c in ("x", "y", "z")]) - frame.box[:, 0]
        assert np.allclose(ts.positions, xyz.astype(np.float32), rtol=1e-6, atol=1e-7)
        v = np.column_stack([frame.column(c) for c in ("vx", "vy", "vz")])
        assert np.allclose(ts.velocities, v.astype(np.float32), rtol=1e-6, atol=1e-9)
