#!/bin/sh
# LAMMPS timing breakdown of the paper scene's shear phase on 1 and 2 cores.
# Usage: sh workflows/lammps_timing.sh [OUTDIR] [SHEAR_STEPS]   (from the repo root, venv active
# or .venv present). Prints steps/s and loop/(Pair+Neigh) for serial, MPI 2 and OpenMP 2.
set -e
OUT=${1:-/tmp/granavg-timing}; STEPS=${2:-10000}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
export LD_LIBRARY_PATH="$(dirname "$BIN")/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
COMMON="-in $ROOT/lammps_inputs/couette.lmp -screen none -var n_grow 5000 -var n_relax 5000 \
 -var n_shear $STEPS -var contacts none -var dump_every 1000000 -var restart_every 10000000 \
 -var thermo_every $STEPS"
for mode in serial mpi2 omp2; do
  d=$OUT/$mode; rm -rf "$d"; mkdir -p "$d"
  case $mode in
    serial) "$BIN/lmp" $COMMON -var out "$d" -log "$d/log.lammps" ;;
    mpi2)   "$BIN/mpirun" -np 2 "$BIN/lmp" $COMMON -var out "$d" -log "$d/log.lammps" ;;
    omp2)   OMP_NUM_THREADS=2 "$BIN/lmp" -sf omp -pk omp 2 $COMMON -var out "$d" -log "$d/log.lammps" ;;
  esac
  # the last "Loop time" block is the shear phase
  awk -v m=$mode '/^Loop time/{loop=$4; steps=$9} /^Pair /{p=$5} /^Neigh /{n=$5} /^Modify /{mo=$5} /^Output /{o=$5}
       END{printf "%-6s steps/s %7.0f  loop %6.2f s  Pair %6.2f  Neigh %5.2f  Modify %5.2f  Output %5.2f  loop/(Pair+Neigh) %.2f\n", m, steps/loop, loop, p, n, mo, o, loop/(p+n)}' "$d/log.lammps"
done
