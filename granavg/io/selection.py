"""What a :class:`~granavg.io.reader.DumpReader` asks of each frame, for the walkers of
the layouts other than text (:mod:`granavg.io.binary_dump`, :mod:`granavg.io.yaml_dump`):
whether a frame lies outside its window of steps and times, and which columns it wants."""

from __future__ import annotations

from granavg.errors import UserError


def skipped(reader, step: int, time) -> bool:
    """Whether the frame at ``step`` (``time``) lies outside the reader's ``steps``
    window (first, last[, every]) or before its ``from_time``."""
    window = reader.steps
    return window is not None and not (
        window[0] <= step <= window[1]
        and (len(window) < 3 or (step - window[0]) % window[2] == 0)) or (
        reader.from_time is not None and time is not None and time < reader.from_time)


def wanted(reader, path, names) -> list:
    """The columns the reader wants (all of ``names`` if it names none), each among
    ``names``: a missing one is a one-line refusal naming what needs it."""
    want = reader.columns if reader.columns is not None else names
    missing = [c for c in want if c not in names]
    if missing:
        need = reader.needed_by.get(missing[0])
        raise UserError(f"{path}: column '{missing[0]}' is missing (columns: "
                        f"{' '.join(names)})" + (f"; {need} needs it" if need else "")
                        + "; write it in the dump or do not ask for what needs it")
    return list(want)
