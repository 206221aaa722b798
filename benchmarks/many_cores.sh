#!/bin/sh
# Issue 56's measurements on one many-core machine, in one go: 48 frames of a million
# spheres (6.4 GB of %g text, made from the shipped frame on every core: no LAMMPS
# needed) as a dump.* series, as one plain file and as a gzip series; one process on 4
# and every core, local clusters of 2, 8 and every worker (the cluster itself timed:
# GRANAVG_COST_MODEL=off), against cat and against zcat of one file x 48 / cores in the
# same rounds, the profiles' hashes compared, where one process' time goes (--stages),
# and the series again with numpy's huge-page advice on (the command turns it off:
# docs/running-big.md, "Huge pages").
#   sh benchmarks/many_cores.sh DIR        (from the repo root; PYTHON: the interpreter)
# Needs about 16 GB free in DIR. On 2 cores the whole script takes 6 min 53 s (the data
# about 1 min of it, 2 min 21 s before it was made on every core); on many cores its
# time is unmeasured.
set -e
DIR=${1:?usage: many_cores.sh DIR}
PY=${PYTHON:-python3}
N=$(nproc)
echo "machine: $N cores,$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
"$PY" benchmarks/big_3d.py make "$DIR"
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout series --counts 4 "$N" \
  --workers 2 8 "$N" -n 2 --stages
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout single --counts "$N" -n 2
"$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout gzip --counts "$N" -n 2
echo "numpy's huge-page advice on (NUMPY_MADVISE_HUGEPAGE=1):"
NUMPY_MADVISE_HUGEPAGE=1 "$PY" benchmarks/big_3d.py threads "$DIR" --files 48 --layout series \
  --counts "$N" -n 2
