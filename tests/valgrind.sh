#!/usr/bin/env bash
# Memcheck over a representative subset of ohm runs. Not part of ctest (slow):
#   tests/valgrind.sh build/ohm        # an ohm built WITHOUT sanitizers
# Each run must exit as expected and valgrind must report no errors and no
# definitely-lost blocks. --error-exitcode=1 collides with ohm's own exit 1
# for bad input, so the log's ERROR SUMMARY is checked as well.
set -eu
source "$(dirname "$0")/lib.sh" "$1"
SUPP=$(dirname "$0")/valgrind.supp
if ldd "$OHM" | grep -q 'libasan\|libubsan'; then echo "$OHM is built with sanitizers; use a plain build" >&2; exit 1; fi

vg() { # NAME WANT_EXIT -- ohm args...
  local name=$1 want=$2; shift 3
  local log="$T/vg.$passed.$failed.log" got
  set +e
  timeout 1200 valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite \
    --suppressions="$SUPP" --log-file="$log" "$OHM" --quiet "$@" >"$T/out" 2>"$T/err"
  got=$?; set -e
  local summary; summary=$(grep 'ERROR SUMMARY' "$log" | tail -1)
  echo "$name: exit $got; $summary; $(grep -h 'definitely lost:' "$log" | tail -1 | sed 's/^==[0-9]*== *//')"
  if ! grep -q 'ERROR SUMMARY: 0 errors' "$log"; then
    bad "$name: valgrind reported errors (log follows)"; sed -n '1,200p' "$log" >&2; return
  fi
  if [ "$got" != "$want" ]; then bad "$name: exit $got, expected $want: $(tail -3 "$T/err")"; return; fi
  ok
}

vg "mesh read+voxelize+solve, dim 12" 0 -- -read file=samples/cow.obj -voxelize dim=12 -material preset=marble \
  -light type=directional dir=0,-1,-1 -solve -write file="$T/cow.vdb" -stats file="$T/cow.json"
vg "cg + depth band + auto, dim 16" 0 -- -read file=samples/spot.obj size=200 -voxelize dim=16 -material preset=skin1 \
  -light type=directional dir=0,-1,0 orbit=3 axis=x -solve solver=auto depth_band_error=0.01 -stats file="$T/cg.json"
vg "ohm accuracy, tiny" 0 -- accuracy dims=8,12 ref=16 materials=skin1 bands=1 slab=1 csv="$T/acc.csv"
vg "bad .vdb (4 GB string)" 1 -- -read file=tests/data/corpus/fuzz-string-4gb.vdb
vg "pipeline error (unknown action)" 2 -- run tests/data/corpus/unknown-action.ohm
vg "pipeline that fails while running (missing mesh)" 1 -- run tests/data/corpus/missing-file.ohm
vg "bad PLY (negative index, binary)" 1 -- -read file=tests/data/corpus/index-neg-bin.ply -voxelize dim=8
vg "bad PLY (10^12 faces)" 1 -- -read file=tests/data/corpus/huge-faces.ply -voxelize dim=8
vg "NIfTI read + voxelize" 0 -- -read file=samples/ch2_2mm.nii.gz -voxelize dim=12 threshold=1
vg "bad NIfTI (65535^3)" 1 -- -read file=tests/data/corpus/huge-dims-2.nii -voxelize dim=8 threshold=1

finish
