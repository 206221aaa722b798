"""What the gate costs: the whole ``granavg average`` of a 3D pile with every frame's
checks (:func:`granavg.engine.gate.inspect`) against the same command with them left
out, as whole processes in the same run (benchmarks/paired.py).

    python benchmarks/gate_cost.py DIR [--every N] [-n 5]

Makes its data in DIR as benchmarks/formats_read.py does (tests/decks/pile_3d_si.lmp,
900 spheres, a frame every N steps, default 10: 501 frames), then averages the text
dumps (atoms and pair/local contacts) into 8 slabs, A with the checks, B without.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from formats_read import make, paired  # noqa: E402

#: ``granavg`` with the per-frame checks replaced by nothing.
UNCHECKED = ("import sys, granavg.engine.gate as g; g.inspect = lambda frame, dim: None; "
             "from granavg.cli import main; sys.exit(main(sys.argv[1:]))")
OPTIONS = ("--contact-columns id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],"
           "dz=c_pl[4],force=c_pl[5],ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8] --dt 1e-5 "
           "--units si --slabs z --range 0 0.012 --bins 8 --no-progress")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("-n", type=int, default=5)
    args = ap.parse_args(argv)
    f = make(args.dir, args.every)
    py, out = sys.executable, args.dir / "gate.csv"
    job = (f"average --atoms {f['lammps_g_atoms.dump']} --contacts "
           f"{f['lammps_g_contacts.dump']} {OPTIONS} --out {out}")
    print("## granavg average with the gate's checks (A) / without (B)")
    print(paired(f"rm -f {out}*; {py} -m granavg {job}",
                 f"rm -f {out}*; {py} -c '{UNCHECKED}' {job}", args.n))


if __name__ == "__main__":
    main()
