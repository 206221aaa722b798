"""Read a run's two dumps with granavg's reader, every column, and nothing else: the
baseline that ``granavg average`` is measured against (benchmarks/whole_average.sh).

    python benchmarks/read_dumps.py RUN_DIR
"""

import sys
from pathlib import Path

from granavg.io.reader import DumpReader

run = Path(sys.argv[1])
for name in ("atoms", "contacts"):
    path = next(run.glob(f"{name}.dump*"))
    rows = sum(len(frame.data) for frame in DumpReader(path))
    print(f"{path.name}: {rows} rows")
