"""The package's layers and which may import which, read from the code's own imports
(top level or inside functions). Data flow one way: sim (runs) -> io (formats -> frames)
-> engine (frames -> profiles) -> analysis (profiles -> checks, figures) -> paper (the
paper's claims and report); only the pipeline wires them, and the CLI is a shell around
the pipeline."""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "granavg"
#: layer -> the granavg modules or packages it may import (besides itself)
ALLOWED = {
    "engine": ("granavg.errors",),
    "io": ("granavg.errors", "granavg.signals", "granavg.engine"),
    "sim": ("granavg.errors", "granavg.signals", "granavg.dask_cluster", "granavg.io",
            "granavg.engine.quantities", "granavg.engine.requirements",
            "granavg.engine.unit_system",
            "granavg.engine.kernels", "granavg.__init__"),
    "analysis": ("granavg.errors", "granavg.engine"),
    "paper": ("granavg.errors", "granavg.engine", "granavg.analysis"),
    "pipeline": ("granavg.errors", "granavg.signals", "granavg.extras", "granavg.dask_cluster",
                 "granavg.engine", "granavg.io",
                 "granavg.sim", "granavg.analysis", "granavg.paper", "granavg.__init__"),
}


def imports(path: Path) -> set:
    """Every granavg module a file imports (top level or inside functions)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "granavg":
                found.update(f"granavg.{a.name}" if a.name != "__version__" else
                             "granavg.__init__" for a in node.names)
            elif node.module.startswith("granavg"):
                found.add(node.module)
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            found.add("relative:" + (node.module or ""))
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("granavg"))
    return found


def within(module: str, allowed) -> bool:
    return any(module == a or module.startswith(a + ".") for a in allowed)


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_each_layer_imports_only_what_it_may(layer):
    bad = {}
    for path in sorted((ROOT / layer).rglob("*.py")):
        wrong = {m for m in imports(path)
                 if not within(m, (f"granavg.{layer}", *ALLOWED[layer]))}
        if wrong:
            bad[path.name] = sorted(wrong)
    assert not bad, bad


def test_the_cli_only_calls_the_pipeline():
    wrong = {m for m in imports(ROOT / "cli.py")
             if not within(m, ("granavg.pipeline", "granavg.errors", "granavg.__init__",
                               "granavg.io.lammps_dumps"))}
    assert not wrong, wrong


def test_the_rules_can_fail(tmp_path):
    """The check sees a forbidden import where there is one (sim importing analysis,
    inside a function)."""
    path = tmp_path / "probe.py"
    path.write_text("def f():\n    from granavg.paper.claims import analyze\n")
    assert imports(path) == {"granavg.paper.claims"}
    assert not within("granavg.paper.claims", ("granavg.sim", *ALLOWED["sim"]))


def test_no_module_imports_the_driver_that_imports_it():
    """refdem_run shares the run's file names and progress bar through run_layout, not
    through the driver that starts it."""
    for job in ("refdem_run", "run_layout", "embedded", "mpi"):
        assert "granavg.sim.simulate" not in imports(ROOT / "sim" / f"{job}.py"), job


def test_importing_the_engine_and_the_cli_loads_no_lammps_no_mpi_no_analysis():
    code = ("import sys, granavg.engine, granavg.cli; "
            "maps = open('/proc/self/maps').read(); "
            "print('lammps' in sys.modules, 'libmpi' in maps, "
            "any(m.startswith('granavg.analysis') for m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "False", "False"]


HEAVY = ("scipy.stats", "scipy.spatial", "pandas", "dask", "matplotlib", "lammps", "tqdm")


@pytest.mark.parametrize("modules", [
    "granavg.engine, granavg.cli",
    "granavg.pipeline.averaging, granavg.io.lammps_dumps, granavg.io.profiles_io"])
def test_averaging_imports_nothing_it_does_not_use(modules):
    """The engine, the CLI and the average command's own modules load no statistics,
    no triangulation, no dask, no plotting and no pandas (0.3 s of start-up), nor tqdm
    unless a progress bar shows (0.04 s)."""
    code = (f"import sys, {modules}; "
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == []


def test_a_whole_average_of_a_real_run_loads_none_of_them(small_run, tmp_path):
    """`granavg average` of a LAMMPS run (both dumps, all quantities) writes its tables
    without loading any of :data:`HEAVY`; reading them back (analysis) uses pandas."""
    out = tmp_path / "p.csv"
    code = ("import sys; from granavg.cli import main; "
            f"code = main(['average', {str(small_run)!r}, '--bins', '6', '--t-min', '1.5', "
            f"'--out', {str(out)!r}, '--no-progress']); "
            f"print(code, *[m for m in {HEAVY!r} if m in sys.modules])")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["0"], proc.stdout + proc.stderr
    assert out.with_name("p.csv.timeseries.csv").exists()


def test_the_averaging_bar_shows_on_a_terminal_only(small_run, tmp_path):
    """`granavg average` under a pseudo-terminal draws its tqdm bar (and loads tqdm);
    through a pipe it draws none and loads none."""
    import pty

    def average(out, terminal):
        code = ("import sys; from granavg.cli import main; "
                f"code = main(['average', {str(small_run)!r}, '--bins', '6', '--t-min', "
                f"'1.5', '--out', {str(out)!r}]); "
                "sys.stdout.write('tqdm' in sys.modules and ' TQDM' or '')")
        if not terminal:
            proc = subprocess.run([sys.executable, "-c", code], capture_output=True,
                                  text=True)
            assert proc.returncode == 0, proc.stderr
            return proc.stdout + proc.stderr
        leader, follower = pty.openpty()
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                                stderr=follower)
        os.close(follower)
        seen = b""
        while True:                              # read as it comes: the pty's buffer is small
            try:
                chunk = os.read(leader, 1 << 16)
            except OSError:                      # the child has closed its end
                break
            if not chunk:
                break
            seen += chunk
        os.close(leader)
        stdout = proc.stdout.read().decode()
        assert proc.wait() == 0, seen.decode(errors="replace")
        return stdout + seen.decode(errors="replace")

    on_terminal = average(tmp_path / "t.csv", True)
    assert "averaging" in on_terminal and "frame" in on_terminal and "TQDM" in on_terminal
    piped = average(tmp_path / "p.csv", False)
    assert "averaging:" not in piped and "TQDM" not in piped


# -- the plug-ins' promises: no circle, no dispatch on a kind, no flags below the CLI ------

def module_name(path: Path, root: Path = ROOT) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def import_graph(root: Path = ROOT) -> dict:
    """granavg module -> the granavg modules it imports (top level or in functions), each
    import resolved to the module it names (``from a.b import c`` is ``a.b.c`` where
    that is a module, else ``a.b``)."""
    modules = {module_name(p, root): p for p in root.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        edges = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and \
                    node.module.startswith("granavg"):
                for alias in node.names:
                    full = f"{node.module}.{alias.name}"
                    edges.add(full if full in modules else node.module)
            elif isinstance(node, ast.Import):
                edges.update(a.name for a in node.names if a.name in modules)
        graph[name] = {e for e in edges if e in modules and e != name}
    return graph


def circles(graph: dict) -> list:
    """Every import circle (strongly connected group of more than one module)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_module_imports_itself_through_others():
    assert circles(import_graph()) == []


