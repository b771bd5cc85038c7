#!/usr/bin/env bash
# An iterative solve that stops short of cg_tol says so (docs/solvers.md,
# "Stopping short"): a warning line and cg_stalled in the statistics, the
# result kept; a solve that reaches cg_tol says nothing.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# nearly singular (sigma_a = 1e-6, no leak): kappa is large, so a column can
# pass the backward-error test with ||b - A x|| / ||b|| far above cg_tol
singular=(-read file=samples/spot.obj size=10 -voxelize dim=16 -material sigma_a=1e-6 sigma_s=1
          -light type=directional dir=0,-1,0 intensity=1)
normal=(-read file=samples/spot.obj size=50 -voxelize dim=24 -material preset=marble
        -light type=directional dir=0,-1,0 intensity=1)

# expect_stalled NAME SOLVER ITERS: the last run warned once that SOLVER
# stopped short of cg_tol=1e-10 (after ITERS iterations, when given), and its
# statistics ($T/NAME.json) say so beside a relative residual above cg_tol
expect_stalled() {
  local name=$1 solver=$2 iters=${3:-[0-9]+} n
  n=$(grep -c '^ohm: warning: solve: .* stopped short of cg_tol' <<<"$LAST_ERR" || true)
  check "$name: one stopped-short warning (got $n): $LAST_ERR" test "$n" = 1
  check "$name: the warning names the solver, residual, tolerance, iterations and what to do" grep -E -q -- \
    "^ohm: warning: solve: $solver stopped short of cg_tol=1e-10 in [1-9][0-9]* column\(s\): relative residual [0-9.e+-]+ after $iters iterations in all; the result is kept .*use solver=direct, or .* a looser cg_tol=" \
    <<<"$LAST_ERR"
  check "$name: stats" $PY -c "
import json; s = json.load(open('$T/$name.json'))
assert s['solver'] == '$solver' and s['cg_stalled'] >= 1 and s['cg_relres'] > 1e-10, s
assert s['conservation_error'] < 1e-6, s"
}
# expect_clean NAME SOLVER: no such warning; cg_stalled 0, cg_relres within cg_tol
expect_clean() {
  local name=$1 solver=$2
  check "$name: no stopped-short warning: $LAST_ERR" test "$(grep -c 'stopped short' <<<"$LAST_ERR" || true)" = 0
  check "$name: stats" $PY -c "
import json; s = json.load(open('$T/$name.json'))
assert s['solver'] == '$solver' and s['cg_stalled'] == 0 and 0 < s['cg_relres'] <= 1e-10, s"
}

# at the residual floor (no cap): cg and mg stagnate above cg_tol
for sv in cg mg; do
  expect_exit 0 "$sv, floor" -- "$OHM" "${singular[@]}" -solve solver=$sv boundary=neumann cg_tol=1e-10 \
    -stats file="$T/floor_$sv.json"
  expect_stalled "floor_$sv" $sv
done

# a solve that reaches cg_tol says nothing
for sv in cg mg; do
  expect_exit 0 "$sv, normal" -- "$OHM" "${normal[@]}" -solve solver=$sv cg_tol=1e-10 -stats file="$T/normal_$sv.json"
  expect_clean "normal_$sv" $sv
done

if require_test_hooks "iterative solvers at their iteration cap (OHM_TEST_MAX_ITER)"; then
# at the iteration cap (a test hook sets it) with a small backward error:
# kept, and said, with the iterations the cap allowed
cap() { # cap NAME SOLVER ITERS EXTRA...
  local name=$1 solver=$2 iters=$3; shift 3
  OHM_TEST_MAX_ITER=$iters expect_exit 0 "$name" -- "$OHM" "${singular[@]}" -solve solver=$solver boundary=neumann \
    cg_tol=1e-10 "$@" -stats file="$T/$name.json"
  expect_stalled "$name" $solver $iters
}
cap cap_cg cg 50
cap cap_mg mg 10
# mg's cycle on an OpenCL device, and PETSc's BoomerAMG, where this build has them
if "$OHM" devices >/dev/null 2>&1; then cap cap_mg_device mg 10 device=cpu; fi
if "$OHM" "${normal[@]}" -solve solver=amg >/dev/null 2>&1; then cap cap_amg amg 10; fi
fi
finish
