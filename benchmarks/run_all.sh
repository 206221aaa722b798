#!/bin/sh
# granavg's benchmark suite: every benchmark of docs/benchmarks.md, in one go.
#   sh benchmarks/run_all.sh OUTDIR          (from the repo root; .venv from `make test`)
# Ratios are always against a baseline measured in the same run; record the machine
# (`nproc`, CPU model) with the numbers.
set -e
OUT=${1:?usage: run_all.sh OUTDIR}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
mkdir -p "$OUT"
# the bytecode of the sources as they are (as `make` leaves it), not compiled per process
"$BIN/python" -m compileall -q "$ROOT/granavg"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
echo "## LAMMPS"; sh "$ROOT/workflows/lammps_timing.sh" "$OUT/timing" 10000
echo "## reader, engine, memory"
"$BIN/granavg" simulate --preset fast --omp 2 --out "$OUT/demo" --no-progress
"$BIN/python" "$ROOT/benchmarks/averaging.py" "$OUT/demo"
"$BIN/python" "$ROOT/benchmarks/reader_vs_ovito.py" "$OUT/demo" ${OVITO_PYTHON:+--ovito-python "$OVITO_PYTHON"}
echo "## the whole average against reading (the demo run and a long run made of it)"
"$BIN/python" "$ROOT/benchmarks/long_run.py" "$OUT/demo" "$OUT/long" 20
sh "$ROOT/benchmarks/whole_average.sh" "$OUT/demo" "$OUT/long"
echo "## dask"; "$BIN/python" "$ROOT/benchmarks/parallel.py" "$OUT/demo" 1 2
echo "## against OVITO, all cores, a million spheres, the cost model"
"$BIN/python" "$ROOT/benchmarks/ovito_job.py" "$OUT/demo" ${OVITO_PYTHON:+--ovito-python "$OVITO_PYTHON"} --frames 60 600
"$BIN/python" "$ROOT/benchmarks/startup_floor.py" "$OUT/demo"
"$BIN/python" "$ROOT/benchmarks/cost_model.py"
"$BIN/python" "$ROOT/benchmarks/big_3d.py" make "$OUT/big3d"
"$BIN/python" "$ROOT/benchmarks/big_3d.py" time "$OUT/big3d" ${OVITO_PYTHON:+--ovito-python "$OVITO_PYTHON"}
"$BIN/python" "$ROOT/benchmarks/engine_threads.py" "$OUT/big3d/big.dump"
"$BIN/python" "$ROOT/benchmarks/big_3d.py" series "$OUT/big3d"
echo "## reference DEM"
"$BIN/granavg" simulate --preset paper-hooke --out "$OUT/small" --no-progress --set R_i=0.04 \
  --set R_o=0.0826 --set n_small=250 --set n_large=40 --set Omega=0.5 --set t_grow=1 \
  --set t_relax=1 --set t_end=1 --set t_dump_start=0 --set restart_dt=1
"$BIN/python" "$ROOT/benchmarks/refdem.py" "$OUT/small/prepared.data"
echo "## what each part of the paper scene costs (docs/scene.md)"
sh "$ROOT/benchmarks/scene_parts.sh"
echo "## end to end (simulate + average + analyze), the presets"
"$BIN/python" "$ROOT/benchmarks/end_to_end.py" "$OUT/e2e-fast" fast
"$BIN/python" "$ROOT/benchmarks/end_to_end.py" "$OUT/e2e-paper" paper 4 2
