#!/usr/bin/env bash
# The scale study (docs/scale.md): time per light, setup time,
# iterations and peak memory of solver=direct, cg, amg and mg from 1e5 to 1e7
# cells, on a synthetic block medium with 1e6 contrasts in D (8^3-cell blocks,
# sigma_s' = 1 or 1e6 /mm at random, sigma_a = 0.001 /mm: the hard case for
# CG), on marble Spot, the Colin27 head and the walnut CT; then weak scaling of amg under mpirun -np 1, 2, 4
# (oversubscribed on this 2-core machine: iterations and memory per rank are
# meaningful, the times are not).  Writes docs/scale.csv and the table in
# docs/scale-table.md; a row that would not fit in memory or exceed
# MAX_SECONDS (default 600) per solve is skipped and says so.
#   scripts/scale.sh [build/ohm]          SIZES="46 100 216" to choose N (N^3 cells)
#   SOLVERS="mg" APPEND=1 scripts/scale.sh   only those solvers' rows, added to
#                                           the docs/scale.csv there is (the
#                                           others' rows keep their run's date)
#   SIZES=" " SPOT_DIMS=" " HEAD_VOXELS=" " MPI_ROWS=0 APPEND=1 scripts/scale.sh
#                                           only the walnut's rows (WALNUT_VOXELS)
# Takes about an hour at the default sizes; run it with nothing else busy.
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=$(realpath "${1:-build/ohm}")
SIZES=${SIZES:-"46 100 147 216"}
SPOT_DIMS=${SPOT_DIMS:-"128 256 400"}
MAX_SECONDS=${MAX_SECONDS:-600}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
csv=docs/scale.csv
SOLVERS=${SOLVERS:-"amg cg direct mg"}
# MODEL_ONLY=1: only the table, plot and model, from the docs/scale.csv there is
[ "${MODEL_ONLY:-0}" = 1 ] || [ "${APPEND:-0}" = 1 ] || \
echo "scene,solver,ranks,cells,t_setup,t_solve_per_light,iterations_per_light,peak_rss_mb,t_assemble,t_total,note" >"$csv"

# N: the block medium of N^3 cells (scripts/block-medium.py: 8^3 blocks,
# sigma_s' 1 or 1e6 /mm at random) and its transfer function
blocks() { scripts/block-medium.py "$1" "$tmp/blocks$1.raw" "$tmp/blocks.transfer"; }

# row SCENE SOLVER RANKS -- ohm arguments (without -solve): one CSV row;
# SOLVE_OPTS (a word, in the environment) adds -solve options
row() {
  local scene=$1 solver=$2 ranks=$3; shift 4
  local launch=()
  [ "$ranks" = 0 ] || launch=(mpirun --oversubscribe -np "$ranks")
  echo "scale: $scene $solver ranks=$ranks" >&2
  set +e
  /usr/bin/time -f "%M" -o "$tmp/rss" timeout $((MAX_SECONDS * 4)) "${launch[@]}" "$OHM" "$@" \
    -solve solver="$solver" ${SOLVE_OPTS:-} -stats file="$tmp/s.json" >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  set -e
  if [ $rc != 0 ]; then
    local why; why=$(grep -m1 '^ohm: error:' "$tmp/err" | cut -c1-160 | tr ',' ';')
    [ $rc = 124 ] && why="over $((MAX_SECONDS * 4)) s"
    echo "$scene,$solver,${ranks/#0/1},,,,,,,,skipped: ${why:-exit $rc}" >>"$csv"
    return
  fi
  python3 - "$tmp/s.json" "$tmp/rss" "$scene" "$solver" "${ranks/#0/1}" >>"$csv" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
rss_mb = int(open(sys.argv[2]).read().split()[-1]) / 1024.0  # mpirun: its largest child
cols = max(1, s["solves"])
setup = s["t_analyze"] + s["t_factor"] + s["t_cg_setup"]
serial = s["t_voxelize"] + s.get("t_network", 0) + s["t_assemble"] + s["t_source"]
print("%s,%s,%s,%d,%.3f,%.4f,%.1f,%.0f,%.3f,%.3f," % (sys.argv[3], s["solver"], sys.argv[5], s["cells"], setup,
      s["t_solve"] / cols, s["cg_iterations"] / cols, rss_mb, s["t_assemble"], serial + setup + s["t_solve"]))
PY
}

if [ "${MODEL_ONLY:-0}" != 1 ]; then
for n in $SIZES; do
  blocks "$n"
  scene=(-read file="$tmp/blocks$n.raw" dims="$n,$n,$n" type=u8 spacing=1 -voxelize dim="$n" threshold=5
         -material transfer="$tmp/blocks.transfer" -light type=directional dir=0,-1,0 intensity=1)
  for solver in $SOLVERS; do
    if [ "$solver" = direct ] && [ "$n" -gt 100 ]; then
      echo "blocks $n^3,direct,1,,,,,,,,skipped: the factor of more than 1e6 cells does not fit in 24 GB" >>"$csv"
      continue
    fi
    row "blocks $n^3" "$solver" 0 -- "${scene[@]}"
  done
  rm -f "$tmp/blocks$n.raw"
