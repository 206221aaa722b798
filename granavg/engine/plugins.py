"""One registry for every axis of growth (cells, smoothing kernels, quantities, input
formats): the objects a package's modules define under one attribute name, found
without being listed anywhere; those an installed package names as entry points of the
registry's group (``granavg.formats``, ...: a plug-in outside granavg's tree that the
command line sees too); and those registered at run time (:meth:`Registry.register`). Each registry owns
what its objects declare (name, help, contract) and checks it when one registers."""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Option:
    """An option a plug-in declares (a kind of cells, an input format), as its Python
    code, the API's keywords and the command line (``--name-with-dashes``, or ``flag``)
    take it.

    Attributes
    ----------
    name : str
        The Python name (a keyword of :func:`granavg.average`).
    help : str
        What it sets, in words (lengths in the data's unit); other options named as
        ``{name}`` fields, which each front end names its way (the command line: its
        flags).
    kind : {"float", "int", "str", "map"}
        ``map``: ``NAME=VALUE,...`` on the command line, a dict in Python.
    nargs : int or str, optional
        How many values (argparse's: 2, "+"); None for one.
    metavar : str or tuple, optional
    choices : tuple, optional
    runs : bool
        A run directory takes it too (cells in the run's annulus); the others are for
        anyone's files only.
    cli_name : str, optional
        The command line's name where it is not the Python name (``atom-columns``: its
        flag ``--atom-columns``).
    unit : str, optional
        Its unit, where it has one (``"the data's time unit"``).
    """

    name: str
    help: str
    kind: str = "float"
    nargs: int | str | None = None
    metavar: str | tuple | None = None
    choices: tuple | None = None
    runs: bool = False
    cli_name: str | None = None
    unit: str | None = None

    @property
    def cli_flag(self) -> str:
        """The command line's flag."""
        return "--" + (self.cli_name or self.name.replace("_", "-"))

    def parse(self, value):
        """A value as the command line gives it, in Python's form (a ``map``'s text as a
        dict; one-line refusal for a malformed one)."""
        if self.kind != "map" or not isinstance(value, str):
            return value
        from granavg.errors import UserError

        out = {}
        for part in filter(None, (p.strip() for p in value.split(","))):
            key, sep, val = part.partition("=")
            if not sep or not key.strip() or not val.strip():
                raise UserError(f"column map {part!r}: expected NAME=COLUMN, e.g. "
                                "id1=c_pp[1]")
            out[key.strip()] = val.strip()
        return out


class Registry:
    """The objects of one kind, by name.

    Parameters
    ----------
    package : str
        The package whose modules are searched (``granavg.engine.cells``).
    attribute : str
        The module attribute that holds a module's object (``CELLS``).
    accepts : callable
        ``accepts(obj) -> bool``: whether an attribute found is one of this kind.
    name_of : callable
        ``name_of(obj) -> str``: the key it is registered under.
    check : callable, optional
        ``check(obj)``: its contract; raises ``ValueError`` with the reason to refuse.
    group : str, optional
        The entry-point group whose objects join the package's (``granavg.formats``).
    """

    def __init__(self, package: str, attribute: str, accepts: Callable,
                 name_of: Callable, check: Callable | None = None, group: str | None = None):
        self.package, self.attribute, self.group = package, attribute, group
        self.accepts, self.name_of, self.check = accepts, name_of, check
        self._found: dict = {}
        self._added: dict = {}

    def all(self) -> dict:
        """Every object, by name: the package's modules' (found once), then those
        registered at run time."""
        if not self._found:
            package = importlib.import_module(self.package)
            found = {}
            for info in pkgutil.iter_modules(package.__path__):
                module = importlib.import_module(f"{self.package}.{info.name}")
                obj = getattr(module, self.attribute, None)
                if obj is not None and self.accepts(obj):
                    self._checked(obj)
                    found[self.name_of(obj)] = obj
            for point in self._entry_points():
                obj = point.load()
                if not self.accepts(obj):
                    raise TypeError(f"entry point {point.name} = {point.value} (group "
                                    f"{self.group}) is not a {self.attribute}")
                self._checked(obj)
                found.setdefault(self.name_of(obj), obj)
            self._found = found
        return {**self._found, **self._added}

    def _entry_points(self) -> list:
        if self.group is None:
            return []
        from importlib.metadata import entry_points
        return list(entry_points(group=self.group))

    def register(self, obj):
        """Add an object of this kind (checked against its contract); returns it."""
        if not self.accepts(obj):
            raise TypeError(f"{obj!r} is not a {self.attribute} of {self.package}")
        name = self.name_of(obj)
        if name in self.all() and self.all()[name] is not obj:
            raise ValueError(f"{self.package} already has {name!r}")
        self._checked(obj)
        self._added[name] = obj
        return obj

    def unregister(self, name: str) -> None:
        """Remove an object registered at run time."""
        self._added.pop(name, None)

    def _checked(self, obj) -> None:
        if self.check is not None:
            try:
                self.check(obj)
            except ValueError as exc:
                raise ValueError(f"{self.name_of(obj)!r} ({self.package}) breaks its "
                                 f"contract: {exc}") from None
