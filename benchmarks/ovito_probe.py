"""Which OVITO an interpreter has: OVITO is not a dependency of granavg, so the benchmarks
that race it run it in another environment (``pip install ovito`` there) and say so when
it is missing."""

import subprocess


def ovito_version(python: str) -> str | None:
    """OVITO's version in ``python``, or None (after printing why the line is skipped)."""
    probe = subprocess.run([python, "-c", "import ovito; print(ovito.version_string)"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        print(f"OVITO skipped: {python} has no ovito module (pip install ovito in a "
              "separate environment and give --ovito-python)")
        return None
    return probe.stdout.strip()