done
for d in $SPOT_DIMS; do
  scene=(-read file=samples/spot.obj size=50 -voxelize dim="$d" -material preset=marble
         -light type=directional dir=0,-1,0 intensity=1)
  for solver in $SOLVERS; do
    if [ "$solver" = direct ] && [ "$d" -gt 200 ]; then
      echo "spot dim $d,direct,1,,,,,,,,skipped: the factor does not fit in 24 GB" >>"$csv"
      continue
    fi
    row "spot dim $d" "$solver" 0 -- "${scene[@]}"
  done
done
# the Colin27 head through its transfer function, at the scan's 1 mm and at
# 0.5 mm (trilinear), lit by one spot light; shadows through the grid
for v in ${HEAD_VOXELS:-1 0.5}; do
  scene=(-read file=samples/ch2.nii.gz -voxelize voxel="$v" threshold=40 -material transfer=samples/mri-head.transfer
         -light type=spot pos=-150,60,200 dir=0.6,-0.2,-0.8 angle=25 falloff=5 intensity=5000)
  for solver in $SOLVERS; do
    [ "$solver" != direct ] || continue
    SOLVE_OPTS=shadows=grid row "head ${v} mm" "$solver" 0 -- "${scene[@]}"
  done
done
# the walnut CT (uint16, 0.625 mm) through its RGB transfer function (shell,
# kernel, air: sigma_s' 0.01 to 2 /mm), at 0.2 mm (1e6 cells) and
# 0.1 mm (7.7e6), one directional light
for v in ${WALNUT_VOXELS:-0.2 0.1}; do
  scene=(-read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 spacing=0.625 -voxelize voxel="$v"
         threshold=5000 -material transfer=samples/walnut.transfer -light type=directional dir=0,-1,0 intensity=1)
  for solver in $SOLVERS; do
    if [ "$solver" = direct ] && [ "$v" != 0.2 ]; then
      echo "walnut $v mm,direct,1,,,,,,,,skipped: ohm refuses it after the analysis (the factor needs 23.3 GiB; 19.4 free)" >>"$csv"
      continue
    fi
    row "walnut $v mm" "$solver" 0 -- "${scene[@]}"
  done
done
# weak and strong scaling of amg under mpirun (MPI_ROWS=0: not)
if [[ " $SOLVERS " == *" amg "* ]] && [ "${MPI_ROWS:-1}" = 1 ]; then
# weak scaling: about 1e6 cells per rank
for np in 1 2 4; do
  n=$(python3 -c "print(round((1e6 * $np) ** (1 / 3)))")
  blocks "$n"
  row "blocks $n^3 (weak)" amg "$np" -- -read file="$tmp/blocks$n.raw" dims="$n,$n,$n" type=u8 spacing=1 \
    -voxelize dim="$n" threshold=5 -material transfer="$tmp/blocks.transfer" -light type=directional dir=0,-1,0
  rm -f "$tmp/blocks$n.raw"
done
# strong scaling: 1e7 cells on both cores of this machine
n=216
blocks "$n"
row "blocks $n^3 (2 ranks)" amg 2 -- -read file="$tmp/blocks$n.raw" dims="$n,$n,$n" type=u8 spacing=1 \
  -voxelize dim="$n" threshold=5 -material transfer="$tmp/blocks.transfer" -light type=directional dir=0,-1,0
rm -f "$tmp/blocks$n.raw"
fi

fi

{
  echo "| scene | solver | ranks | cells | setup (s) | solve / light (s) | iterations / light | peak RSS (MB) | assembly (s) | total (s) | note |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  tail -n +2 "$csv" | sed 's/^/| /; s/,/ | /g; s/$/ |/'
} >docs/scale-table.md

# the plot: time per light and setup time against cells, per solver (blocks)
for solver in direct cg amg mg; do
  awk -F, -v s="$solver" '$1 ~ /^blocks/ && $1 !~ /\(/ && $2 == s && $4 != "" {print $4, $6, $5}' "$csv" \
    >"$tmp/$solver.dat"
done
if command -v gnuplot >/dev/null; then
  gnuplot <<GP
set terminal pngcairo size 900,560
set output "docs/scale.png"
set logscale xy
set xlabel "cells"
set ylabel "seconds"
set key top left
set grid
set title "Random block medium, 1e6 contrasts in D: one light, one channel (this 2-core machine)"
plot "$tmp/direct.dat" using 1:2 with linespoints title "direct: solve / light", \
     "$tmp/cg.dat" using 1:2 with linespoints title "cg: solve / light", \
     "$tmp/amg.dat" using 1:2 with linespoints title "amg: solve / light", \
     "$tmp/mg.dat" using 1:2 with linespoints title "mg: solve / light", \
     "$tmp/direct.dat" using 1:3 with linespoints dashtype 2 title "direct: analysis + factor", \
     "$tmp/amg.dat" using 1:3 with linespoints dashtype 2 title "amg: setup", \
     "$tmp/mg.dat" using 1:3 with linespoints dashtype 2 title "mg: setup"
