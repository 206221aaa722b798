"""Reading speed of the input formats, as whole processes in the same run
(benchmarks/paired.py): LAMMPS' binary atom dump against its text (the same frames,
17 digits), and LIGGGHTS' text dumps (atoms + pair/gran/local contacts, converted)
against LAMMPS' (atoms + pair/local contacts, converted), per row read.

    python benchmarks/formats_read.py DIR [--every N] [-n 5]

Makes its data in DIR: the 3D pile deck of the tests (tests/decks/pile_3d_si.lmp,
900 spheres: 17 digits with the binary dump, and LAMMPS' default %g) and, where Debian's liggghts is installed, tests/decks/
pile_liggghts.lig (1600 spheres), each with a frame every N steps (default 10: 501 and
201 frames), so that reading dominates the process.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DECKS = ROOT / "tests" / "decks"

READ_ONE = ("from granavg.io.reader import DumpReader; import sys; "
            "print(sum(len(f.data) for f in DumpReader(sys.argv[1])))")
FRAMES = ("from granavg.io.formats import open_frames; import sys, json; "
          "o = json.loads(sys.argv[3]); "
          "print(sum(len(f.atoms[\"x\"]) + len(f.contacts[\"id1\"]) "
          "for f in open_frames(sys.argv[1], sys.argv[2], **o)))")


def make(d: Path, every: int) -> dict:
    from granavg.sim.lammps_session import lammps_session

    out = {}
    for kind, precise in (("lammps", "yes"), ("lammps_g", "no")):
        lam = d / kind
        lam.mkdir(parents=True, exist_ok=True)
        with lammps_session(["-log", str(lam / "log.lammps"), "-var", "out", str(lam),
                             "-var", "precise", precise, "-var", "binary", precise,
                             "-var", "every", str(every)]) as lmp:
            lmp.file(str(DECKS / "pile_3d_si.lmp"))
        out.update({f"{kind}_{n}": lam / n for n in ("atoms.dump", "atoms.bin",
                                                      "contacts.dump")})
    if shutil.which("liggghts"):
        lig = d / "liggghts"
        lig.mkdir(exist_ok=True)
        subprocess.run(["liggghts", "-in", str(DECKS / "pile_liggghts.lig"), "-log", "none",
                        "-echo", "none", "-var", "out", str(lig), "-var", "stl",
                        str(DECKS / "floor_liggghts.stl"), "-var", "every", str(every)],
                       check=True, stdout=subprocess.DEVNULL)
        out.update({f"liggghts_{n}": lig / n for n in ("atoms.dump", "contacts.dump")})
    return out


def rows(cmd: list) -> int:
    return int(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)


def paired(a: str, b: str, n: int) -> str:
    return subprocess.run([sys.executable, str(ROOT / "benchmarks" / "paired.py"), "-n",
                           str(n), a, b], capture_output=True, text=True,
                          check=True).stdout


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("-n", type=int, default=5)
    args = ap.parse_args(argv)
    f = make(args.dir, args.every)
    py = sys.executable
    text, binary = f["lammps_atoms.dump"], f["lammps_atoms.bin"]
    print(f"## LAMMPS text ({text.stat().st_size / 1e6:.0f} MB) against binary "
          f"({binary.stat().st_size / 1e6:.0f} MB), the same frames: A/B = text/binary")
    print(paired(f"{py} -c '{READ_ONE}' {text}", f"{py} -c '{READ_ONE}' {binary}", args.n))
    print("## the start-up alone (Python, granavg's reader imported) against binary")
    print(paired(f"{py} -c 'import granavg.io.reader'", f"{py} -c '{READ_ONE}' {binary}",
                 args.n))
    if "liggghts_atoms.dump" not in f:
        print("## LIGGGHTS: not measured (liggghts not installed: apt-get install -y "
              "liggghts)")
        return
    lam = [f["lammps_g_atoms.dump"], f["lammps_g_contacts.dump"],
           '{"contact_map": {"id1": "c_pp[1]", "id2": "c_pp[2]", "dist": "c_pl[1]", '
           '"dx": "c_pl[2]", "dy": "c_pl[3]", "dz": "c_pl[4]", "force": "c_pl[5]", '
           '"ftx": "c_pl[6]", "fty": "c_pl[7]", "ftz": "c_pl[8]"}, "dt": 1e-5}']
    lig = [f["liggghts_atoms.dump"], f["liggghts_contacts.dump"],
           '{"liggghts": "pos id force delta", "dt": 1e-5}']
    n_lam, n_lig = (rows([py, "-c", FRAMES, *map(str, c)]) for c in (lam, lig))
    print(f"## LIGGGHTS text ({n_lig} atom + contact rows) against LAMMPS text ({n_lam}), "
          "both %g, "
          "read and converted to frames: A/B = LIGGGHTS/LAMMPS time; per row: x "
          f"{n_lam / n_lig:.4f}")
    quoted = lambda c: f"{py} -c '{FRAMES}' {c[0]} {c[1]} '{c[2]}'"
    print(paired(quoted(lig), quoted(lam), args.n))


if __name__ == "__main__":
    main()
