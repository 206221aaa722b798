"""The way in: manifests, command-line values and output paths checked before any work.

Every check raises :class:`~granavg.errors.UserError` with one line naming what is wrong,
where, and what to do; nothing here reads a dump or writes a result.
"""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path

from granavg.errors import ParameterError, UserError, literal, named

log = logging.getLogger(__name__)

#: Keys the averaging needs from a run's manifest: (section, key, kind); kind "pos" is a
#: finite number > 0, "num" any finite number, "count" an integer >= 0.
MANIFEST_KEYS = [
    ("scene", "R_i", "pos"), ("scene", "R_o", "pos"), ("scene", "h", "pos"),
    ("scene", "rho_p", "pos"), ("scene", "Omega", "pos"), ("scene", "d_s", "pos"),
    ("scene", "d_l", "pos"), ("scene", "n_small", "count"), ("scene", "n_large", "count"),
    ("scene", "k_n", "pos"),
    ("derived", "dt_s", "pos"), ("derived", "t_end_s", "pos"),
    ("derived", "dump_interval_s", "pos"),
]


def check_manifest(m, path) -> dict:
    """The manifest ``m`` read from ``path``, refused with one line if a key the
    averaging needs is missing or of the wrong kind; a warning if the run did not end
    complete."""
    if not isinstance(m, dict):
        raise UserError(f"{path}: a manifest is a JSON object, this is a "
                        f"{type(m).__name__}; use the manifest.json granavg simulate wrote")
    for section, key, kind in MANIFEST_KEYS:
        block = m.get(section)
        if not isinstance(block, dict) or key not in block:
            raise UserError(f"{path}: key {section}.{key} is missing; use the manifest.json "
                            "granavg simulate wrote, or give the scene on the command line")
        value = block[key]
        if not _is_kind(value, kind):
            want = {"pos": "a number > 0", "num": "a number", "count": "an integer >= 0"}[kind]
            raise UserError(f"{path}: {section}.{key} = {value!r} is not {want} (SI units); "
                            "fix the manifest")
    if not m["scene"]["R_i"] < m["scene"]["R_o"]:
        raise UserError(f"{path}: scene.R_i = {m['scene']['R_i']} is not below scene.R_o = "
                        f"{m['scene']['R_o']}; fix the manifest")
    status = m.get("status")
    if status not in (None, "complete"):
        log.warning(named("%s: the run's status is %r, not complete: its dumps may end "
                          "early (resume it: granavg simulate {resume})"), path, status)
    return m


def _is_kind(value, kind) -> bool:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if kind == "count":
        return float(value).is_integer() and value >= 0
    if not math.isfinite(value):
        return False
    return value > 0 if kind == "pos" else True


def positive(name, value):
    """A finite number > 0, or a one-line refusal naming the parameter ``name``."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ParameterError(name, f"{{param}} {float(value):g}: must be a finite number > 0")
    return value


def finite(name, value):
    """A finite number, or a one-line refusal naming the parameter ``name``."""
    if value is not None and not math.isfinite(value):
        raise ParameterError(name, f"{{param}} {float(value):g}: must be a finite number")
    return value


def free_output(path: Path, suffixes=("",)) -> Path:
    """Refuse an output that exists (with any of ``suffixes`` appended), lies under a
    file, or sits in a directory that cannot be written - before any work."""
    path = Path(path)
    for suffix in suffixes:
        target = path.with_name(path.name + suffix)
        if target.exists() or target.is_symlink():
            raise ParameterError("out", f"{target} exists; choose another {{param}} (results "
                                 "are never overwritten)")
    parent = path.parent
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise ParameterError("out", f"{{param}} {path}: {probe} is a file, not a directory; "
                             "choose another {param}")
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise ParameterError("out", f"{{param}} {path}: cannot write in {probe} "
                             f"({exc.strerror}); choose another {{param}}") from None
    return path


def existing_file(name, path):
    """A path that is an existing regular file (not a directory), or a pattern with a
    ``*`` that matches some (a file series, :func:`granavg.io.reader.series`); refusals
    name the parameter ``name``."""
    if path is None:
        return None
    p = Path(path)
    if "*" in p.name or "%" in p.name:
        from granavg.io.reader import series
        try:
            series(p)
        except UserError as exc:
            raise ParameterError(name, f"{{param}} {literal(str(exc))}") from None
        return p
    if not p.exists():
        raise ParameterError(name, f"{{param}} {literal(str(p))}: no such file")
    if not p.is_file():
        raise ParameterError(name, f"{{param}} {literal(str(p))}: is a directory, not a dump "
                             "file")
    return p


def run_directory(path) -> Path:
    """A path that is a directory (a run of granavg simulate)."""
    p = Path(path)
    if not p.exists():
        raise UserError(f"{p}: no such run directory")
    if not p.is_dir():
        raise ParameterError("run_dirs", f"{literal(str(p))}: is a file, not a run directory "
                             "(which holds manifest.json); for a dump give {atoms} "
                             f"{literal(str(p))} (and {{contacts}} for its contacts)")
    return p
