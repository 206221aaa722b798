"""The damage harness shared by tests/test_damage_*.py: each input route's real, clean
output is built once per module, copied, damaged in one place and averaged by the real
command line (``python -m granavg average ...`` in a subprocess). The verdicts:

- :func:`refused`: exit 2 with exactly one ``granavg: error:`` line naming what and where
  (every needle; a tuple is any one of its items), no traceback, nothing left in the
  output folder;
- :func:`same_numbers`: exit 0 and the numbers of the clean run.

Their assertion messages start with the kind of failure (``DEFECT traceback``, ``DEFECT
silent wrong``, ``DEFECT exit``, ``WEAK message``), so that a failing run reads as a work
list. Besides them: readers and writers of the layouts damaged here (LAMMPS' text, binary
and yaml dumps, legacy VTK text), written from the formats' own descriptions, without
granavg."""

from __future__ import annotations

import re
import shutil
import struct
from pathlib import Path

import numpy as np

from granavg.io.profiles_io import read_profiles

from .helpers import run_cli

# -- running the command line and judging it -----------------------------------------------


def average(*args, timeout=600):
    """``granavg average ARGS`` in a subprocess: the CompletedProcess."""
    return run_cli("average", *args, "--no-progress", timeout=timeout)


def out_path(tmp_path, name="p.csv") -> Path:
    """An output path in an empty folder of its own (what :func:`refused` looks into)."""
    folder = tmp_path / "out"
    folder.mkdir(exist_ok=True)
    return folder / name


def errors(stderr: str) -> list:
    return [ln for ln in stderr.splitlines() if ln.startswith("granavg:") and "error" in ln]


