#!/usr/bin/env bash
# Spot (50 mm marble, dim 64) lit from its +x side, solved by ohm, rendered by
# Blender's Cycles with pipelines/blender/render.py: the exitance (light
# leaving the surface) as a glowing skin, and the fluence inside.
#   pipelines/blender/render-spot.sh [build/ohm] [outdir]
# Writes OUTDIR/spot-side.vdb, .json, -exitance.png, -fluence.png and
# -render.json (render.py's report: grids, boxes, camera, times).
set -euo pipefail
cd "$(dirname "$0")/../.."
OHM=${1:-build/ohm}
out=${2:-out}
BLENDER=${OHM_BLENDER:-blender}
mkdir -p "$out"
command -v "$BLENDER" >/dev/null || { echo "render-spot: blender not found (apt-get install blender)" >&2; exit 1; }
"$OHM" -read file=samples/spot.obj size=50 -voxelize dim=64 -material preset=marble \
  -light type=directional dir=-1,0,0 intensity=1 -solve \
  -write file="$out/spot-side.vdb" -stats file="$out/spot-side.json"
scale=$(/usr/bin/python3 -c 'import json,sys; print(repr(json.load(open(sys.argv[1]))["mesh_scale_mm"]))' "$out/spot-side.json")
render() {  # render GRID EXPOSURE
  "$BLENDER" -b --factory-startup --python-exit-code 3 -P pipelines/blender/render.py -- \
    --vdb "$out/spot-side.vdb" --mesh samples/spot.obj --scale-mm "$scale" --light-dir -1,0,0 \
    --grid "$1" --exposure "$2" --size 480 360 --samples 32 \
    --out "$out/spot-side-$1.png" --json "$out/spot-side-$1-render.json" | grep '^render.py:'
  /usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); [print("render.py:", p) for p in d["problems"]]; sys.exit(not d["ok"])' \
    "$out/spot-side-$1-render.json"
}
render exitance 0.5
render fluence 0.03
echo "render-spot: wrote $out/spot-side-exitance.png and $out/spot-side-fluence.png"
