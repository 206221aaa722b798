#!/bin/sh
# The whole `granavg average` against reading its dumps, zcat, and itself with fewer
# quantities.
#   sh benchmarks/whole_average.sh RUN [LONG]     (from the repo root; .venv from make test)
# RUN: a paper-cell run directory (granavg simulate --preset paper ...); LONG: a long run
# made from it (python benchmarks/long_run.py RUN LONG 20: ~1000 frames). Every figure is
# a median of benchmarks/paired.py, each ratio paired in the same call.
set -e
RUN=${1:?usage: whole_average.sh RUN [LONG]}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
T=$(mktemp -d)
avg() { echo "rm -f $T/$2.csv*; exec $BIN/granavg average $1 --bins 20 $3 --out $T/$2.csv --no-progress"; }
bench() { "$BIN/python" "$ROOT/benchmarks/paired.py" -n "${N:-5}" "$1" "$2" | grep -E "A wall|B wall|A/B wall"; }
for R in "$RUN" ${2:+"$2"}; do
  echo "## $R"
  echo "### whole average / reading both dumps (benchmarks/read_dumps.py)"
  bench "$(avg "$R" a)" "$BIN/python $ROOT/benchmarks/read_dumps.py $R"
  echo "### whole average / zcat of both dumps"
  bench "$(avg "$R" a)" "zcat $R/atoms.dump.gz $R/contacts.dump.gz > /dev/null"
  echo "### --quantities nu,v / all quantities"
  bench "$(avg "$R" b "--quantities nu,v")" "$(avg "$R" a)"
  echo "### --sectors off / default"
  bench "$(avg "$R" c "--sectors off")" "$(avg "$R" a)"
  N=3
done
echo "### start-up: granavg --version / python -c pass"
bench "$BIN/granavg --version" "$BIN/python -c pass"
rm -rf "$T"
