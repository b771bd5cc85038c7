#!/usr/bin/env bash
# solver=amg (PETSc CG + hypre BoomerAMG) in one process and under mpirun,
# against the direct solver, on a heterogeneous scan-based scene (the walnut
# CT through its transfer function): every cell's fluence agrees to 1e-6
# relative and power is conserved to the solver's tolerance; a rank that
# fails or is killed ends the run with an error and leaves earlier outputs
# as they were (docs/solvers.md, "Large grids").  MPI as root, oversubscribed, 2 ranks.
#   bash tests/mpi_amg.sh build/ohm        (or: ctest -R mpi_amg)
set -eu
source "$(dirname "$0")/lib.sh" "$1"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
MPI=(mpirun --oversubscribe -np 2)
# a safety limit only (a hang must end the test), scaled under the sanitizers
LIMIT=$(SAFETY 300)
# Open MPI's plugins are dlclosed at MPI_Finalize, so LeakSanitizer sees
# their process-lifetime allocations as leaks with one anonymous frame that no
# suppression can name: runs that start MPI check memory errors and undefined
# behaviour under the sanitizers, not leaks.
if [ "$SANITIZED" = 1 ]; then export ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=0"; fi

WALNUT=(-read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 spacing=0.625
        -voxelize dim=40 threshold=5000 -material transfer=samples/walnut.transfer)
TOP=(-light type=directional dir=0,-1,0 intensity=1)
ORBIT=(-light type=directional dir=0,-1,-1 intensity=1 orbit=12 axis=y)

# agree.py A.vdb B.vdb A.json B.json TOL: the same cells, every fluence and
# exitance value within TOL relative (of the larger of the two, or of the
# grid's largest value for cells darker than 1e-9 of it); B conserves power
cat >"$T/agree.py" <<'PY'
import json, sys
import pyopenvdb as vdb
fa, fb, ja, jb, tol = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5])
ga = {g.name: g for g in vdb.readAll(fa)[0]}
gb = {g.name: g for g in vdb.readAll(fb)[0]}
names = sorted(n for n in ga if n.startswith(("fluence", "exitance")))
assert names and names == sorted(n for n in gb if n.startswith(("fluence", "exitance"))), (names, sorted(gb))
worst = 0.0
for n in names:
    a = {tuple(it.min): it.value for it in ga[n].citerOnValues()}
    b = {tuple(it.min): it.value for it in gb[n].citerOnValues()}
    assert a.keys() == b.keys(), "%s: %d vs %d active cells" % (n, len(a), len(b))
    top = max(abs(v) for v in a.values())
    for ijk, va in a.items():
        d = abs(va - b[ijk]) / max(abs(va), abs(b[ijk]), 1e-9 * top)
        worst = max(worst, d)
sa, sb = json.load(open(ja)), json.load(open(jb))
cons = sb["conservation_error"]
print("worst relative difference %.3g over %d grids; conservation %.2g; %s on %d rank(s), %d iterations"
      % (worst, len(names), cons, sb["solver"], sb["ranks"], sb["cg_iterations"]))
assert worst <= tol, "worst relative difference %.3g > %g" % (worst, tol)
assert cons < 1e-9, "conservation error %.3g" % cons
assert abs(sa["power_out"] - sb["power_out"]) <= 1e-9 * sa["power_out"], (sa["power_out"], sb["power_out"])
PY
agree() {  # NAME A B TOL [EXPECT-PYTHON on stats s of B]
  local name=$1 a=$2 b=$3 tol=$4 expect=${5:-True}
  if $PY "$T/agree.py" "$T/$a.vdb" "$T/$b.vdb" "$T/$a.json" "$T/$b.json" "$tol" >"$T/agree.out" 2>&1 &&
     $PY -c "import json, sys; s = json.load(open(sys.argv[1])); assert $expect, s" "$T/$b.json"; then
    ok; echo "$name: $(cat "$T/agree.out")"
  else bad "$name: $(tail -3 "$T/agree.out")"; fi
}
solve() {  # NAME LAUNCH... -- SOLVE-OPTIONS... : the walnut, written to $T/NAME.{vdb,json}
  local name=$1; shift
  local launch=()
  while [ "$1" != "--" ]; do launch+=("$1"); shift; done; shift
  expect_exit 0 "$name" -- "${launch[@]}" "$OHM" "${WALNUT[@]}" "${LIGHTS[@]}" -solve "$@" \
    -write file="$T/$name.vdb" -stats file="$T/$name.json"
}

