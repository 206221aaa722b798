"""Listing a dump's frames without parsing their rows (DumpReader headers_only, what the
dask client cuts chunks from): the same frames, times and boxes as a full read, and the
same refusal of a damaged file, on a real run's dumps."""

import gzip
import shutil

import numpy as np
import pytest

from granavg.errors import UserError
from granavg.io.reader import DumpReader


@pytest.fixture(scope="module")
def plain(small_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("headers") / "atoms.dump"
    with gzip.open(small_run / "atoms.dump.gz", "rb") as src, open(out, "wb") as dst:
        shutil.copyfileobj(src, dst)
    return out


def heads(path, **kw):
    return [(f.timestep, f.time, f.data.shape[0], f.box.tobytes(), f.line)
            for f in DumpReader(path, **kw)]


@pytest.mark.parametrize("kind", ["plain", "gzip"])
def test_the_listing_matches_a_full_read(plain, small_run, kind):
    path = plain if kind == "plain" else small_run / "atoms.dump.gz"
    listed = heads(path, columns=[], headers_only=True)
    assert listed == heads(path) and len(listed) >= 3
    assert all(f.data.shape[1] == 0 for f in DumpReader(path, [], headers_only=True))


def test_a_series_is_listed_as_read(plain, tmp_path):
    """A dump.* series: each file one frame, listed in the order of the number."""
    text = plain.read_text()
    frames = ["ITEM: TIMESTEP" + f for f in text.split("ITEM: TIMESTEP")[1:]]
    for f in frames:
        (tmp_path / f"dump.{int(f.split()[2])}.txt").write_text(f)
    pattern = tmp_path / "dump.*.txt"
    assert heads(pattern, columns=[], headers_only=True) == heads(pattern)


def test_a_cut_last_frame_is_left_out_and_a_short_one_refused_alike(plain, tmp_path):
    lines = plain.read_text().splitlines(keepends=True)
    cut = tmp_path / "cut.dump"
    cut.write_text("".join(lines[:-3]))
    listed = heads(cut, columns=[], headers_only=True)
    assert listed == heads(cut) == heads(plain)[:-1]
    n = int(lines[3])
    short = tmp_path / "short.dump"                 # the first frame lacks a row
    short.write_text("".join(lines[:9 + n - 1] + lines[9 + n:]))
    messages = []
    for kw in ({}, {"columns": [], "headers_only": True}):
        with pytest.raises(UserError) as err:
            list(DumpReader(short, **kw))
        messages.append(str(err.value))
    assert messages[0] == messages[1] and f"has {n - 1} rows, its header says {n}" in messages[0]
    assert np.all(np.isfinite([h[0] for h in listed]))
