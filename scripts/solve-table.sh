#!/usr/bin/env bash
# Solve a mesh at a series of grid sizes and print a Markdown table: cells,
# nnz(A), nnz(L), flops, analyse / factor / solve times, backward error and
# conservation error.  Defaults: spot.obj at 50 mm, marble, one directional
# light, dim 16 32 64 128.
#   scripts/solve-table.sh [build/ohm] [mesh] [material preset] [dims...]
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=${1:-build/ohm}; mesh=${2:-samples/spot.obj}; mat=${3:-marble}; shift $(( $# < 3 ? $# : 3 ))
dims=${*:-16 32 64 128}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
echo "| dim | cells | nnz(A) | nnz(L) | flops | channels / factors | analyse (s) | factor (s) | source (s) | solve (s) | backward error | conservation error |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for d in $dims; do
  "$OHM" --quiet -read file="$mesh" size=50 -voxelize dim="$d" -material preset="$mat" \
    -light type=directional dir=0,-1,-1 -solve -stats file="$tmp/s.json"
  /usr/bin/python3 - "$d" "$tmp/s.json" <<'PY'
import json, sys
d, s = sys.argv[1], json.load(open(sys.argv[2]))
print(f"| {d} | {s['cells']} | {s['nnz_A']:.3g} | {s['nnz_L']:.3g} | {s['flops']:.3g} | {s['channels']} / {s['factors']} | "
      f"{s['t_analyze']:.3f} | {s['t_factor']:.3f} | {s['t_source']:.4f} | {s['t_solve']:.4f} | {s['residual']:.2g} | "
      f"{s['conservation_error']:.2g} |")
PY
done
