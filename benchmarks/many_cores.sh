#!/bin/sh
# Issue 56's measurements on one many-core machine, in one go: 48 frames of a million
# spheres (6.4 GB of %g text, made from the shipped frame: no LAMMPS needed) as a dump.*
# series, as one plain file and as a gzip series; one process on 1, 4 and every core,
# local clusters of 2, 4, 8 and every worker (the cluster itself timed:
# GRANAVG_COST_MODEL=off), against cat and zcat in the same rounds, the profiles' hashes
# compared, where one process' time goes (--stages), and the series again with numpy's
# huge-page advice on (the command turns it off: docs/running-big.md, "Huge pages").
#   sh benchmarks/many_cores.sh DIR        (from the repo root; PYTHON: the interpreter)
# Needs about 16 GB free in DIR. Not yet run on many cores: its time there is unmeasured.
set -e
DIR=${1:?usage: many_cores.sh DIR}
PY=${PYTHON:-python3}
N=$(nproc)
echo "machine: $N cores,$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
"$PY" benchmarks/big_3d.py make "$DIR"
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout series --counts 1 4 "$N" \
  --workers 2 4 8 "$N" -n 2 --stages
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout single --counts 4 "$N" -n 2
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout gzip --counts 4 "$N" \
  --workers "$N" -n 2
echo "numpy's huge-page advice on (NUMPY_MADVISE_HUGEPAGE=1):"
NUMPY_MADVISE_HUGEPAGE=1 "$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout series \
  --counts "$N" -n 2