def test_the_circle_check_sees_a_circle(tmp_path):
    pkg = tmp_path / "granavg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from granavg.b import f\n")
    (pkg / "b.py").write_text("def f():\n    from granavg.a import g\n")
    assert circles(import_graph(pkg)) == [["granavg.a", "granavg.b"]]


def kinds() -> set:
    from granavg.engine.cells import registry
    return set(registry())


def kind_dispatch(path: Path, known: set) -> list:
    """Lines that compare something with the name of a kind of cells."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Compare):
            for part in (node.left, *node.comparators):
                names = [part] if isinstance(part, ast.Constant) else \
                    list(part.elts) if isinstance(part, (ast.Tuple, ast.List, ast.Set)) else []
                if any(isinstance(n, ast.Constant) and n.value in known for n in names):
                    out.append(node.lineno)
    return out


def test_no_dispatch_on_a_kind_of_cells_outside_their_modules():
    """Everything specific to a geometry is in its module of granavg/engine/cells: no
    other code compares a kind with a geometry's name."""
    known = kinds()
    cells = ROOT / "engine" / "cells"
    found = {str(p.relative_to(ROOT)): lines for p in sorted(ROOT.rglob("*.py"))
             if cells not in p.parents and (lines := kind_dispatch(p, known))}
    assert not found, found


