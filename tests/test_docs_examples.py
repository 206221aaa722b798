"""Every shell and Python example of docs/ runs (docs/*.md and docs/*/*.md).

Each fenced block of those pages is listed in PLAN below, by page and position, with the
first characters it must start with and how it is run; a new block, a moved one or one
whose start changed fails `test_every_block_of_the_docs_is_planned` until PLAN says how
it runs. How a block runs:

- ``run``: the block itself, in a fresh temporary directory: a shell block under
  ``bash -e`` with this venv's bin/ first on PATH (``granavg`` and ``python`` are this
  checkout's), a Python block with this venv's Python. Where the page names a user's own
  files (RUN, DIR, atoms.dump, $MAP, ...) the plan's ``subs`` replace them by a real small
  run, each pair in the open (a pair that no longer matches its block fails), and
  ``links`` put a fixture's files into the directory under the page's names. The inputs:
  the shipped examples (granavg/examples/data), docs/paper's tables, and short real runs
  of LAMMPS, LIGGGHTS and Yade (slow lane). Every ``--out`` a command names must exist
  after it. The environment is a user's: none of the tests' GRANAVG_ settings.
- ``covered``: run by the test module named.
- ``parsed``: too long to run here, for the reason given (minutes of simulation or a
  machine this project does not have): the block is valid bash, each ``granavg``
  command in it is accepted by granavg's own command line parser and each script it
  runs exists.
- ``text``: not a command (printed output, LAMMPS input lines).

Yade (docs/formats.md) runs in its own Python: its blocks run in one test of their own,
the install lines included, into a venv of Yade's Python made in the temporary
directory (as tests/test_yade.py does, from the session's wheel of this clone).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from .helpers import MAP3, run_cli, run_pile3d

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
BIN = Path(sys.executable).parent          # the venv's bin/: granavg, python
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.S | re.M)
SHELL, PYTHON = ("sh", "bash", "console", "shell"), ("python", "py")

#: The collapse deck's contact columns (workflows/collapse.py), as a Python dict.
COLLAPSE_MAP = ('{"id1": "c_pp[1]", "id2": "c_pp[2]", "dist": "c_pl[1]", "dx": "c_pl[2]", '
                '"dy": "c_pl[3]", "force": "c_pl[4]", "ftx": "c_pl[5]", "fty": "c_pl[6]"}')


@dataclass(frozen=True)
class Block:
    page: str             # relative to docs/
    k: int                # its position among the page's fenced blocks, from 0
    lang: str
    line: int             # of its opening fence
    code: str


@dataclass(frozen=True)
class Plan:
    how: str              # run, covered, parsed, text, yade
    starts: str           # what the block starts with
    lane: str = "slow"    # run: fast or slow
    needs: tuple = ()     # fixtures: their paths fill <name> in subs, links and prelude
    subs: tuple = ()      # (in the block, replaced by): a user's own files -> a real run
    links: tuple = ()     # (fixture, names or globs): its files linked into the directory
    env: tuple = ()       # (variable, value) the page assumes set
    prelude: str = ""     # Python: what the page says exists before the block
    apart: bool = False   # shell: its commands are alternatives: each in its own directory
    skip: tuple = ()      # (command start, reason): commands of the block not run
    expect: tuple = ()    # Python: files it must have written
    why: str = ""         # covered: the module; parsed, text: why


def blocks() -> list:
    out = []
    for path in sorted([*DOCS.glob("*.md"), *DOCS.glob("*/*.md")]):
        text = path.read_text()
        for k, m in enumerate(FENCE.finditer(text)):
            out.append(Block(str(path.relative_to(DOCS)), k, m.group(1).lower(),
                             text[:m.start()].count("\n") + 1, m.group(2)))
    return out


_PAPER = "the paper cell's run (2945 disks): a 1 s run of the paper preset stands for it"
_BENCH = "a benchmark: minutes to hours on 2 cores, its result the page's table"

PLAN = {
    # -- analysis.md -------------------------------------------------------------------
    ("analysis.md", 0): Plan(
        "run", "granavg analyze profiles20.csv profiles60.csv --out report/",
        links=(("paper_tables", ("profiles20.csv*", "profiles60.csv*")),),
        skip=(("granavg demo", "simulates the demo scene for 30 s: 4 min 20 s on 2 cores; "
               "its steps (simulate, average, analyze) run in this module on short runs"),)),
    # -- api.md, extending.md: run in one namespace by their own modules ---------------
    **{("api.md", k): Plan("covered", s, why="tests/test_api_docs.py") for k, s in enumerate((
        "import granavg", "from granavg.cells import Rings", "pile = granavg.examples",
        "frames = granavg.open(", "ds = fields.to_xarray()", "boxes = granavg.average", "smooth = granavg.average",
        "windows = granavg.average", "mixture = granavg.average",
        "rings20 = granavg.average", "import numpy as np",
        "import subprocess, sys", "from granavg.pipeline.api import run"))},
    **{("extending.md", k): Plan("covered", s, why="tests/test_extending.py")
       for k, s in enumerate(("from granavg.engine.quantities import", "import math",
                              "import numpy as np\n\nfrom granavg.engine import timing",
                              "from dataclasses import dataclass", "import granavg",
                              "import tempfile"))},
    # -- benchmarks.md -----------------------------------------------------------------
    ("benchmarks.md", 0): Plan("parsed", "python benchmarks/ovito_job.py RUN",
                               why=_BENCH + "; needs OVITO in an environment of its own"),
    ("benchmarks.md", 1): Plan("parsed", "granavg simulate --preset paper --out ENS",
                               why=_BENCH + "; the 4 paper runs take 13 min"),
    ("benchmarks.md", 2): Plan("parsed", "sh workflows/lammps_timing.sh", why=_BENCH),
    ("benchmarks.md", 3): Plan("parsed", "python benchmarks/end_to_end.py OUT fast",
                               why=_BENCH + "; 2 min 20 s and 7 min"),
    ("benchmarks.md", 4): Plan("parsed", "sh workflows/what_it_costs.sh", why=_BENCH),
    ("benchmarks.md", 5): Plan("parsed", 'B="granavg simulate --preset paper',
                               why=_BENCH + "; 16 runs of 2 s of the paper scene"),
    ("benchmarks.md", 6): Plan("parsed", "python benchmarks/big_3d.py make DIR",
                               why=_BENCH + "; an 803 MB dump, and OVITO"),
    # -- deck.md -----------------------------------------------------------------------
    ("deck.md", 0): Plan(
        "run", "from lammps import lammps",
        links=(("ROOT", ("lammps_inputs",)),),
        subs=(('cmdargs=["-log", "none", "-screen", "none"]',
               'cmdargs=["-log", "none", "-screen", "none", "-var", "n_grow", "200", '
               '"-var", "n_relax", "200", "-var", "n_shear", "200"]'),),
        expect=("prepared.data", "atoms.dump.gz", "sheared.data"),
        why="the deck's own 510 s of simulated time scaled to 600 steps"),
    # -- errors.md ---------------------------------------------------------------------
    ("errors.md", 0): Plan("parsed", "granavg simulate --preset paper --out ENS --seeds 4",
                           why="the calibration: 13 min of simulation, then 11 s"),
    ("errors.md", 1): Plan("parsed", "python workflows/calibrate_errors.py OUT OUT/runs",
                           why="needs the 4 runs of docs/paper (7 min 32 s)"),
    ("errors.md", 2): Plan("parsed", "python workflows/calibrate_derived.py OUT ENS",
                           why="needs the 4 paper runs of errors.md's first block"),
    ("errors.md", 3): Plan("parsed", "granavg simulate --preset paper-hooke --out ENS",
                           why="4 x 500 s of the plain-law scene: about 40 min"),
    # -- formats.md --------------------------------------------------------------------
    ("formats.md", 0): Plan("text", "compute pp all property/local",
                            why="LAMMPS input (tests/decks/pile_3d_si.lmp dumps the same)"),
    ("formats.md", 1): Plan("text", "compute cpgl all pair/gran/local",
                            why="LIGGGHTS input (tests/decks/pile_liggghts.lig runs it)"),
    ("formats.md", 2): Plan(
        "run", "granavg average --atoms atoms.dump --contacts contacts.dump --wall-contacts",
        links=(("liggghts_pile", ("atoms.dump", "contacts.dump", "walls.dump")),)),
    ("formats.md", 3): Plan("yade", "from granavg.pipeline.yade import YadeAverage"),
    ("formats.md", 4): Plan("yade", 'PY=$(head -1 "$(command -v yade)"'),
    ("formats.md", 5): Plan("yade", "import os\nfrom yade import export"),
    ("formats.md", 6): Plan("yade", "granavg average --atoms 'vtk/pile-spheres.*.vtu'"),
    # -- profiles.md -------------------------------------------------------------------
    ("profiles.md", 0): Plan(
        "run", "granavg average RUN_DIR --bins 20 --out profiles.csv", apart=True,
        needs=("paper_run",),
        subs=(("RUN_DIR", "<paper_run>"), ("--t-min 125", "--t-min 0.5")),
        why=_PAPER + "; its frames end at 1 s, so --t-min 0.5 for 125"),
    ("profiles.md", 1): Plan(
        "run", "granavg average RUN_DIR --bins 20 --kernel lucy", needs=("paper_run",),
        subs=(("RUN_DIR", "<paper_run>"),), why=_PAPER),
    # -- rheology.md -------------------------------------------------------------------
    ("rheology.md", 0): Plan(
        "run", "granavg rheology profiles20.csv --out rheology/",
        links=(("paper_tables", ("profiles20.csv*",)),),
        subs=(("runA.csv runB.csv", "profiles20.csv"),),
        why="docs/paper's 20-ring table stands for the two runs"),
    ("rheology.md", 1): Plan("run", "import granavg"),
    # -- refdem.md ---------------------------------------------------------------------
    ("refdem.md", 0): Plan(
        "parsed", "granavg simulate --preset paper-hooke --set t_end=60 --out runs/prep",
        subs=(("--out runs/prep ...", "--out runs/prep"),),
        why="60 s of the paper cell in the reference engine (numpy): hours; the engine "
            "runs in tests/test_refdem*.py on small cells"),
    # -- running-big.md ----------------------------------------------------------------
    ("running-big.md", 0): Plan("parsed", "granavg simulate --preset paper-hooke --out "
                                "runs/paper --np 4",
                                why="500 s of the paper cell on 4 MPI ranks: a 4-core "
                                    "machine and 9 min"),
    ("running-big.md", 1): Plan("parsed", "granavg simulate --preset paper-hooke --out "
                                "runs/p --omp 2", why="2 x 500 s of the paper cell: 18 min "
                                "(in situ on small runs: tests/test_insitu.py)"),
    ("running-big.md", 2): Plan("parsed", "/usr/bin/time -v granavg simulate --preset fast",
                                why="a measurement: 2 x 60 s of the fast scene, 4 min"),
    ("running-big.md", 3): Plan("parsed", "/usr/bin/time -v granavg simulate --preset "
                                "paper-hooke", why="a measurement: 2 x 500 s, 18 min"),
    ("running-big.md", 4): Plan(
        "run", "granavg average runs/paper --bins 20 --workers 2", apart=True,
        needs=("paper_run", "scheduler"),
        subs=(("runs/paper", "<paper_run>"), ("tcp://head:8786", "<scheduler>")),
        why=_PAPER + "; the cluster: a local dask scheduler with one worker"),
    ("running-big.md", 5): Plan(
        "run", "granavg average --atoms 'dump.*.txt' --contacts 'pairs.*.txt'",
        lane="fast", needs=("pile_series",),
        links=(("pile_series", ("dump.*.txt", "pairs.*.txt")),),
        subs=(("--contact-columns ...", "--contact-columns <pile_map>"),),
        why="the shipped 3D pile, one file per frame; '...': its contact columns"),
    # -- species.md --------------------------------------------------------------------
    ("species.md", 0): Plan(
        "run", "granavg average RUN --bins 20 --species type", apart=True,
        needs=("paper_run", "mixed_pile"),
        links=(("mixed_pile", ("atoms.dump", "contacts.dump")),),
        env=(("MAP", "<pile_map>"),),
        subs=(("granavg average RUN ", "granavg average <paper_run> "),
              ("granavg average ... ", "granavg average --atoms atoms.dump --contacts "
               "contacts.dump --contact-columns $MAP --gravity 0 0 -9.81 --slabs z "
               "--bins 12 ")),
        why=_PAPER + "; the dumps: tests/decks/pile_3d_si.lmp with types 1, 2 and a "
            "floor of type 3 (bidisperse yes, floor spheres); '...': the line above's "
            "inputs"),
    ("species.md", 1): Plan("run", "import granavg", needs=("paper_run",),
                            prelude='run = "<paper_run>"\n', why=_PAPER),
    ("species.md", 2): Plan(
        "run", "granavg average D/run --bins 20 --species type", needs=("paper_run",),
        subs=(("D/run", "<paper_run>"),), why="the demo's run: " + _PAPER),
    # -- stability.md: what granavg prints ---------------------------------------------
    **{("stability.md", k): Plan("text", "granavg: error:", why="an error message")
       for k in range(4)},
    # -- time.md -----------------------------------------------------------------------
    ("time.md", 0): Plan("run", "granavg average --atoms DIR/atoms.dump",
                         needs=("collapse_run",), subs=(("DIR/", "<collapse_run>/"),),
                         why="DIR: lammps_inputs/collapse_2d.lmp run to 70 ms "
                             "(workflows/collapse.py)"),
    ("time.md", 1): Plan("run", "import granavg", needs=("collapse_run",),
                         subs=(("DIR/", "<collapse_run>/"),
                               ("contact_map={...}", "contact_map=" + COLLAPSE_MAP)),
                         why="as the block above; {...}: the collapse's contact columns"),
    ("time.md", 2): Plan("text", "granavg: momentum balance in time at the frames'",
                         why="what granavg prints (tests/test_transient_decks.py -k "
                             "cli_says)"),
    ("time.md", 3): Plan("text", "fix     fmean all ave/atom 1 N N fx fy fz",
                         why="LAMMPS input (lammps_inputs/collapse_2d.lmp with -var "
                             "mean_forces 1 dumps the same; tests/test_transient_decks.py "
                             "-k mean_forces)"),
    # -- docs/*/README.md: the published runs, made again --------------------------------
    ("paper/README.md", 0): Plan("parsed", "python benchmarks/end_to_end.py OUT paper 4 2",
                                 why="the published ensemble: 7 min 32 s"),
    ("paper-rolling/README.md", 0): Plan(
        "parsed", "granavg simulate --preset paper-rolling --out ENS --seeds 4",
        why="the published ensemble: 4 x 250 s of the paper cell, about 30 min"),
    ("paper-strong-plate/README.md", 0): Plan(
        "parsed", "python benchmarks/end_to_end.py OUT paper-strong-plate 4 2",
        why="the published ensemble: about 8 min"),
    ("sweep/README.md", 0): Plan("parsed", "python workflows/sweep.py OUT",
                                 subs=(("tcp://HOST:8786", "tcp://127.0.0.1:8786"),),
                                 why="the study: every setting x 4 realisations, hours"),
    ("sweep/README.md", 1): Plan("text", "expected wall time", why="what granavg prints"),
}


def _planned(how):
    found = {(b.page, b.k): b for b in blocks()}
    slow = [pytest.mark.slow]
    return [pytest.param(found[key], plan, id=f"{key[0]}#{key[1]}",
                         marks=slow if (plan.how, plan.lane) == ("run", "slow") else [])
            for key, plan in PLAN.items() if plan.how == how and key in found]


# -- the inventory -----------------------------------------------------------------------

def test_every_block_of_the_docs_is_planned():
    """Each fenced block of docs/ is in PLAN, starts as PLAN says, and every shell or
    Python block is run, covered or parsed (text only for what is not a command)."""
    found = {(b.page, b.k): b for b in blocks()}
    assert set(found) == set(PLAN), ("unplanned: " + ", ".join(
        f"docs/{p} block {k + 1} (line {found[p, k].line})" for p, k in sorted(
            set(found) - set(PLAN))), "gone: " + ", ".join(
        f"docs/{p} block {k + 1}" for p, k in sorted(set(PLAN) - set(found))))
    for key, plan in PLAN.items():
        block = found[key]
        assert block.code.startswith(plan.starts), (key, block.code[:80])
        if block.lang in SHELL + PYTHON:
            assert plan.how in ("run", "covered", "parsed", "yade"), key
        else:
            assert plan.how == "text", (key, block.lang)
        if plan.how in ("parsed", "text", "covered"):
            assert plan.why, key
    for key, plan in PLAN.items():
        if plan.how == "covered":
            assert f"docs/{key[0]}" in (ROOT / plan.why).read_text(), key


def test_the_pages_show_no_placeholder_install():
    """granavg is not on the package index: no page tells to pip install it by name."""
    for block in blocks():
        assert not re.search(r"pip install[^\n|]*\s'?granavg(\s|$|\[)", block.code), block
    for path in DOCS.rglob("*.md"):
        assert not re.search(r"pip install[^`]*\s'?granavg(\[\w+\])?'?`", path.read_text()), path


# -- shared helpers ------------------------------------------------------------------------

def _fill(text: str, where: dict) -> str:
    for name, value in where.items():
        text = text.replace(f"<{name}>", str(value))
    assert not re.search(r"<(paper_run|scheduler|collapse_run|pile_map|mixed_pile|wheel)>",
                         text), text
    return text


def _substituted(block: Block, plan: Plan, where: dict) -> str:
    code = block.code
    for old, new in plan.subs:
        assert old in code, f"docs/{block.page} block {block.k + 1}: '{old}' not in it"
        code = code.replace(old, _fill(new, where))
    return code


def _commands(code: str) -> list:
    """The block's commands: continuation lines joined, comment-only lines dropped."""
    out = []
    for line in code.replace("\\\n", " ").splitlines():
        if line.strip() and not line.strip().startswith("#"):
            out.append(line)
    return out


