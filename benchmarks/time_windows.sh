#!/bin/sh
# Fields in time against the single average of the same frames (issue: fields in time):
# 60 windows of 10 frames, and 60 times smoothed by a Gaussian, each against the whole
# average of the same 600 frames, in one pass; binned cells and a Lucy kernel in space.
#   sh benchmarks/time_windows.sh DIR     (from the repo root; .venv from make test)
# DIR: where the data go: the 2D column collapse (lammps_inputs/collapse_2d.lmp), 595
# disks with their walls, dumped every 5 steps over its first 31 ms (about 600 frames,
# 80 MB; made once, ~10 s). Every figure is a median of benchmarks/paired.py, each ratio
# paired in the same call.
set -e
DIR=${1:?usage: time_windows.sh DIR}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
mkdir -p "$DIR"
[ -f "$DIR/run/contacts.dump" ] || "$BIN/python" -c "
import sys; from pathlib import Path; sys.path.insert(0, '$ROOT/workflows'); import collapse
collapse.run_deck(Path('$DIR/run'), 50, dense=(0.0, 0.0313), duration=0.0313, step=5)"
R=$DIR/run
MAP=id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],force=c_pl[4],ftx=c_pl[5],fty=c_pl[6]
avg() { echo "rm -rf $DIR/$1.*; exec $BIN/granavg average --atoms $R/atoms.dump --contacts $R/contacts.dump --contact-columns $MAP --wall-types 2 --gravity 0 -9.81 --thickness 0.002 --grid 24 10 --x-range 0 0.12 --y-range 0 0.05 --no-progress --out $DIR/$1.csv $2"; }
bench() { "$BIN/python" "$ROOT/benchmarks/paired.py" -n "${N:-5}" "$1" "$2" | grep -E "A wall|B wall|A/B wall"; }
echo "### 60 windows of 10 frames / the whole average (binned)"
bench "$(avg w "--window-frames 10")" "$(avg a)"
echo "### 60 times, Gaussian w_t = 0.25 ms (binned) / the whole average"
bench "$(avg g "--time-kernel gauss --time-width 0.00025 --times 0.0008 0.0305 0.0005")" "$(avg a)"
echo "### Lucy kernel in space, w = 6 mm: 60 windows / the whole average"
bench "$(avg lw "--kernel lucy --width 0.006 --window-frames 10")" "$(avg la "--kernel lucy --width 0.006")"
echo "### Lucy kernel in space: 60 times with the balance laws / the whole average"
bench "$(avg lg "--kernel lucy --width 0.006 --time-kernel gauss --time-width 0.00025 --times 0.0008 0.0305 0.0005")" "$(avg la "--kernel lucy --width 0.006")"
