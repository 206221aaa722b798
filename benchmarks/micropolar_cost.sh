#!/bin/sh
# What the micropolar and energy fields cost, whole commands paired in the same call
# (benchmarks/paired.py: the median ratio is the figure).
#   sh benchmarks/micropolar_cost.sh RUN [BASE]     (from the repo root; .venv from make test)
# RUN: a run directory of the paper cell or the demo (granavg simulate --preset demo
# --out RUN); BASE: a commit without these fields (default 6a5d14e), checked out into a
# temporary worktree and run with the same environment.
#  1. The quantities granavg had before (--quantities Q), this code / BASE's: the cost
#     of those quantities must not change (issue 39).
#  2. All the data allow / the same Q, this code: what the new fields cost.
set -e
RUN=${1:?usage: micropolar_cost.sh RUN [BASE]}
BASE=${2:-6a5d14e}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
T=$(mktemp -d)
git -C "$ROOT" worktree add -q --detach "$T/base" "$BASE"
trap 'git -C "$ROOT" worktree remove --force "$T/base"; rm -rf "$T"' EXIT
Q=nu,rho,v,omega,coordination,F,sigma,dsigma,dsigma_fluct,eps,boundary,body
avg() { echo "rm -f $T/$1.csv*; PYTHONPATH=$2 exec $BIN/python -m granavg average $RUN --bins 20 $3 --out $T/$1.csv --no-progress"; }
bench() { "$BIN/python" "$ROOT/benchmarks/paired.py" -n "${N:-5}" "$1" "$2" | grep -E "A wall|B wall|A/B wall"; }
echo "## $RUN, 20 rings, --quantities $Q: this code / $BASE"
bench "$(avg a "$ROOT" "--quantities $Q")" "$(avg b "$T/base" "--quantities $Q")"
echo "## $RUN, 20 rings: all the data allow / --quantities $Q, this code"
bench "$(avg c "$ROOT" "")" "$(avg d "$ROOT" "--quantities $Q")"