def test_the_dispatch_check_sees_a_dispatch(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("def f(g):\n    if g.kind in ('slabs', 'slabs3d'):\n        return 1\n")
    assert kind_dispatch(probe, kinds()) == [2]


FLAG = __import__("re").compile(r"(?<![\w-])--[a-z][a-z-]+")


def flag_texts(path: Path) -> list:
    """(line, flag) of each command-line flag in a string of the file that is not a
    docstring (messages, log lines, data written into outputs)."""
    tree = ast.parse(path.read_text())
    docs = docstring_ids(tree)
    return [(node.lineno, m) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docs for m in FLAG.findall(node.value)]


def test_no_flag_text_below_the_cli():
    """Flags live in cli.py; below it messages name parameters ({t_min}), which the CLI
    names as its flags (errors.ParameterError, errors.named)."""
    found = {str(p.relative_to(ROOT)): texts for p in sorted(ROOT.rglob("*.py"))
             if p != ROOT / "cli.py" and (texts := flag_texts(p))}
    assert not found, found


def test_the_flag_check_sees_a_flag(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""Docs may say --t-min."""\n\ndef f():\n    raise ValueError("give '
                     '--t-min T")\n')
    assert flag_texts(probe) == [(4, "--t-min")]


def lines_outside_the_parser(path: Path) -> int:
    """Lines of a module outside the functions that build its argument parser (those
    calling ``add_argument`` or ``add_parser``)."""
    tree = ast.parse(path.read_text())
    builders = 0
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(
                isinstance(n, ast.Attribute) and n.attr in ("add_argument", "add_parser")
                for n in ast.walk(node)):
            builders += node.end_lineno - node.lineno + 1
    return len(path.read_text().splitlines()) - builders


def test_the_cli_is_argument_parsing():
    """cli.py holds its parser and a call of the pipeline's commands: at most 150
    lines besides the parser (the commands' logic lives in granavg.pipeline.commands);
    the count sees a command's logic moved back into it."""
    assert lines_outside_the_parser(ROOT / "cli.py") <= 150
    grown = ROOT.parent / "tests" / "__cli_probe.py"
    try:
        grown.write_text((ROOT / "cli.py").read_text() +
                         (ROOT / "pipeline" / "commands.py").read_text())
        assert lines_outside_the_parser(grown) > 150
    finally:
        grown.unlink()


def test_the_help_says_what_granavg_does_in_full_sentences():
    """``granavg --help`` describes the tool in sentences that end (no RST markup), and
    an example option value stays whole on its line (wrapped only between words)."""
    env = dict(os.environ, COLUMNS="80")
    top = subprocess.run([sys.executable, "-m", "granavg", "--help"], capture_output=True,
                         text=True, env=env)
    text = top.stdout.split("positional arguments")[0]
    description = " ".join(text.split("\n\n", 1)[1].split())
    assert description.endswith(".") and "``" not in top.stdout and len(description) > 100
    avg = subprocess.run([sys.executable, "-m", "granavg", "average", "--help"],
                         capture_output=True, text=True, env=env)
    example = ("id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],"
               "ftx=c_pl[5],fty=c_pl[6]")
    assert any(line.strip() == example for line in avg.stdout.splitlines()), avg.stdout


def docstring_ids(tree) -> set:
    """The string constants of a module that are docstrings."""
    docs = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef,
                             ast.ClassDef)) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant):
            docs.add(id(body[0].value))
    return docs


def registered() -> tuple:
    """(kinds of cells, their class names, kernel names - in space and in time) as the
    registries hold them."""
    from granavg.engine.cells import registry as cells
    from granavg.engine.smoothing import registry as kernels
    from granavg.engine.timing import registry as time_kernels
    return (set(cells()), {c.__name__ for c in cells().values()},
            set(kernels()) | set(time_kernels()))