def _env(plan: Plan, where: dict) -> dict:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("GRANAVG_") and k not in ("PYTHONPATH", "MPLBACKEND")}
    env.update(PATH=f"{BIN}{os.pathsep}{env.get('PATH', '')}", MPLBACKEND="Agg",
               PYTHONUNBUFFERED="1")
    env.update({k: _fill(v, where) for k, v in plan.env})
    return env


def _link(plan: Plan, where: dict, into: Path) -> None:
    for fixture, names in plan.links:
        src = Path(where[fixture])
        for name in names:
            matched = sorted(src.glob(name))
            assert matched, (fixture, name)
            for path in matched:
                (into / path.name).symlink_to(path)


def _outs(command: str) -> list:
    words = shlex.split(command, comments=True)
    return [words[i + 1] for i, w in enumerate(words[:-1]) if w == "--out"]


def _shell(command: str, cwd: Path, env: dict, timeout=600):
    proc = subprocess.run(["bash", "-e", "-c", command], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{command}\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    for out in _outs(command):
        assert (cwd / out).exists(), (command, out)
    return proc


# -- fixtures: the real runs that stand for a user's files ---------------------------------

@pytest.fixture(scope="module")
def paper_tables() -> Path:
    """docs/paper's tables (20 and 60 rings of the published ensemble)."""
    return DOCS / "paper"


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory) -> Path:
    """The paper preset's scene (2945 disks, from its shipped packing) sheared 1 s, a
    frame every 0.25 s; the average's default start at 0.005 rotations (0.31 s) so that
    the pages' commands without --t-min find frames (about 12 s)."""
    out = tmp_path_factory.mktemp("docs_paper") / "run"
    proc = run_cli("simulate", "--preset", "paper", "--out", out, "--no-progress",
                   *[a for s in ("t_end=1", "dump_dt=0.25", "restart_dt=1",
                                 "discard_rotations=0.005") for a in ("--set", s)])
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def mixed_pile(tmp_path_factory) -> Path:
    """tests/decks/pile_3d_si.lmp with atom types 1 (small), 2 (large) and a floor of
    fixed type-3 spheres: atoms.dump, contacts.dump (about 5 s)."""
    out = tmp_path_factory.mktemp("docs_mixed_pile")
    run_pile3d(out, bidisperse="yes", floor="spheres")
    return out


