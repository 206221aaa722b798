"""A dump.* series on dask: listed from each file's first header alone, each worker
opening only its own files; names that are not time steps fall back to a scan; the
profiles are the serial ones. And the pieces: a first header read without its rows, gzip
chunks decompressed ahead of the parser."""

import gzip
import shutil

import numpy as np
import pytest

from granavg.errors import UserError
from granavg.io.prefetch import ReadAhead
from granavg.io.reader import DumpReader, numbered_series
from granavg.pipeline.on_dask import series_windows
from granavg.engine.spec import TimeAxis
from tests.helpers import average_pile3d as average

ARGS = ("--slabs", "z", "--range", 0, 0.024, "--bins", 6)


@pytest.fixture(scope="module")
def many(pile3d_series):
    """The 3D pile deck writing one file per frame (atoms.<step>.txt, contacts.<step>.txt):
    the session's run."""
    return pile3d_series


def test_the_windows_split_the_files_whole_from_their_first_headers(many):
    files = numbered_series(many / "atoms.*.txt")
    reader = DumpReader(many / "atoms.*.txt", [])
    windows = series_windows(many / "atoms.*.txt", many / "contacts.*.txt",
                             lambda f: f.time, TimeAxis(t_min=0.0, block_time=1e-9), 4)
    assert windows and len(windows) > 1
    for k, (number, path) in enumerate(files):                  # every file in one window
        step = reader.first_header(path).timestep
        assert step == number
        assert sum(lo <= step <= hi for lo, hi in windows) == 1
    own = [DumpReader(many / "atoms.*.txt", steps=w, named_steps=True)._own_files()
           for w in windows]
    assert sorted(p for files_ in own for p in files_) == [p for _, p in files]
    # a worker's own files give the frames a scan of every file gives for its window
    for w, files_ in zip(windows, own):
        named = [f.timestep for f in DumpReader(many / "atoms.*.txt", ["x"], steps=w,
                                                named_steps=True)]
        scanned = [f.timestep for f in DumpReader(many / "atoms.*.txt", ["x"], steps=w)]
        assert named == scanned and len(named) == len(files_)


@pytest.mark.slow
def test_names_that_are_not_time_steps_are_listed_by_a_scan_with_the_same_profiles(
        many, tmp_path):
    renamed = tmp_path / "renamed"
    renamed.mkdir()
    for kind in ("atoms", "contacts"):
        for k, (_, path) in enumerate(numbered_series(many / f"{kind}.*.txt")):
            shutil.copy(path, renamed / f"{kind}.{k + 1}.txt")        # 1, 2, ...: not steps
    assert series_windows(renamed / "atoms.*.txt", renamed / "contacts.*.txt",
                          lambda f: f.time, TimeAxis(t_min=0.0, block_time=1e-9), 4) is None
    files = dict(atoms="atoms.*.txt", contacts="contacts.*.txt")
    serial = average(many, tmp_path / "s.csv", *ARGS, **files)
    by_names = average(many, tmp_path / "n.csv", *ARGS, "--workers", 2, **files)
    by_scan = average(renamed, tmp_path / "r.csv", *ARGS, "--workers", 2, **files)
    assert by_names.meta["dask"]["listed_by"] == "file names"
    assert by_scan.meta["dask"]["listed_by"] == "header scan"
    for q in serial.values:
        for p in (by_names, by_scan):
            assert np.array_equal(serial.values[q], p.values[q], equal_nan=True), q
            assert np.array_equal(serial.sem[q], p.sem[q], equal_nan=True), q


def test_a_first_header_is_read_without_its_rows(many, tmp_path):
    path = numbered_series(many / "atoms.*.txt")[0][1]
    text = path.read_text().splitlines(keepends=True)
    head = next(k for k, line in enumerate(text) if line.startswith("ITEM: ATOMS"))
    text[head + 2] = "1 1 not-a-number\n"                      # a damaged row
    bad = tmp_path / "bad.txt"
    bad.write_text("".join(text))
    first = DumpReader(bad, ["x"]).first_header()
    assert first.timestep == numbered_series(many / "atoms.*.txt")[0][0]
    assert first.data.shape == (int(text[text.index("ITEM: NUMBER OF ATOMS\n") + 1]), 0)
    with pytest.raises(UserError, match="bad.txt:15: malformed row"):   # a full read sees it
        list(DumpReader(bad, ["x"]))


class Chunks:
    """A file object handing out ``pieces`` and then raising ``error`` (or ending)."""

    def __init__(self, pieces, error=None):
        self.pieces, self.error = list(pieces), error

    def read(self, n):
        if self.pieces:
            return self.pieces.pop(0)
        if self.error is not None:
            raise self.error
        return b""


def test_read_ahead_hands_out_the_bytes_in_order_and_an_error_after_them():
    pieces = [b"abc", b"defg", b"h"]
    ahead = ReadAhead(Chunks(pieces), 4)
    first = ahead.read(2)                       # whole chunks: at least n, never cut
    assert first is pieces[0]                   # one chunk is handed on uncopied
    assert ahead.read(5) == b"defgh" and ahead.read(4) == b""
    ahead.close()
    ahead = ReadAhead(Chunks([b"ab", b"c", b"defg"]), 4)
    assert ahead.read(3) == b"abc" and ahead.read(1) == b"defg" and ahead.read(1) == b""
    ahead.close()
    ahead = ReadAhead(Chunks([b"abc"], EOFError("cut")), 4)
    assert ahead.read(8) == b"abc"                                  # the data first
    with pytest.raises(EOFError, match="cut"):
        ahead.read(8)
    ahead.close()


def test_the_buffer_join_is_the_rest_and_the_chunk_in_order():
    from granavg.io.parse import joined
    rest, chunk = b"ITEM: TIMESTEP\n10\n1 2", b" 3\n4 5 6\n"
    assert joined(rest, 15, chunk) == rest[15:] + chunk
    assert joined(rest, 0, chunk) == rest + chunk and joined(rest, len(rest), chunk) == chunk
    assert joined(rest, len(rest) + 3, b"") == b"" and joined(b"", 0, chunk) == chunk
    big = np.random.default_rng(1).integers(0, 255, 9 << 20, dtype=np.uint8).tobytes()
    assert joined(big, 12345, big[:4 << 20]) == big[12345:] + big[:4 << 20]


def test_a_gzip_dump_reads_the_same_with_its_chunks_decompressed_ahead(many, tmp_path,
                                                                      monkeypatch):
    import granavg.io.text_scan as reader_module

    plain = b"".join(p.read_bytes() for _, p in numbered_series(many / "atoms.*.txt"))
    gz = tmp_path / "atoms.dump.gz"
    gz.write_bytes(gzip.compress(plain))
    monkeypatch.setattr(reader_module, "CHUNK", 4096)           # many chunks, frames across them
    frames = list(DumpReader(gz))
    (tmp_path / "atoms.dump").write_bytes(plain)
    same = list(DumpReader(tmp_path / "atoms.dump"))
    assert [f.timestep for f in frames] == [f.timestep for f in same]
    assert all(np.array_equal(a.data, b.data) for a, b in zip(frames, same))
