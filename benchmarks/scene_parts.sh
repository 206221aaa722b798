#!/bin/sh
# What each part of the `paper` scene costs: whole commands paired in the same call
# (benchmarks/paired.py: the median ratio A/B is the figure; docs/scene.md's table of
# "model only what a scene requires" quotes it, its accuracy column docs/sweep's study).
#   sh benchmarks/scene_parts.sh [T_END]     (from the repo root; .venv from make test)
# Simulation: T_END s (default 5) of the paper preset from its shipped packing (seed
# 20011), the preset against the same with one part left out or changed:
#   rolling resistance (mu_roll=0: the plain pair gran/hooke/history), the plate's law in
#   full each step (base_every=0) instead of its coefficient renewed every 10 steps, no
#   plate (mu_base=0), no contact output (contacts=0: no contact dump).
# Averaging: a 20-s run of the preset (the speed/accuracy study's window: 28 frames after
# the discarded start) averaged over 20 rings with all the data allow against
# --quantities nu,v (density and velocity only), 5 pairs.
set -e
T_END=${1:-5}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
sim() { echo "rm -rf $T/$1; exec $BIN/granavg simulate --preset paper --out $T/$1 \
--no-progress --set t_end=$T_END --set dump_dt=0.5 --set restart_dt=$T_END $2"; }
bench() { "$BIN/python" "$ROOT/benchmarks/paired.py" -n "${N:-3}" "$1" "$2" \
          | grep -E "A wall|B wall|A/B wall|A/B cpu"; }
for part in "mu_roll=0" "base_every=0" "mu_base=0" "contacts=0"; do
    echo "## simulate $T_END s: the paper preset / --set $part"
    bench "$(sim a "")" "$(sim b "--set $part")"
done
"$BIN/granavg" simulate --preset paper --out "$T/run" --no-progress --set t_end=20 \
    --set dump_dt=0.5 --set restart_dt=20 2>/dev/null
avg() { echo "rm -f $T/$1.csv*; exec $BIN/granavg average $T/run --bins 20 $2 --out \
$T/$1.csv --no-progress"; }
echo "## average a 20-s run over 20 rings: all quantities / --quantities nu,v"
N=5 bench "$(avg c "")" "$(avg d "--quantities nu,v")"