@pytest.fixture(scope="module")
def pile_series(tmp_path_factory) -> Path:
    """The shipped 3D pile (granavg.examples.pile_3d) one file per frame, named as
    docs/running-big.md names them: dump.<step>.txt, pairs.<step>.txt."""
    import gzip

    from granavg import examples

    out = tmp_path_factory.mktemp("docs_pile_series")
    start = re.compile(r"(?:ITEM: UNITS\n\S+\n)?(?:ITEM: TIME\n\S+\n)?ITEM: TIMESTEP\n")
    for src, stem in ((examples.pile_3d.atoms, "dump"), (examples.pile_3d.contacts, "pairs")):
        text = gzip.open(src, "rt").read()
        cuts = [m.start() for m in start.finditer(text)] + [len(text)]
        frames = [text[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
        assert len(frames) == 3
        for f in frames:
            step = re.search(r"ITEM: TIMESTEP\n(\d+)", f).group(1)
            (out / f"{stem}.{step}.txt").write_text(f)
    return out


@pytest.fixture(scope="module")
def collapse_run(tmp_path_factory) -> Path:
    """lammps_inputs/collapse_2d.lmp as workflows/collapse.py runs it, at the deck's own
    dt = t_c/50, to 70 ms, frames every 4 steps over 60.5-69.5 ms (about 7 s)."""
    sys.path.insert(0, str(ROOT / "workflows"))
    try:
        import collapse
    finally:
        sys.path.remove(str(ROOT / "workflows"))
    return collapse.run_deck(tmp_path_factory.mktemp("docs_collapse") / "run", 50,
                             duration=0.07, step=4)


@pytest.fixture(scope="module")
def liggghts_pile(tmp_path_factory) -> Path:
    """tests/decks/pile_liggghts.lig with its mesh floor (about 25 s): atoms.dump,
    contacts.dump and walls.dump of compute pair/gran/local and wall/gran/local with the
    keywords pos id force delta, as docs/formats.md writes them."""
    if shutil.which("liggghts") is None:
        pytest.skip("liggghts not installed: apt-get install -y liggghts")
    out = tmp_path_factory.mktemp("docs_liggghts")
    decks = ROOT / "tests" / "decks"
    proc = subprocess.run(["liggghts", "-in", str(decks / "pile_liggghts.lig"), "-log",
                           "none", "-echo", "none", "-var", "out", str(out), "-var", "stl",
                           str(decks / "floor_liggghts.stl")], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0 and (out / "walls.dump").exists(), proc.stdout[-2000:]
    return out


@pytest.fixture(scope="module")
def scheduler():
    """A dask scheduler with one worker on this machine: the pages' tcp://head:8786."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def _where(plan: Plan, request) -> dict:
    where = {"pile_map": MAP3, "ROOT": ROOT}
    for name in {*plan.needs, *(f for f, _ in plan.links)} - {"ROOT"}:
        where[name] = request.getfixturevalue(name)
    return where


# -- the blocks that run -------------------------------------------------------------------

@pytest.mark.parametrize("block, plan", _planned("run"))
def test_the_example_runs(block, plan, tmp_path, request):
    where = _where(plan, request)
    code = _substituted(block, plan, where)
    env = _env(plan, where)
    if block.lang in PYTHON:
        _link(plan, where, tmp_path)
        script = tmp_path / "example.py"
        script.write_text(_fill(plan.prelude, where) + code)
        proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"docs/{block.page} block {block.k + 1}\n" + \
            proc.stderr[-3000:]
        for name in plan.expect:
            assert (tmp_path / name).exists(), name
        return
    commands = _commands(code)
    for start, reason in plan.skip:
        assert any(c.startswith(start) for c in commands), (start, reason)
    commands = [c for c in commands if not any(c.startswith(s) for s, _ in plan.skip)]
    assert commands
    if plan.apart:
        for i, command in enumerate(commands):
            cwd = tmp_path / f"line{i + 1}"
            cwd.mkdir()
            _link(plan, where, cwd)
            _shell(command, cwd, env)
    else:
        _link(plan, where, tmp_path)
        _shell("\n".join(commands), tmp_path, env)


# -- the blocks too long to run: parsed ----------------------------------------------------

@pytest.mark.parametrize("block, plan", _planned("parsed"))
def test_the_example_too_long_to_run_is_valid(block, plan, monkeypatch):
    from granavg.cli import _parser
    from granavg.errors import UserError

    code = _substituted(block, plan, {})
    proc = subprocess.run(["bash", "-n", "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for command in _commands(code):
        words = shlex.split(command, comments=True)
        while words[:1] == ["/usr/bin/time"] or words[:1] == ["-v"]:
            words = words[1:]
        if not words or "=" in words[0]:
            continue                                   # a variable's assignment
        if words[0] == "granavg":
            try:
                _parser().parse_args(words[1:])
            except (SystemExit, UserError) as stop:
                pytest.fail(f"docs/{block.page} block {block.k + 1}: granavg refuses "
                            f"'{command}' ({stop})")
        elif words[0] in ("python", "sh"):
            assert (ROOT / words[1]).is_file(), (block.page, words[1])
        else:
            pytest.fail(f"docs/{block.page} block {block.k + 1}: what runs '{command}'?")


# -- Yade: docs/formats.md's install lines, in process and from files ----------------------

#: What docs/formats.md's Yade blocks assume built: a small pile (144 spheres of
#: d = 1.6 and 2.4 mm falling onto a box floor, periodic in x and y), O.dt = 2e-5 s
#: (the `--dt 2e-05` of the page's command), 2000 steps run.
YADE_SCENE = """\
from yade import utils
from yade.wrapper import (Bo1_Box_Aabb, Bo1_Sphere_Aabb, ForceResetter, FrictMat,
                          Ig2_Box_Sphere_ScGeom, Ig2_Sphere_Sphere_ScGeom,
                          InsertionSortCollider, InteractionLoop,
                          Ip2_FrictMat_FrictMat_FrictPhys, Law2_ScGeom_FrictPhys_CundallStrack,
                          NewtonIntegrator, PyRunner, VTKRecorder)
O.periodic = True
O.cell.setBox(0.016, 0.016, 0.1)
O.materials.append(FrictMat(young=1e6, poisson=0.3, density=2500, frictionAngle=0.5))
O.bodies.append(utils.box((0.008, 0.008, -1e-3), (0.008, 0.008, 1e-3), fixed=True))
for k in range(144):
    layer, cell = divmod(k, 36)
    i, j = divmod(cell, 6)
    O.bodies.append(utils.sphere(((i + 0.5) * 0.016 / 6, (j + 0.5) * 0.016 / 6,
                                  1.3e-3 + layer * 0.016 / 6), (0.8e-3, 1.2e-3)[k % 2]))
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()],
                                   allowBiggerThanPeriod=True),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                             [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.5)]
