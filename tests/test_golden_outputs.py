"""Today's outputs, kept: the files ``granavg average`` writes for the shipped examples
(granavg.examples) against those it wrote on 2026-12-04 (tests/golden/), byte for byte,
but for the unit labels that were wrong then (:data:`RELABELLED`).

Tables are kept whole; NetCDF and VTK files as SHA-256 of their bytes. Fields of the
smoothing kernels (compiled by the machine's C compiler, which may fuse a multiply-add)
are held to their printed digits instead of their last bits.

The sidecars' numbers and the replicates are held to 1e-12 relative: on 2026-12-06 numpy
2.4.6 (with its LAPACK, for the stationarity's trend fits, and its reductions) changed
their last bits with the code unchanged (the tables, NetCDF and VTK files stayed
identical). The replicates are kept whole as that day's files (tests/golden/*.npz),
written by the code whose files had the 2026-12-04 hashes. The sidecar's ``spec`` (new
since) is tested in tests/test_spec.py."""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from granavg.examples import pile_3d

from .conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = Path(__file__).parent / "golden"
MAP3 = ",".join(f"{k}={v}" for k, v in pile_3d.contact_map.items())
E = "granavg/examples/data"
#: name -> (arguments of ``granavg average``, files compared as text, as hashes, kernel)
CASES = {
    "rings": ([f"{E}/couette_2d", "--bins", 8, "--t-min", 1, "--netcdf"],
              (".json", ".timeseries.csv", ""), (".nc", ".replicates.npz"), False),
    "polar": ([f"{E}/couette_2d", "--polar-grid", 4, 8, "--t-min", 1, "--vtk"],
              ("", ".json"), (".vtu",), False),
    "slabs": (["--atoms", f"{E}/pile_3d/atoms.dump.gz", "--contacts",
               f"{E}/pile_3d/contacts.dump.gz", "--contact-columns", MAP3, "--slabs", "z",
               "--range", 0, 0.024, "--bins", 12, "--gravity", 0, 0, -9.81],
              ("", ".json"), (".replicates.npz",), False),
    "kring": ([f"{E}/couette_2d", "--bins", 6, "--t-min", 1, "--kernel", "lucy", "--width",
               0.008, "--quantities", "nu,rho,v,omega,sigma,gradv,D,W,divsigma,divdsigma"],
              ("", ".json"), (), True),
    "kboxes": (["--atoms", f"{E}/pile_3d/atoms.dump.gz", "--contacts",
                f"{E}/pile_3d/contacts.dump.gz", "--contact-columns", MAP3, "--grid", 3, 3, 4,
                "--z-range", 0, 0.024, "--kernel", "lucy", "--width", 0.004, "--gravity", 0,
                0, -9.81], ("", ".json"), (), True),
}


def written(name, out_dir):
    """Run the case's command (in the repository, the examples' paths relative)."""
    args, *_ = CASES[name]
    out = out_dir / f"{name}.csv"
    proc = run_cli("average", *args, "--out", out, "--no-progress", cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    return out


def sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


#: Unit labels that were wrong on 2026-12-04 (guessed from the columns' names): each
#: column of these quantities or coordinates (``phi``, ``phi_lo``, ...) and its unit in SI.
RELABELLED = {"gradv": "1/s", "D": "1/s", "W": "1/s", "divsigma": "Pa/m",
              "divdsigma": "Pa/m", "spin_density": "kg/(m s)", "phi": "rad"}


def relabelled(meta):
    """The golden sidecar with today's corrected unit labels."""
    for column in meta.get("columns", {}):
        name = column[:-4] if column.endswith("_sem") else column
        for prefix, unit in RELABELLED.items():
            if name == prefix or name.startswith(prefix + "_"):
                meta["columns"][column] = unit
    return meta


def close(a, b, path=""):
    """JSON values equal, numbers to 1e-12 relative (kernel fields)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), path
        for k in a:
            close(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            close(x, y, f"{path}/{k}")
    elif isinstance(a, float) and isinstance(b, (int, float)):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-300, nan_ok=True), path
    else:
        assert a == b, path


def same_arrays(path, golden):
    """The replicates' arrays as the golden file's: names, shapes and kinds exact, numbers
    to 1e-12 relative."""
    got, want = np.load(path), np.load(golden)
    assert sorted(got.files) == sorted(want.files)
    for k in want.files:
        a, b = got[k], want[k]
        assert a.shape == b.shape and a.dtype.kind == b.dtype.kind, k
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=0, equal_nan=True, err_msg=k)
        else:
            assert np.array_equal(a, b), k


def numbers_of(text):
    rows = [line.split(",") for line in text.splitlines()]
    return rows[0], rows[1:]


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "kboxes"
                                  else n for n in CASES])
def test_todays_outputs_are_kept(name, tmp_path):
    """Every file of the case as it was, the unit labels corrected; a kernel's numbers
    to their last printed digit (tables, 10 digits) or 1e-12 relative (sidecar)."""
    out = written(name, tmp_path)
    _, texts, binaries, kernel = CASES[name]
    hashes = json.loads((GOLDEN / "hashes.json").read_text())
    for suffix in binaries:
        if suffix == ".replicates.npz":
            same_arrays(str(out) + suffix, GOLDEN / (out.name + suffix))
        else:
            assert sha(str(out) + suffix) == hashes[out.name + suffix], suffix
    for suffix in texts:
        got = Path(str(out) + suffix).read_text()
        want = (GOLDEN / (out.name + suffix)).read_text()
        if suffix == ".json":
            got = json.loads(got)
            assert got.pop("spec")["version"] == 1
            close(got, relabelled(json.loads(want)))
        elif kernel:
            (head, rows), (head0, rows0) = numbers_of(got), numbers_of(want)
            assert head == head0 and len(rows) == len(rows0)
            for r, r0 in zip(rows, rows0):
                for x, x0 in zip(r, r0):
                    try:
                        assert float(x) == pytest.approx(float(x0), rel=1e-9, abs=1e-300,
                                                         nan_ok=True)
                    except ValueError:
                        assert x == x0
        else:
            assert got == want, suffix
