#!/bin/sh
# Reproduce the paper end to end: an ensemble of K realisations of the `paper` preset
# (2945 disks with rolling resistance and base-plate friction, 50 s of shear each from
# the K shipped sheared packings, on a dask cluster of 2 workers), averaged together
# over 20 and 60 rings from the preset's discard time on (between-run errors), and over
# 20 rings split by type (the mixture), analysed: Figs. 1-9, the time series, the
# mixture's segregation and a report.
#   sh workflows/reproduce_paper.sh OUTDIR [K] [simulate options]      (K default 4)
# The committed result is docs/paper/ (report.html, summary.json, figures); see its README.
# A later --preset wins: `... OUT 4 --preset paper-rolling` gives docs/paper-rolling/ (250 s runs).
set -e
OUT=${1:?usage: reproduce_paper.sh OUTDIR [K] [simulate options]}; shift
K=${1:-4}; [ $# -gt 0 ] && shift
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
start=$(date +%s)
"$BIN/granavg" simulate --preset paper --out "$OUT/runs" --seeds "$K" --workers 2 "$@"
sim=$(date +%s)
for n in 20 60; do
  "$BIN/granavg" average "$OUT"/runs/seed* --bins $n --out "$OUT/profiles$n.csv"
done
# the mixture: small (type 1) and large (type 2) disks, for the report's mixture section
"$BIN/granavg" average "$OUT"/runs/seed* --bins 20 --species type --out "$OUT/profiles20-species.csv"
"$BIN/granavg" analyze "$OUT/profiles20.csv" "$OUT/profiles60.csv" "$OUT/profiles20-species.csv" \
  --out "$OUT/report"
end=$(date +%s)
echo "simulate: $((sim - start)) s; average and report: $((end - sim)) s; total: $((end - start)) s"
