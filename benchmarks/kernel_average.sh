#!/bin/sh
# A smoothing kernel's average against the exact weights' on the same frames, whole
# commands paired in the same call (benchmarks/paired.py: the median ratio is the figure).
#   sh benchmarks/kernel_average.sh RUN BIG     (from the repo root; .venv from make test)
# RUN: a paper-cell run directory (granavg simulate --preset paper --out RUN);
# BIG: a directory made by `python benchmarks/big_3d.py make BIG` (about a million spheres
# of mean diameter 2 mm, 6 frames). Widths are one mean diameter: 7.64 mm for the paper
# cell's disks (2538 of 7.42 mm, 407 of 8.99 mm), 2 mm for the spheres.
set -e
RUN=${1:?usage: kernel_average.sh RUN BIG}
BIG=${2:?usage: kernel_average.sh RUN BIG}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
T=$(mktemp -d)
avg() { echo "rm -f $T/$1.csv*; exec $BIN/granavg average $2 --out $T/$1.csv --no-progress"; }
bench() { "$BIN/python" "$ROOT/benchmarks/paired.py" -n "${N:-5}" "$1" "$2" | grep -E "A wall|B wall|A/B wall"; }
Q=nu,rho,v,omega,coordination,F,sigma,dsigma,dsigma_fluct,eps,boundary,body
echo "## $RUN, 20 rings: lucy w = 7.64 mm / exact, the same quantities"
bench "$(avg a "$RUN --bins 20 --quantities $Q --kernel lucy --width 0.00764")" \
      "$(avg b "$RUN --bins 20 --quantities $Q")"
echo "## $RUN, 20 rings: lucy, all the data allow (gradients too) / exact, all"
bench "$(avg a "$RUN --bins 20 --kernel lucy --width 0.00764")" "$(avg b "$RUN --bins 20")"
echo "## $RUN, 20 rings: gauss w = 7.64 mm / exact, the same quantities"
bench "$(avg a "$RUN --bins 20 --quantities $Q --kernel gauss --width 0.00764")" \
      "$(avg b "$RUN --bins 20 --quantities $Q")"
B="--atoms $BIG/big.dump --grid 20 20 6 --z-range 0 0.03 --quantities nu,rho,v,omega,dsigma,dsigma_fluct"
N=3
echo "## $BIG/big.dump, 20 x 20 x 6 boxes: lucy w = 2 mm / exact"
bench "$(avg c "$B --kernel lucy --width 0.002")" "$(avg d "$B")"
rm -rf "$T"
