"""The kinds of cells an average is made over, by their class names (``Rings``,
``Slabs``, ``Grid``, ``PolarGrid``, ``Slabs3D``, ``Boxes``, ``Shells``, and any
registered with :func:`granavg.engine.cells.register`): read from the cells' registry,
so that a new kind appears here without being named anywhere else.

>>> from granavg.cells import Rings
>>> Rings.count(20, 0.1032, 0.2524, h=0.006).n
20
"""

from granavg.engine.cells import registry


def _classes() -> dict:
    return {cls.__name__: cls for cls in registry().values()}


def __getattr__(name):
    found = _classes()
    if name not in found:
        raise AttributeError(f"granavg.cells has no {name!r} (kinds: "
                             f"{', '.join(sorted(found))})")
    return found[name]


def __dir__():
    return sorted(_classes())