GP
fi

# the model: amg's setup, solve and memory per cell fitted (least squares
# through the origin) to the blocks rows of 1e6 cells and more; ohm's serial
# memory per cell from the cg rows (cg holds 5 vectors beside A); predictions
# for 1e8 and 1e9 cells on N machines like this one (2 ranks each), assuming
# the iteration count stays as measured in the weak-scaling rows
/usr/bin/python3 - "$csv" >docs/scale-model.md <<'PY'
import csv, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["cells"]]
def fit(pairs):
    return sum(x * y for x, y in pairs) / sum(x * x for x, _ in pairs) if pairs else float("nan")
amg = [r for r in rows if r["solver"] == "amg" and r["scene"].startswith("blocks") and "(" not in r["scene"]
       and int(r["cells"]) >= 10**6]
cg = [r for r in rows if r["solver"] == "cg" and r["scene"].startswith("blocks") and int(r["cells"]) >= 10**6]
a = fit([(int(r["cells"]), float(r["t_setup"])) for r in amg])
b = fit([(int(r["cells"]), float(r["t_solve_per_light"])) for r in amg])
m_amg = fit([(int(r["cells"]), float(r["peak_rss_mb"]) * 2**20) for r in amg])
m_cg = fit([(int(r["cells"]), float(r["peak_rss_mb"]) * 2**20) for r in cg])
serial = m_cg - (5 * 8 + 72)    # cg: 5 vectors and A (72 B/cell) beside ohm's own
solver = m_amg - serial
weak = sorted((int(r["ranks"]), float(r["iterations_per_light"]), float(r["peak_rss_mb"])) for r in rows
              if "weak" in r["scene"] and r["cells"])
print("### The model (fitted by scripts/scale.sh)\n")
print("From the block-medium rows with at least 1e6 cells, one rank:\n")
print("- amg setup %.0f ns per cell, solve %.0f ns per cell per light per channel;" % (a * 1e9, b * 1e9))
print("- whole-process peak %.0f B per cell with amg, %.0f B per cell with cg;" % (m_amg, m_cg))
print("- so ohm's own (serial) share is about %.0f B per cell, and amg's about %.0f B per cell."
      % (serial, solver))
if weak:  # the largest rank is rank 0, which also holds the serial data
    print("- weak scaling (about 1e6 cells per rank): " + "; ".join(
        "%d rank(s): %.1f iterations, %.0f MB on the largest rank" % w for w in weak) + ".")
mg = [r for r in rows if r["solver"] == "mg" and r["scene"].startswith("blocks") and int(r["cells"]) >= 10**6]
if mg:
    setup = fit([(int(r["cells"]), float(r["t_setup"])) for r in mg])
    solve = fit([(int(r["cells"]), float(r["t_solve_per_light"])) for r in mg])
    peak = fit([(int(r["cells"]), float(r["peak_rss_mb"]) * 2**20) for r in mg])
    print("- mg (one machine; it does not run under mpirun) setup %.0f ns per cell, solve %.0f ns per cell per light "
          "per channel, whole-process peak %.0f B per cell: 1e8 cells would take %.0f s per light and %.1f GB "
          "(1e9 B); 1e9 cells %.0f s per light and %.0f GB, on one machine with that much memory, if its iterations "
          "stay as flat as from 1e5 to 1e8 (16-18). mg does not distribute: beyond one machine, amg's table below."
          % (setup * 1e9, solve * 1e9, peak, solve * 1e8, peak * 1e8 / 1e9, solve * 1e9, peak * 1e9 / 1e9))
print("\nPredicted for machines like this one (2 cores, 24 GB; 2 ranks each), if the iteration count stays")
print("flat as in the weak-scaling rows and the network adds nothing (an optimistic bound for the times):\n")
print("| cells | machines | rank 0's memory (serial + its share) | memory per other rank | setup | per light per channel |")
print("|---:|---:|---:|---:|---:|---:|")
for n in (1e8, 1e9):
    for N in (1, 4, 16, 64):
        ranks = 2 * N
        r0 = serial * n + solver * n / ranks
        other = solver * n / ranks
        fits = r0 + other <= 24 * 2**30 and 2 * other <= 24 * 2**30  # rank 0 shares its machine
        print("| %.0e | %d | %.1f GB%s | %.1f GB | %.0f s | %.0f s |" % (n, N, r0 / 2**30, "" if fits else " (does not fit)",
              other / 2**30, a * n / ranks, b * n / ranks))
PY
echo "scale: wrote $csv, docs/scale-table.md, docs/scale-model.md and docs/scale.png" >&2
