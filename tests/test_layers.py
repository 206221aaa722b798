"""The package's layers: the engine (geometry, weights, channels, accumulators,
profiles, errors) imports nothing from io, sim or analysis, and no module imports its
way back into a circle with the LAMMPS driver."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "granavg"


def imports(path: Path) -> set:
    """Every granavg module a file imports (top level or inside functions)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.startswith("granavg"):
                found.add(node.module)
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            found.add("relative:" + (node.module or ""))
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("granavg"))
    return found


@pytest.mark.parametrize("path", sorted((ROOT / "engine").glob("*.py")), ids=lambda p: p.name)
def test_the_engine_imports_no_other_layer(path):
    bad = {m for m in imports(path)
           if m.startswith(("granavg.io", "granavg.sim", "granavg.analysis", "relative:"))}
    assert not bad, bad


def test_no_module_imports_the_driver_that_imports_it():
    """refdem_run shares the run's file names and progress bar through run_files, not
    through the driver that starts it."""
    for job in ("refdem_run", "run_files", "embedded", "mpi"):
        assert "granavg.sim.simulate" not in imports(ROOT / "sim" / f"{job}.py"), job
