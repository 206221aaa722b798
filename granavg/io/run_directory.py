"""A run's output directory: manifest, restart bookkeeping, and safe dump truncation.

Nothing here overwrites results silently: a directory that holds another run is refused,
the manifest is replaced atomically, and a dump is only ever cut back to the frames
before a restart point when a run is resumed.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from granavg.io.dumpfile import open_text, tolerant_lines
from granavg.errors import ParameterError, UserError, literal

MANIFEST = "manifest.json"


def claim_new(out: Path) -> Path:
    """Create ``out`` for a new run; refuse if it holds another run or other files."""
    out = Path(out)
    if (out / MANIFEST).exists():
        status = read_manifest(out).get("status", "unknown")
        raise ParameterError("out", f"{literal(out)} already holds a run (status: "
                             f"{literal(status)}); choose a new {{param}}, or add {{resume}} "
                             "to continue it")
    if out.exists() and any(out.iterdir()):
        raise ParameterError("out", f"{literal(out)} is not empty; choose a new or empty "
                             "{param} directory")
    out.mkdir(parents=True, exist_ok=True)
    return out


def read_manifest(out: Path) -> dict:
    """The run's manifest as a dict; a clear error if it is missing or damaged."""
    path = Path(out) / MANIFEST
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise UserError(f"{path} not found: {out} is not a granavg run directory") from None
    except json.JSONDecodeError as exc:
        raise UserError(f"{path} is damaged ({exc.msg} at line {exc.lineno})") from None


def write_manifest(out: Path, manifest: dict) -> None:
    """Write the manifest atomically (a crash leaves the old or the new one, never half)."""
    path = Path(out) / MANIFEST
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(manifest, indent=2, sort_keys=False) + "\n")
    os.replace(tmp, path)


def restart_files(out: Path) -> dict:
    """Restart files of a run by time step: {step: path}."""
    found = {}
    for path in (Path(out) / "restart").glob("restart.*.bin"):
        m = re.fullmatch(r"restart\.(\d+)\.bin", path.name)
        if m:
            found[int(m.group(1))] = path
    return found


def frame_steps(path: Path) -> list:
    """Time steps of the complete frames of a dump file (a damaged tail is ignored)."""
    steps = []
    for step, _ in _frames_text(path):
        steps.append(step)
    return steps


def truncate_dump(path: Path, before_step: int) -> int:
    """Keep only the frames with time step < ``before_step``; returns how many remain.

    Used on ``--resume``: the resumed run writes the frames from the restart point on.
    The file is rewritten beside itself and swapped in atomically.
    """
    path = Path(path)
    tmp = path.with_name("tmp." + path.name)
    kept = 0
    with open_text(tmp, "wt") as dst:
        for step, text in _frames_text(path):
            if step >= before_step:
                break
            dst.write(text)
            kept += 1
    os.replace(tmp, path)
    return kept


def _frames_text(path: Path):
    """Yield (timestep, text) of each complete frame: one begins at the first ``ITEM:``
    line after the rows of the previous one. A damaged tail (a writer killed
    mid-stream: cut or corrupt gzip, half a line) ends the frames without an error."""
    lines, step, expect, count, in_rows = [], None, None, 0, False
    fh = tolerant_lines(path)
    for line in fh:
        if not line.endswith("\n"):
            break                       # only the damaged tail lacks its newline
        if in_rows and line.startswith("ITEM:"):
            if step is not None and count == expect:
                yield step, "".join(lines)
            lines, step, expect, count, in_rows = [], None, None, 0, False
        lines.append(line)
        if line.startswith(("ITEM: TIMESTEP", "ITEM: NUMBER OF")):
            text = next(fh, "")
            try:
                value = int(text)
            except ValueError:
                return                  # the damage lies in this frame's header
            if not text.endswith("\n"):
                return
            if line.startswith("ITEM: TIMESTEP"):
                step = value
            else:
                expect = value
            lines.append(f"{value}\n")
        elif line.startswith(("ITEM: ATOMS", "ITEM: ENTRIES")):
            in_rows = True
        elif in_rows and line.endswith("\n"):
            count += 1
    if step is not None and count == expect:
        yield step, "".join(lines)