def plugin_names(path: Path, kinds, classes, kernels) -> list:
    """(line, name) of each kernel or geometry named in a string of the file that is not
    a docstring: a kernel's name or a cells class's as a word; a kind of cells as the
    whole string, or as a word where it is no English word (``polar_grid``)."""
    tree = ast.parse(path.read_text())
    docs = docstring_ids(tree)
    pieces = {id(v) for node in ast.walk(tree) if isinstance(node, ast.JoinedStr)
              for v in node.values}                          # parts of f-strings' text
    out = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Constant) and isinstance(node.value, str)) or \
                id(node) in docs:
            continue
        whole = id(node) not in pieces
        for word in set(__import__("re").findall(r"[A-Za-z_][A-Za-z0-9_]*", node.value)):
            identifier = "_" in word or any(ch.isdigit() for ch in word)
            if word in kernels or word in classes or (
                    word in kinds and ((whole and node.value.strip() == word) or identifier)):
                out.append((node.lineno, word))
    return sorted(out)


def test_no_kernel_or_geometry_is_named_outside_its_registry():
    """Messages, help and choices name kernels and kinds of cells from their registries
    (granavg/engine/smoothing, granavg/engine/timing, granavg/engine/cells): a new
    kernel or geometry is one module there, and appears everywhere else by itself."""
    names = registered()
    own = (ROOT / "engine" / "cells", ROOT / "engine" / "smoothing", ROOT / "engine" / "timing")
    found = {str(p.relative_to(ROOT)): hits for p in sorted(ROOT.rglob("*.py"))
             if not any(d in p.parents for d in own) and (hits := plugin_names(p, *names))}
    assert not found, found


def test_the_name_check_sees_a_name(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""Lucy\'s kernel may be named here."""\n\nKINDS = ("rings", '
                     '"a polar_grid")\nHELP = "smooth with lucy or gauss"\n')
    assert plugin_names(probe, *registered()) == [(3, "polar_grid"), (3, "rings"),
                                                  (4, "gauss"), (4, "lucy")]


# -- the tests' own layers: modules share helpers, never one another ---------------------

TESTS = Path(__file__).resolve().parent
#: The test package's modules any test module may import.
SHARED = ("helpers", "damage", "conftest")


def imported_test_modules(path: Path, own: set) -> list:
    """(line, module) for each module of the test package (``own``: their names) that a
    file imports, top level or inside functions, relatively (``from .x``, ``from . import
    x``) or through the package (``from tests.x``, ``from tests import x``, ``import
    tests.x``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level == 0 and (module == "tests" or module.startswith("tests.")):
                module = module[len("tests"):].lstrip(".")
            elif node.level == 0:
                continue
            names = [module.split(".")[0]] if module else [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name.split(".")[1] for a in node.names
                     if a.name.startswith("tests.")]
        found += [(node.lineno, n) for n in names if n in own]
    return sorted(found)


def test_no_test_module_imports_another():
    """What several test modules use (helpers, deck runners, synthetic profiles) lives
    in tests/helpers.py, the damage harness in tests/damage.py, fixtures in
    tests/conftest.py: a test module imports no other
    test module, so each can be read, run and changed alone."""
    own = {p.stem for p in TESTS.glob("*.py")}
    found = {p.name: wrong for p in sorted(TESTS.glob("*.py"))
             if (wrong := [(line, m) for line, m in imported_test_modules(p, own)
                           if m not in SHARED])}
    assert not found, found


def test_the_test_import_check_sees_an_import(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("from .helpers import run_cli\nfrom .test_default_dumps import frames\n"
                     "from tests.conftest import small_cell_args\n\n\ndef f():\n"
                     "    from tests.test_claims import SCENE\n    from . import test_b\n"
                     "    import tests.test_c\n    from granavg.engine import average\n")
    own = {"helpers", "conftest", "test_default_dumps", "test_claims", "test_b", "test_c"}
    assert imported_test_modules(probe, own) == [
        (1, "helpers"), (2, "test_default_dumps"), (3, "conftest"), (7, "test_claims"),
        (8, "test_b"), (9, "test_c")]
    wrong = [m for _, m in imported_test_modules(probe, own) if m not in SHARED]
    assert wrong == ["test_default_dumps", "test_claims", "test_b", "test_c"]