LIGHTS=("${TOP[@]}")
solve direct -- solver=direct
solve amg1 -- solver=amg cg_tol=1e-14
solve amg2 timeout $LIMIT "${MPI[@]}" -- solver=amg cg_tol=1e-14
solve direct2 timeout $LIMIT "${MPI[@]}" -- solver=direct
agree "amg, one process = direct" direct amg1 1e-6 "s['solver'] == 'amg' and s['ranks'] == 1 and s['factors'] == 0"
agree "amg, mpirun -np 2 = direct" direct amg2 1e-6 "s['solver'] == 'amg' and s['ranks'] == 2"
agree "direct, mpirun -np 2 = direct" direct direct2 1e-12 "s['solver'] == 'direct'"

# several frames: one setup per material, warm starts, batches of columns
LIGHTS=("${ORBIT[@]}")
solve orbit_direct -- solver=direct
solve orbit_amg2 timeout $LIMIT "${MPI[@]}" -- solver=amg cg_tol=1e-14 batch_mb=1
for f in 0001 0009 0012; do  # first frame, first of the second batch, last
  cp "$T/orbit_direct.json" "$T/orbit_direct_$f.json"; cp "$T/orbit_amg2.json" "$T/orbit_amg2_$f.json"
  agree "amg orbit frame $f, mpirun -np 2 = direct" "orbit_direct_$f" "orbit_amg2_$f" 1e-6 \
    "s['frames'] == 12 and s['solves'] == 12 * s['channels'] and s['ranks'] == 2"
done

# petsc_options: other PETSc solvers, and a misspelt option
LIGHTS=("${TOP[@]}")
solve gamg2 timeout $LIMIT "${MPI[@]}" -- solver=amg cg_tol=1e-14 petsc_options="-pc_type gamg"
agree "petsc_options=-pc_type gamg, 2 ranks = direct" direct gamg2 1e-6
solve mumps2 timeout $LIMIT "${MPI[@]}" -- solver=amg \
  petsc_options="-ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps"
agree "MUMPS Cholesky through petsc_options, 2 ranks = direct" direct mumps2 1e-9
expect_exit 2 "misspelt petsc option" -- "$OHM" "${WALNUT[@]}" "${TOP[@]}" -solve solver=amg \
  petsc_options="-pc_hypre_boomeramg_strong_treshold 0.4"
expect_error_line "misspelt petsc option" "petsc_options: '-pc_hypre_boomeramg_strong_treshold' was not used by PETSc"

# a PETSc error on every rank of two: one line naming a rank, no hang
set +e
timeout $LIMIT "${MPI[@]}" "$OHM" "${WALNUT[@]}" "${TOP[@]}" -solve solver=amg petsc_options="-pc_type no_such_pc" \
  >"$T/out" 2>"$T/err"
got=$?
set -e
if [ "$got" != 0 ] && [ "$got" != 124 ] && grep -Eq '^ohm: error: solve: amg: rank [01]: .*no_such_pc' "$T/err"; then ok
else bad "PETSc error under mpirun: exit $got, stderr: $(tail -3 "$T/err")"; fi

# killing one rank ends the run with an error, and the earlier output stays
cp "$T/direct.vdb" "$T/kept.vdb"
cp "$T/kept.vdb" "$T/kept.orig"
set +e
timeout $LIMIT "${MPI[@]}" "$OHM" "${WALNUT[@]}" -light type=directional dir=0,-1,-1 intensity=1 orbit=2000 axis=y \
  -solve solver=amg -write file="$T/kept.vdb" >"$T/out" 2>"$T/err" &
job=$!
set -e
victim=""
for _ in $(seq 1 $((LIMIT * 10))); do  # until rank 1 is serving solves
  if grep -q "amg set up on 2 rank" "$T/err" 2>/dev/null; then
    for p in $(pgrep -x ohm); do
      if tr '\0' '\n' </proc/"$p"/environ 2>/dev/null | grep -qx 'OMPI_COMM_WORLD_RANK=1'; then victim=$p; fi
    done
  fi
  [ -n "$victim" ] && break
  sleep 0.1
done
if [ -n "$victim" ]; then
  kill -KILL "$victim"
  t_kill=$(date +%s)
  set +e; wait $job; got=$?; set -e
  took=$(( $(date +%s) - t_kill ))
  if [ "$got" != 0 ] && [ "$got" != 124 ]; then ok; else bad "killed rank: mpirun exit $got"; fi
  check "killed rank: the run ended in ${took}s (< $(SAFETY 30) s)" test "$took" -lt "$(SAFETY 30)"
  check "killed rank: mpirun says which process died" grep -Eq "(rank 1|signal 9|Killed)" "$T/err"
  check "killed rank: the earlier output is unchanged" cmp -s "$T/kept.vdb" "$T/kept.orig"
  check "killed rank: no temporary left" bash -c '! ls "$1"/.kept.vdb* "$1"/kept.vdb.* 2>/dev/null | grep -q .' _ "$T"
else
  kill $job 2>/dev/null || true
  bad "killed rank: rank 1 never started serving: $(tail -3 "$T/err")"
fi
finish
