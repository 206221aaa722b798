#!/bin/sh
# Reproduce the paper end to end: the `paper` preset (2945 disks, 500 s of shear),
# averaged over 20 and 60 rings from t = 2 rotations on, analysed, Figs. 2-9 and a report.
#   sh workflows/reproduce_paper.sh OUTDIR [--omp N | --np N]
# The committed result is docs/paper/ (report.html, summary.json, figures); see its README.
set -e
OUT=${1:?usage: reproduce_paper.sh OUTDIR [simulate options]}; shift
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
start=$(date +%s)
"$BIN/granavg" simulate --preset paper --out "$OUT/run" "$@"
sim=$(date +%s)
for n in 20 60; do
  "$BIN/granavg" average "$OUT/run" --bins $n --out "$OUT/profiles$n.csv"
done
"$BIN/granavg" analyze "$OUT/profiles20.csv" "$OUT/profiles60.csv" --out "$OUT/report"
end=$(date +%s)
echo "simulate: $((sim - start)) s; average and report: $((end - sim)) s; total: $((end - start)) s"
