#!/usr/bin/env bash
# The scale study of issue 12 (docs/scale.md): time per light, setup time,
# iterations and peak memory of solver=direct, cg and amg from 1e5 to 1e7
# cells, on a synthetic block medium with 1e6 contrasts in D (8^3-cell blocks
# alternating sigma_s' = 1 and 1e6 /mm, sigma_a = 0.001 /mm: the hard case for
# CG) and on marble Spot; then weak scaling of amg under mpirun -np 1, 2, 4
# (oversubscribed on this 2-core machine: iterations and memory per rank are
# meaningful, the times are not).  Writes docs/scale.csv and the table in
# docs/scale-table.md; a row that would not fit in memory or exceed
# MAX_SECONDS (default 600) per solve is skipped and says so.
#   scripts/scale.sh [build/ohm]          SIZES="46 100 216" to choose N (N^3 cells)
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
echo "scene,solver,ranks,cells,t_setup,t_solve_per_light,iterations_per_light,peak_rss_mb,t_assemble,t_total,note" >"$csv"

blocks() {  # N: an N^3 u8 volume of 8^3 blocks, densities 10 and 20 alternating
  /usr/bin/python3 - "$1" "$tmp/blocks$1.raw" <<'PY'
import sys
import numpy as np
n = int(sys.argv[1])
i = np.arange(n) // 8
v = np.where((i[:, None, None] + i[None, :, None] + i[None, None, :]) % 2 == 0, 10, 20).astype(np.uint8)
v.tofile(sys.argv[2])
PY
}
printf 'ohm-transfer 1\n10 0.001 1\n20 0.001 1e6\n' >"$tmp/blocks.transfer"

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
print("%s,%s,%s,%d,%.3f,%.4f,%.1f,%.0f,%.3f,%.3f," % (sys.argv[3], s["solver"], sys.argv[5], s["cells"], setup,
      s["t_solve"] / cols, s["cg_iterations"] / cols, rss_mb, s["t_assemble"],
      s["t_voxelize"] + s["t_assemble"] + setup + s["t_source"] + s["t_solve"]))
PY
}

for n in $SIZES; do
  blocks "$n"
  scene=(-read file="$tmp/blocks$n.raw" dims="$n,$n,$n" type=u8 spacing=1 -voxelize dim="$n" threshold=5
         -material transfer="$tmp/blocks.transfer" -light type=directional dir=0,-1,0 intensity=1)
  for solver in amg cg direct; do
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
  for solver in amg cg direct; do
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
  for solver in amg cg; do
    SOLVE_OPTS=shadows=grid row "head ${v} mm" "$solver" 0 -- "${scene[@]}"
  done
done
# weak scaling: about 1e6 cells per rank
for np in 1 2 4; do
  n=$(python3 -c "print(round((1e6 * $np) ** (1 / 3)))")
  blocks "$n"
  row "blocks $n^3 (weak)" amg "$np" -- -read file="$tmp/blocks$n.raw" dims="$n,$n,$n" type=u8 spacing=1 \
    -voxelize dim="$n" threshold=5 -material transfer="$tmp/blocks.transfer" -light type=directional dir=0,-1,0
  rm -f "$tmp/blocks$n.raw"
done

{
  echo "| scene | solver | ranks | cells | setup (s) | solve / light (s) | iterations / light | peak RSS (MB) | assembly (s) | total (s) | note |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  tail -n +2 "$csv" | sed 's/^/| /; s/,/ | /g; s/$/ |/'
} >docs/scale-table.md
echo "scale: wrote $csv and docs/scale-table.md" >&2