def _traceback(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    return lines[-1] if lines else ""


#: A path in a message: a needle that is no path is looked for in the line with each path
#: cut to its file name (the tests' own folder names hold words such as 'nan').
_PATH = re.compile(r"(?:/[^\s:;,()']+)+")


def _has(line: str, needle) -> bool:
    if isinstance(needle, tuple):
        return any(_has(line, n) for n in needle)
    needle = str(needle)
    return needle in (line if "/" in needle else
                      _PATH.sub(lambda m: m.group(0).rsplit("/", 1)[-1], line))


def refused(proc, out, *needles, clean=None) -> str:
    """The call exits 2 with one error line holding every needle (a tuple: any of its
    items), without a traceback, and leaves nothing in ``out``'s folder. ``clean``: the
    clean run's profiles, to say how far the numbers are off where the damage went
    through. Returns the error line."""
    if "Traceback" in proc.stderr:
        raise AssertionError(f"DEFECT traceback (exit {proc.returncode}): "
                             f"{_traceback(proc.stderr)}")
    if proc.returncode == 0:
        what = difference(out, clean) if clean is not None and Path(out).exists() else \
            "no comparison"
        said = proc.stderr.strip().splitlines()[-2:]
        raise AssertionError(f"DEFECT silent wrong: exit 0 ({what}); stderr ends: {said}")
    lines = errors(proc.stderr)
    assert proc.returncode == 2, f"DEFECT exit {proc.returncode}: {proc.stderr[-600:]}"
    assert len(lines) == 1, f"WEAK message: {len(lines)} error lines: {lines}"
    missing = [n for n in needles if not _has(lines[0], n)]
    assert not missing, f"WEAK message: lacks {missing}: {lines[0]}"
    left = sorted(p.name for p in Path(out).parent.iterdir())
    assert not left, f"DEFECT output left behind: {left}"
    print(f"observed: {lines[0]}")
    return lines[0]


def accepted(proc, out) -> object:
    """Exit 0 without a traceback: the profiles written."""
    if "Traceback" in proc.stderr:
        raise AssertionError(f"DEFECT traceback (exit {proc.returncode}): "
                             f"{_traceback(proc.stderr)}")
    assert proc.returncode == 0, f"DEFECT exit {proc.returncode}: {errors(proc.stderr)}"
    return read_profiles(out)


def difference(out, clean) -> str:
    """How the profiles at ``out`` differ from ``clean`` (profiles): frames and the
    largest relative difference of any field, in words."""
    got = read_profiles(out)
    words = []
    if got.frames_averaged != clean.frames_averaged:
        words.append(f"{got.frames_averaged} frames averaged, clean {clean.frames_averaged}")
    lost = sorted(set(clean.values) - set(got.values))
    if lost:
        words.append(f"{len(lost)} fields missing: {' '.join(lost[:6])}"
                     f"{' ...' if len(lost) > 6 else ''}")
    worst, name = 0.0, None
    for k in set(clean.values) & set(got.values):
        a, b = np.asarray(got.values[k], float), np.asarray(clean.values[k], float)
        if a.shape != b.shape:
            words.append(f"{k} shape {a.shape}, clean {b.shape}")
            continue
        if not np.array_equal(np.isnan(a), np.isnan(b)):
            words.append(f"{k}: NaN in {int(np.isnan(a).sum())} cells, clean "
                         f"{int(np.isnan(b).sum())}")
            continue
        scale = np.nanmax(np.abs(b)) if np.any(np.isfinite(b)) else 0.0
        off = np.nanmax(np.abs(a - b)) if np.any(np.isfinite(a)) else 0.0
        rel = off / scale if scale > 0 else off
        if rel > worst:
            worst, name = rel, k
    if name is not None:
        words.append(f"largest difference {worst:.3g} of the largest value, in {name}")
    return "; ".join(words) or "same numbers as clean"


def same_numbers(proc, out, clean, rtol=0.0):
    """Exit 0 and every field of the clean run's profiles within ``rtol`` of its largest
    value (0: equal), over as many frames. Returns the profiles."""
    got = accepted(proc, out)
    assert got.frames_averaged == clean.frames_averaged and \
        set(got.values) == set(clean.values), f"DEFECT silent wrong: {difference(out, clean)}"
    for k in clean.values:
        a, b = np.asarray(got.values[k], float), np.asarray(clean.values[k], float)
        scale = np.nanmax(np.abs(b)) if np.any(np.isfinite(b)) else 0.0
        ok = np.array_equal(a, b, equal_nan=True) or (
            rtol > 0 and np.array_equal(np.isnan(a), np.isnan(b)) and
            np.nanmax(np.abs(a - b), initial=0.0) <= rtol * scale)
        assert ok, f"DEFECT silent wrong: {difference(out, clean)}"
    print(f"observed: exit 0, {difference(out, clean)}")
    return got


def copy_files(src: Path, dst: Path, pattern="*") -> Path:
    """The files of ``src`` matching ``pattern`` copied into ``dst`` (made)."""
    dst.mkdir(parents=True, exist_ok=True)
    for p in Path(src).glob(pattern):
        if p.is_file():
            shutil.copy(p, dst / p.name)
    return dst


# -- LAMMPS text dumps ---------------------------------------------------------------------


class TextDump:
    """A LAMMPS text dump (``dump custom`` or ``dump local``) as lines, with the frames'
    rows and columns."""

    def __init__(self, lines):
        self.lines = list(lines)

    @classmethod
    def read(cls, path):
        return cls(Path(path).read_text().splitlines(keepends=True))

    def copy(self):
        return TextDump(self.lines)

    def write(self, path) -> Path:
        Path(path).write_text("".join(self.lines))
        return Path(path)

    def frame_starts(self) -> list:
        """0-based index of each frame's first line (``ITEM: UNITS``/``ITEM: TIME``
        before ``ITEM: TIMESTEP`` belong to it)."""
        starts = []
        for k, ln in enumerate(self.lines):
            if ln.startswith("ITEM: TIMESTEP"):
                s = k
                while s >= 2 and self.lines[s - 2].startswith(("ITEM: UNITS", "ITEM: TIME")):
                    s -= 2
                starts.append(s)
        return starts

    def frames(self) -> list:
        """The frames' lines."""
        s = self.frame_starts()
        return [self.lines[a:b] for a, b in zip(s, s[1:] + [len(self.lines)])]

    def step(self, frame) -> int:
        heads = [k for k, ln in enumerate(self.lines) if ln.startswith("ITEM: TIMESTEP")]
        return int(self.lines[heads[frame] + 1])

    def columns(self) -> list:
        head = next(ln for ln in self.lines if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")))
        return head.split()[2:]

    def rows(self, frame) -> list:
        """0-based line indices of the data rows of frame ``frame``."""
        heads = [k for k, ln in enumerate(self.lines)
                 if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES"))]
        ends = self.frame_starts()[1:] + [len(self.lines)]
        return list(range(heads[frame] + 1, ends[frame]))

    def cells(self, k) -> list:
        return self.lines[k].split()

    def set(self, k, column, value):
        """Line ``k`` (0-based) with ``column`` set to ``value`` (text)."""
        cells = self.cells(k)
        cells[self.columns().index(column)] = str(value)
        self.lines[k] = " ".join(cells) + "\n"

    def get(self, k, column) -> float:
        return float(self.cells(k)[self.columns().index(column)])

    def drop_column(self, column):
        j = self.columns().index(column)
        for f in range(len(self.frame_starts())):
            for k in self.rows(f):
                cells = self.cells(k)
                del cells[j]
                self.lines[k] = " ".join(cells) + "\n"
        for k, ln in enumerate(self.lines):
            if ln.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
                words = ln.split()
                del words[2 + j]
                self.lines[k] = " ".join(words) + "\n"

    def keep_frames(self, n):
        """Only the first ``n`` frames."""
        self.lines = [ln for f in self.frames()[:n] for ln in f]


# -- LAMMPS binary dumps -------------------------------------------------------------------


def read_binary(raw: bytes) -> list:
    """The frames of a LAMMPS binary dump (format revision 2: tools/binary2txt.cpp), each a
    dict of its header's fields and ``chunks``, the rows each processor wrote (flat
    doubles); ``start`` its first byte."""
    out, pos = [], 0

    def take(fmt):
        nonlocal pos
        v = struct.unpack_from(fmt, raw, pos)
        pos += struct.calcsize(fmt)
        return v

    def text(n):
        nonlocal pos
        s = raw[pos:pos + n]
        pos += n
        return s

    while pos < len(raw):
        f = {"start": pos}
        (m,) = take("<q")
        f["magic"] = text(-m)
        f["endian"], f["revision"] = take("<ii")
        (f["step"],) = take("<q")
        f["natoms"], f["triclinic"] = take("<qi")
        f["flags"] = list(take("<6i"))
        f["bounds"] = list(take("<6d"))
        f["tilt"] = list(take("<3d")) if f["triclinic"] else None
        (f["size_one"],) = take("<i")
        (n,) = take("<i")
        f["units"] = text(n)
        (f["has_time"],) = take("<b")
        f["time"] = take("<d")[0] if f["has_time"] else None
        (n,) = take("<i")
        f["names"] = text(n).decode().split()
        (nchunk,) = take("<i")
        f["chunks"] = []
        for _ in range(nchunk):
            (n,) = take("<i")
            f["chunks"].append(np.frombuffer(raw, "<f8", n, pos).copy())
            pos += 8 * n
        out.append(f)
    return out


def write_binary(frames, nchunk=None) -> bytes:
    """Frames of :func:`read_binary` as LAMMPS writes them; ``nchunk`` {frame index:
    the chunk count written instead of the true one}."""
    out = []
    for k, f in enumerate(frames):
        names = " ".join(f["names"]).encode()
        head = [struct.pack("<q", -len(f["magic"])), f["magic"],
                struct.pack("<ii", f["endian"], f["revision"]), struct.pack("<q", f["step"]),
                struct.pack("<qi", f["natoms"], f["triclinic"]), struct.pack("<6i", *f["flags"]),
                struct.pack("<6d", *f["bounds"])]
        if f["triclinic"]:
            head.append(struct.pack("<3d", *f["tilt"]))
        head += [struct.pack("<i", len(f["names"])), struct.pack("<i", len(f["units"])),
                 f["units"], struct.pack("<b", 1 if f["time"] is not None else 0)]
        if f["time"] is not None:
            head.append(struct.pack("<d", f["time"]))
        head += [struct.pack("<i", len(names)), names,
                 struct.pack("<i", (nchunk or {}).get(k, len(f["chunks"])))]
        for c in f["chunks"]:
            head += [struct.pack("<i", c.size), np.asarray(c, "<f8").tobytes()]
        out.append(b"".join(head))
    return b"".join(out)


def binary_rows(f) -> np.ndarray:
    """A binary frame's rows, shape (natoms, columns) (a copy)."""
    flat = np.concatenate(f["chunks"]) if f["chunks"] else np.empty(0)
    return flat.reshape(-1, len(f["names"])).copy()


def set_binary_rows(f, rows, nchunk=None):
    """``f`` holding ``rows`` (its names already matching), split into ``nchunk`` chunks
    (default: as many as it had)."""
    n = nchunk or max(len(f["chunks"]), 1)
    f["chunks"] = [np.ascontiguousarray(p).ravel() for p in np.array_split(rows, n)]
    f["natoms"] = rows.shape[0]
    f["size_one"] = rows.shape[1]


# -- LAMMPS dump yaml ----------------------------------------------------------------------


class YamlDump:
    """A LAMMPS ``dump yaml`` as lines, with its documents."""

    def __init__(self, lines):
        self.lines = list(lines)

    @classmethod
    def read(cls, path):
        return cls(Path(path).read_text().splitlines(keepends=True))

    def write(self, path) -> Path:
        Path(path).write_text("".join(self.lines))
        return Path(path)

    def documents(self) -> list:
        """(index of ``---``, index of ``...``) of each document, 0-based."""
        starts = [k for k, ln in enumerate(self.lines) if ln.startswith("---")]
        ends = [k for k, ln in enumerate(self.lines) if ln.startswith("...")]
        return list(zip(starts, ends))

    def key(self, doc, name) -> int:
        """Index of the line ``name:`` of document ``doc``."""
        a, b = self.documents()[doc]
        return next(k for k in range(a, b) if self.lines[k].startswith(f"{name}:"))

    def step(self, doc) -> int:
        return int(self.lines[self.key(doc, "timestep")].split(":")[1])

    def keywords(self) -> list:
        k = self.key(0, "keywords")
        return [w.strip() for w in self.lines[k].split("[", 1)[1].rsplit("]", 1)[0].split(",")
                if w.strip()]

    def rows(self, doc) -> list:
        k = self.key(doc, "data")
        return list(range(k + 1, self.documents()[doc][1]))

    def values(self, k) -> list:
        inner = self.lines[k].split("[", 1)[1].rsplit("]", 1)[0]
        return [w.strip() for w in inner.split(",") if w.strip()]

    def set_values(self, k, values):
        self.lines[k] = "  - [ " + " , ".join(values) + ", ]\n"

    def set(self, k, column, value):
        v = self.values(k)
        v[self.keywords().index(column)] = str(value)
        self.set_values(k, v)

    def drop_column(self, column):
        j = self.keywords().index(column)
        for d in range(len(self.documents())):
            for k in self.rows(d):
                v = self.values(k)
                del v[j]
                self.set_values(k, v)
            kk = self.key(d, "keywords")
            words = [w.strip() for w in self.lines[kk].split("[", 1)[1].rsplit("]", 1)[0]
                     .split(",") if w.strip()]
            del words[j]
            self.lines[kk] = "keywords: [ " + ", ".join(words) + ",  ]\n"


# -- legacy VTK text (LIGGGHTS' dump custom/vtk, Yade's VTKExporter) ------------------------


class LegacyVtk:
    """An ASCII legacy VTK file as lines: the blocks of values after a header line."""

    def __init__(self, path):
        self.path = Path(path)
        self.lines = self.path.read_text().splitlines(keepends=True)

    def write(self, path=None) -> Path:
        path = Path(path or self.path)
        path.write_text("".join(self.lines))
        return path

    def header(self, pattern) -> int:
        """Index of the first line matching the regular expression ``pattern``."""
        rx = re.compile(pattern)
        return next(k for k, ln in enumerate(self.lines) if rx.match(ln))

    def values(self, head, skip=0) -> list:
        """(line index, position in line) of each value after header line ``head`` (and
        ``skip`` more lines, e.g. LOOKUP_TABLE), up to the next line starting a block."""
        out = []
        for k in range(head + 1 + skip, len(self.lines)):
            words = self.lines[k].split()
            if words and re.match(r"^[A-Za-z_]", words[0]) and not \
                    re.match(r"^(nan|inf|-nan)$", words[0], re.I):
                break
            out += [(k, j) for j in range(len(words))]
        return out

    def set_value(self, where, value):
        k, j = where
        words = self.lines[k].split()
        words[j] = str(value)
        self.lines[k] = " ".join(words) + "\n"

    def get_value(self, where) -> float:
        k, j = where
        return float(self.lines[k].split()[j])


# -- XML VTK text (LIGGGHTS' dump custom/vtk .vtp) -----------------------------------------


class XmlVtk:
    """An ASCII XML VTK file as lines: the values of each ``DataArray``."""

    def __init__(self, path):
        self.path = Path(path)
        self.lines = self.path.read_text().splitlines(keepends=True)

    def write(self, path=None) -> Path:
        path = Path(path or self.path)
        path.write_text("".join(self.lines))
        return path

    def array(self, name) -> tuple:
        """(index of the ``<DataArray Name="name"`` line, of its ``</DataArray>``)."""
        start = next(k for k, ln in enumerate(self.lines)
                     if "<DataArray" in ln and f'Name="{name}"' in ln)
        end = next(k for k in range(start, len(self.lines)) if "</DataArray>" in self.lines[k])
        return start, end

    def values(self, name) -> list:
        """(line index, position in line) of each value of array ``name``."""
        start, end = self.array(name)
        out = []
        for k in range(start + 1, end):
            words = self.lines[k].split()
            if words and words[0].startswith("<"):
                break                                 # InformationKey: past the values
            out += [(k, j) for j in range(len(words))]
        return out

    set_value = LegacyVtk.set_value
    get_value = LegacyVtk.get_value


def drop_values(doc, where):
    """Remove the values at ``where`` ((line, position) pairs) from ``doc``'s lines."""
    by_line = {}
    for k, j in where:
        by_line.setdefault(k, set()).add(j)
    for k, js in by_line.items():
        words = doc.lines[k].split()
        indent = doc.lines[k][:len(doc.lines[k]) - len(doc.lines[k].lstrip())]
        doc.lines[k] = indent + " ".join(w for j, w in enumerate(words) if j not in js) + "\n"


# -- runs shared by the damage modules -----------------------------------------------------

ROOT = Path(__file__).resolve().parent.parent
DECKS = Path(__file__).resolve().parent / "decks"


def shared_run(tmp_path_factory, name, build) -> Path:
    """``build(directory)`` once per test session: a later module asking for ``name``
    gets the directory the first one built."""
    d = tmp_path_factory.getbasetemp() / name
    done = d / ".built"
    if not done.exists():
        if d.exists():
            shutil.rmtree(d)
        d.mkdir(parents=True)
        build(d)
        done.write_text("")
    return d


def run_liggghts(out: Path, **variables) -> Path:
    """tests/decks/pile_liggghts.lig run by Debian's liggghts (as tests/test_liggghts.py
    runs it): atoms.dump, contacts.dump, walls.dump, atoms_<step>.vtk/.vtp and their
    bounding boxes, 5 frames 500 steps apart."""
    import subprocess

    args = ["liggghts", "-in", str(DECKS / "pile_liggghts.lig"), "-log", "none", "-echo",
            "none", "-var", "out", str(out), "-var", "stl", str(DECKS / "floor_liggghts.stl")]
    for k, v in variables.items():
        args += ["-var", k, str(v)]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0 and (out / "contacts.dump").exists(), proc.stdout[-2000:]
    return out


def yade_python(tmp_path_factory) -> tuple:
    """(python, environment) that runs Yade with this checkout's granavg: a venv of Yade's
    own Python (the launcher's shebang) with its system packages, granavg's dependencies
    (pyproject.toml) pinned to Yade's numpy, and this checkout on PYTHONPATH (its compiled
    kernels are built for the same Python minor version; else granavg is installed
    from the checkout). Built once per session (about 30 s)."""
    import os
    import subprocess
    import sys
    import tomllib

    launcher = os.path.realpath(shutil.which("yade"))
    with open(launcher) as fh:
        system = fh.readline()[2:].strip()

    def build(d):
        venv = d / "venv"
        subprocess.run([system, "-m", "venv", "--system-site-packages", str(venv)], check=True)
        python = venv / "bin" / "python"
        numpy = subprocess.run([str(python), "-c", "import numpy; print(numpy.__version__)"],
                               capture_output=True, text=True, check=True).stdout.strip()
        (d / "pins.txt").write_text(f"numpy=={numpy}\n")
        deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
        same = subprocess.run([str(python), "-c", "import sys; print(sys.version_info[:2])"],
                              capture_output=True, text=True, check=True).stdout.strip() == \
            str(sys.version_info[:2])
        what = deps if same else [str(ROOT)]
        proc = subprocess.run([str(python), "-m", "pip", "install", "-q", "-c",
                               str(d / "pins.txt"), *what], capture_output=True, text=True,
                              timeout=900)
        assert proc.returncode == 0, proc.stderr[-3000:]
        (d / "pythonpath").write_text(str(ROOT) if same else "")

    d = shared_run(tmp_path_factory, "damage_yade_python", build)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    path = (d / "pythonpath").read_text()
    if path:
        env["PYTHONPATH"] = path
    return d / "venv" / "bin" / "python", env


def run_yade(python, env, script, *args, cwd=None, timeout=900):
    """``yade -n -x SCRIPT ARGS`` in ``python``: the CompletedProcess."""
    import os
    import subprocess

    return subprocess.run([str(python), os.path.realpath(shutil.which("yade")), "-n", "-x",
                           str(script), *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)
