"""All the files one command writes, as one set: all of them appear, or none does.

An :class:`OutputSet` hands out temporary names beside the final ones (``.NAME.tmpPID``)
and renames them all at the end (:meth:`OutputSet.commit`), the main file (suffix
``""``, the table) last and with SIGINT and SIGTERM held back
(:func:`granavg.signals.deferred`), so that no signal falls between two renames. Leaving the block without a commit - an error, a signal, a full
disk - removes every temporary file and the directories the set created. A full disk or
a file-size limit is a :class:`~granavg.errors.UserError` naming the file.

A signal that arrives during the renames is delivered after them: :func:`committed`
tells the command's error handler that the outputs were complete nonetheless.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from granavg.errors import ParameterError, literal
from granavg.signals import deferred

#: errno values of a write that failed for want of room.
NO_ROOM = {errno.ENOSPC, errno.EFBIG, getattr(errno, "EDQUOT", errno.ENOSPC)}

_committed: list[Path] = []         # main files of the sets committed by this process


def committed() -> list:
    """The main files of the output sets committed since :func:`forget` (the last one
    last)."""
    return list(_committed)


def forget() -> None:
    """Start a new command: no output set committed yet."""
    _committed.clear()


class OutputSet:
    """The files ``main + suffix`` for each of ``suffixes`` (``""`` is ``main`` itself).

    Parameters
    ----------
    main : path
        The command's main output (the profiles table).

    Use as a context manager; :meth:`temp` gives the name to write each file to,
    :meth:`commit` publishes them.
    """

    def __init__(self, main):
        self.main = Path(main)
        self.temps: dict[str, Path] = {}
        self.created: list[Path] = []
        self.writing: str | None = None
        self.done = False

    def final(self, suffix: str) -> Path:
        return self.main.with_name(self.main.name + suffix)

    def temp(self, suffix: str = "") -> Path:
        """The temporary name of ``main + suffix`` (the file being written from now)."""
        if suffix not in self.temps:
            final = self.final(suffix)
            self.temps[suffix] = final.with_name(f".{final.name}.tmp{os.getpid()}")
        self.writing = suffix
        return self.temps[suffix]

    def temp_dir(self, suffix: str) -> Path:
        """The temporary name of the directory ``main + suffix``, created (files
        written into it appear with it at :meth:`commit`)."""
        path = self.temp(suffix)
        path.mkdir(exist_ok=True)
        return path

    def __enter__(self) -> "OutputSet":
        missing = []
        parent = self.main.parent
        while not parent.exists():
            missing.append(parent)
            parent = parent.parent
        for d in reversed(missing):
            try:
                d.mkdir()
            except OSError as exc:
                self._discard()
                raise ParameterError("out", f"{literal(d)}: cannot create the directory "
                                     f"({literal(exc.strerror)}); choose another {{param}}"
                                     ) from None
            self.created.append(d)
        return self

    def commit(self) -> list:
        """Rename every file to its final name, the main one last, no signal in between;
        returns the final paths."""
        order = sorted(self.temps, key=lambda s: s == "")             # main last
        renamed = []
        with deferred():
            try:
                for suffix in order:
                    os.replace(self.temps[suffix], self.final(suffix))
                    renamed.append(self.final(suffix))
                self.done = True
                _committed.append(self.main)
            except OSError:
                for path in renamed:                    # none of the set, then
                    if path.is_dir():
                        shutil.rmtree(path, ignore_errors=True)
                    else:
                        path.unlink(missing_ok=True)
                raise
        return [self.final(s) for s in order]

    def __exit__(self, kind, exc, tb):
        if self.done:
            return False
        self._discard()
        if isinstance(exc, OSError) and exc.errno in NO_ROOM:
            name = self.final(self.writing) if self.writing is not None else self.main
            raise ParameterError("out", f"{literal(name)}: {os.strerror(exc.errno).lower()} "
                                 "while writing it (the disk is full or a file-size limit "
                                 "was reached); nothing written - free some space or choose "
                                 "another {param}") from None
        return False

    def _discard(self):
        for t in self.temps.values():
            try:
                if t.is_dir():
                    shutil.rmtree(t, ignore_errors=True)
                else:
                    t.unlink(missing_ok=True)
            except OSError:
                pass
        for d in reversed(self.created):
            try:
                d.rmdir()
            except OSError:
                pass
