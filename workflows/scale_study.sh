#!/bin/sh
# The scale study of docs/profiles.md ("Smoothing kernels"): the same frames with Lucy at
# w = 0.25, 0.5, 1, 2, 4 mean diameters (granavg scales), on the paper cell's 20 rings and
# on a 3D pile of 1711 spheres at rest (tests/decks/pile_3d_si.lmp run by plain lmp).
#   sh workflows/scale_study.sh OUTDIR [RUN]        (venv active or .venv present)
# RUN: a paper-preset run directory (default: made here, granavg simulate --preset paper,
# about 2.5 min); the pile takes about 10 s. Writes OUTDIR/paper.csv and OUTDIR/pile.csv
# with their .json (each field's steps and plateau), .png and .pdf.
set -e
OUT=${1:?usage: scale_study.sh OUTDIR [RUN]}
ROOT=$(cd "$(dirname "$0")/.." && pwd); BIN=${VIRTUAL_ENV:-$ROOT/.venv}/bin
mkdir -p "$OUT"
RUN=${2:-$OUT/paper_run}
[ -d "$RUN" ] || "$BIN/granavg" simulate --preset paper --out "$RUN" --no-progress
"$BIN/granavg" scales "$RUN" --bins 20 --fields nu,v_phi,omega,D_rphi,sigma_rphi \
  --out "$OUT/paper.csv" --no-progress
mkdir -p "$OUT/pile"
(cd "$OUT/pile" && "$BIN/lmp" -in "$ROOT/tests/decks/pile_3d_si.lmp" -var out . \
   -var kn 20.0 -var n 2000 -var top 0.2 -log log.lammps -screen none)
MAP="id1=c_pp[1],id2=c_pp[2],dist=c_pl[1],dx=c_pl[2],dy=c_pl[3],dz=c_pl[4],force=c_pl[5]"
MAP="$MAP,ftx=c_pl[6],fty=c_pl[7],ftz=c_pl[8]"
# the cells end below the free surface (about 0.056 m): the judged nodes stay in the bulk
"$BIN/granavg" scales --atoms "$OUT/pile/atoms.dump" --contacts "$OUT/pile/contacts.dump" \
  --contact-columns "$MAP" --gravity 0 0 -9.81 --slabs z --range 0 0.04 --bins 20 \
  --fields nu,sigma_zz,sigma_xx,coordination --out "$OUT/pile.csv" --no-progress
