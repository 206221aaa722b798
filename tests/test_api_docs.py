"""The Python API as its documentation shows it: every ``python`` block of docs/api.md
runs, in order, in one namespace (on the shipped examples); ``help(granavg.average)``
is numpydoc with an example, and the examples in the API's docstrings run."""

import doctest
import importlib
import os
import pydoc
import re
import subprocess
import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"


def python_blocks(page: Path) -> list:
    return re.findall(r"```python\n(.*?)```", page.read_text(), re.S)


def test_every_example_of_docs_api_runs(tmp_path, monkeypatch):
    blocks = python_blocks(DOCS / "api.md")
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for k, code in enumerate(blocks):
        exec(compile(code, f"docs/api.md, block {k + 1}", "exec"), namespace)
    assert (tmp_path / "sigma_zz.png").exists() and (tmp_path / "rings.csv.json").exists()
    assert namespace["smooth"].units["divsigma_z"] == "Pa/m"
    assert list(namespace["moving"].values["v_x"]) == [1.0, 1.0]


def test_help_of_average_is_numpydoc_with_an_example():
    proc = subprocess.run([sys.executable, "-c", "import granavg; help(granavg.average)"],
                          capture_output=True, text=True, env=dict(os.environ, PAGER="cat"))
    assert proc.returncode == 0, proc.stderr
    for part in ("Parameters\n", "Returns\n", "Examples\n", ">>> fields = granavg.average("):
        assert part in proc.stdout, part


@pytest.mark.parametrize("module", ["granavg.pipeline.api", "granavg.engine.fields",
                                    "granavg.examples", "granavg.cells",
                                    "granavg.engine.unit_system"])
def test_the_docstrings_examples_run(module):
    found = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert found.attempted > 0 and found.failed == 0


def test_importing_granavg_loads_nothing_until_used():
    code = ("import sys, granavg; print(sorted(m for m in sys.modules if m.startswith("
            "'granavg')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.stdout.split() == ["['granavg']"], proc.stdout
    assert "average" in dir(__import__("granavg")) and pydoc.render_doc(
        __import__("granavg").average)