O.dt = 2e-5
O.run(2000, True)
"""


def _block(page: str, k: int) -> Block:
    found = next(b for b in blocks() if (b.page, b.k) == (page, k))
    assert found.code.startswith(PLAN[page, k].starts)
    return found


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("yade") is None,
                    reason="yade not installed: apt-get install -y python3-yade yade")
def test_the_yade_examples_run_as_written(wheel, tmp_path):
    """docs/formats.md's install lines, literally (Yade's Python from its launcher's
    shebang, a venv of it, granavg from this clone, numpy pinned to Yade's), but for the
    clone's path: the wheel this session built from the clone (what pip makes of the
    clone; building it again costs 1-3 min); they run the in-process block after a small
    scene; the same venv runs the export block, whose files the page's command averages."""
    inprocess, install, export, average = (_block("formats.md", k) for k in (3, 4, 5, 6))
    yade = shutil.which("yade")
    with open(os.path.realpath(yade)) as fh:
        system = fh.readline()[2:].strip()
    tag = subprocess.run([system, "-c", "import sys; print(f'cp{sys.version_info[0]}"
                          "{sys.version_info[1]}')"], capture_output=True, text=True,
                         check=True).stdout.strip()
    clone = str(wheel) if f"-{tag}-" in wheel.name else str(ROOT)
    env = _env(Plan("run", ""), {})
    (tmp_path / "script.py").write_text(YADE_SCENE + inprocess.code)
    code = install.code
    for old, new in (("/path/to/granavg", clone), ("script.py ARGS", "script.py")):
        assert old in code, old
        code = code.replace(old, new)
    _shell(code, tmp_path, env, timeout=900)
    from granavg.io.profiles_io import read_profiles

    slabs = read_profiles(tmp_path / "slabs.csv")
    assert slabs.meta["inputs"]["format"] == "yade" and slabs.cells.n == 6
    assert slabs.values["nu"][0] > 0.1 and slabs.values["sigma_zz"][0] < 0

    files = tmp_path / "export"
    files.mkdir()
    (files / "script.py").write_text(YADE_SCENE + export.code + "O.run(2000, True)\n")
    _shell(f"{tmp_path / 'V/bin/python'} {yade} -n -x script.py", files, env)
    _shell("\n".join(_commands(average.code)), files, env)
    from_files = read_profiles(files / "slabs.csv")
    assert from_files.frames_averaged == slabs.frames_averaged == 10
    assert from_files.values["nu"][0] > 0.1 and from_files.values["sigma_zz"][0] < 0
    np.testing.assert_allclose(from_files.cells.edges, slabs.cells.edges)
