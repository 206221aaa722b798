#!/bin/sh
# What each output costs on the paper scene: 20 s of shear (41 frames) from one prepared
# packing, with contact dumps, without contact output, and averaged in situ without dumps;
# then averaging all quantities against density and velocity only.
#   sh workflows/what_it_costs.sh OUTDIR PREPARED.data      (venv active or .venv present)
# Prints wall and CPU seconds (/usr/bin/time), the dump sizes and each run's own split of
# its time between LAMMPS steps and the frames taken from LAMMPS (manifest "timing").
set -e
OUT=${1:?usage: what_it_costs.sh OUTDIR PREPARED.data}; START=${2:?prepared packing}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
mkdir -p "$OUT"; cd "$OUT"
SET="--preset paper-hooke --start $START --no-progress --set t_end=20 --set t_dump_start=0 --set dump_dt=0.5"
t() { name=$1; shift; /usr/bin/time -f "$name: wall %e s, cpu %U+%S s" "$@" 2>&1 | grep -F "$name:"; }
t "simulate, dumps with contacts" "$BIN/granavg" simulate --out full $SET
t "simulate, dumps without contacts" "$BIN/granavg" simulate --out slim $SET --set contacts=0
t "simulate, in situ 20+60 rings, no dumps" "$BIN/granavg" simulate --out situ $SET --average 20 60 --t-min 0 --set dumps=0
t "average all quantities, 20 rings" "$BIN/granavg" average full --t-min 0 --out full/all.csv --no-progress
t "average nu and v, 20 rings" "$BIN/granavg" average full --t-min 0 --quantities nu,v --out full/nuv.csv --no-progress
du -sh full slim situ
ls -l full/*.gz
for r in full slim situ; do   # the runs' own split of their wall time (manifest "timing")
  "$BIN/python" -c "import json,sys; t=json.load(open('$r/manifest.json'))['timing']; print('$r: LAMMPS steps %.1f s, %d frames taken %.2f s (%.1f ms each)' % (t['lammps_steps_s'], t['frames'], t['frames_s'], 1e3*t['frames_s']/max(t['frames'],1)))"
done
