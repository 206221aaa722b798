"""The docstrings' cross-references (``:func:`...```, ``:class:``, ``:meth:``, ...) name
things that exist: a dotted path, a name of the module, or a member (dataclass fields
included) of one of its classes. A reference left behind by a move fails here."""

import dataclasses
import importlib
import inspect
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REF = re.compile(r":(mod|func|class|meth|data|attr):`~?([\w.]+)`")


def has(obj, name) -> bool:
    if hasattr(obj, name):
        return True
    return dataclasses.is_dataclass(obj) and name in {f.name for f in dataclasses.fields(obj)}


def resolves(ref: str, module) -> bool:
    """A dotted path from a module of granavg, or a name of ``module`` or of one of its
    classes."""
    parts = ref.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        ok = True
        for part in parts[i:]:
            if not has(obj, part):
                ok = False
                break
            obj = getattr(obj, part, None)
        if ok:
            return True
    obj = module
    if all(has(obj, p) and (obj := getattr(obj, p, None)) is not None or p == parts[-1]
           for p in parts):
        if has(module, parts[0]):
            return True
    classes = [c for _, c in inspect.getmembers(module, inspect.isclass)]
    return len(parts) == 1 and any(has(c, parts[0]) for c in classes)


def broken_references(path: Path) -> list:
    name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    module = importlib.import_module(name.removesuffix(".__init__"))
    text = path.read_text()
    return [(text[:m.start()].count("\n") + 1, m.group(2)) for m in REF.finditer(text)
            if not resolves(m.group(2), module)]


def test_every_cross_reference_of_the_docstrings_resolves():
    found = {str(p.relative_to(ROOT)): refs for p in sorted((ROOT / "granavg").rglob("*.py"))
             if p.name != "__main__.py" and (refs := broken_references(p))}
    assert not found, found


def test_the_reference_check_sees_a_stale_one():
    module = importlib.import_module("granavg.io.reader")
    assert not resolves("granavg.io.reader.CONSISTENCY", module)
    assert resolves("granavg.engine.fields.Fields.to_xarray", module)
    assert resolves("DumpReader", module)
