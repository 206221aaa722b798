"""A long run for benchmarks: a run directory whose dumps repeat a real run's frames.

    python benchmarks/long_run.py RUN OUT [REPEAT]     # default 20: ~1000 frames

The frames of RUN's atoms and contacts dumps are written REPEAT times, their time steps
shifted so they keep increasing (the physics at the joins is not continuous: this is a
load for timing, not data). The manifest is RUN's with the time span lengthened.
"""

import gzip
import json
import sys
from pathlib import Path


def repeat_dump(src, dst, times, period):
    text = gzip.decompress(src.read_bytes()).decode()
    frames = text.split("ITEM: TIMESTEP\n")[1:]
    with gzip.open(dst, "wt", compresslevel=6) as out:
        for k in range(times):
            for f in frames:
                step, rest = f.split("\n", 1)
                out.write(f"ITEM: TIMESTEP\n{int(step) + k * period}\n{rest}")


def main(run, out, times=20):
    run, out = Path(run), Path(out)
    out.mkdir(parents=True)
    m = json.loads((run / "manifest.json").read_text())
    d = m["derived"]
    period = (d["n_shear_steps"] // d["dump_every_steps"] + 1) * d["dump_every_steps"]
    for name in ("atoms", "contacts"):
        repeat_dump(run / f"{name}.dump.gz", out / f"{name}.dump.gz", times, period)
    d["n_shear_steps"] = period * times - d["dump_every_steps"]
    d["t_end_s"] = d["n_shear_steps"] * d["dt_s"]
    m["scene"]["t_end"] = d["t_end_s"]
    (out / "manifest.json").write_text(json.dumps(m, indent=1))
    print(out, "frames x", times)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:4]))
