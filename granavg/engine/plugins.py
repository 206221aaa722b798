"""One registry for every axis of growth (cells, smoothing kernels, quantities, input
formats): the objects a package's modules define under one attribute name, found
without being listed anywhere, plus those registered at run time
(:meth:`Registry.register`, for a plug-in outside granavg's tree). Each registry owns
what its objects declare (name, help, contract) and checks it when one registers."""

from __future__ import annotations

import importlib
import pkgutil
from typing import Callable


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
    """

    def __init__(self, package: str, attribute: str, accepts: Callable,
                 name_of: Callable, check: Callable | None = None):
        self.package, self.attribute = package, attribute
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
            self._found = found
        return {**self._found, **self._added}

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
