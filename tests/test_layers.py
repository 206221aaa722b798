"""The package's layers and which may import which, read from the code's own imports
(top level or inside functions). Data flow one way: sim (runs) -> io (formats -> frames)
-> engine (frames -> profiles) -> analysis (profiles -> checks, figures); only the
pipeline wires them, and the CLI is a shell around the pipeline."""

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
            "granavg.engine.quantities", "granavg.engine.units", "granavg.__init__"),
    "analysis": ("granavg.errors", "granavg.engine"),
    "pipeline": ("granavg.errors", "granavg.signals", "granavg.dask_cluster", "granavg.engine",
                 "granavg.io",
                 "granavg.sim", "granavg.analysis", "granavg.__init__"),
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
    path.write_text("def f():\n    from granavg.analysis.claims import analyze\n")
    assert imports(path) == {"granavg.analysis.claims"}
    assert not within("granavg.analysis.claims", ("granavg.sim", *ALLOWED["sim"]))


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
