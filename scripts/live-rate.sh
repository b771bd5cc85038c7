#!/usr/bin/env bash
# live-rate.sh — the Blender add-on's live relight rate (docs/live.md): Spot
# (50 mm) in marble with a shadowed point light, at grid sizes around 3·10⁴
# and 3·10⁵ cells, each update timed whole (shadow rays and sources, solve,
# per-vertex exitance, attribute write) in a headless Blender through the
# same update the Live relight timer calls, with the panel's Solver set to
# each of SOLVERS (the factor, and multigrid from the last fluence).  Writes
# docs/live.md and the README's screenshot docs/blender-live.png.  About 5
# minutes.
#   scripts/live-rate.sh [build]            DIMS="60 128" MOVES=40 SOLVERS="direct mg"
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
DIMS=${DIMS:-"60 128"}
MOVES=${MOVES:-40}
SOLVERS=${SOLVERS:-"direct mg"}
ZIP="$BUILD/ohm_blender.zip"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
export BLENDER_USER_CONFIG="$T/config" BLENDER_USER_SCRIPTS="$T/scripts"
rows=""
first=$(echo $SOLVERS | cut -d' ' -f1)
for solver in $SOLVERS; do
  for dim in $DIMS; do
    shot=""
    [ "$dim" = "$(echo $DIMS | cut -d' ' -f1)" ] && [ "$solver" = "$first" ] && shot="$PWD/docs/blender-live.png"
    OHM_SCREENSHOT=$shot OHM_ADDON_SOLVER=$solver blender -b --factory-startup --python-exit-code 1 \
      -P tests/blender_addon.py -- "$ZIP" samples/spot.obj "$T" "$T/live_$dim.json" live "$dim" "$MOVES" \
      > "$T/log_$dim.txt" 2>&1 || { tail -20 "$T/log_$dim.txt"; exit 1; }
    rows+=$(/usr/bin/python3 - "$T/live_$dim.json" "$solver" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
p = r["update_parts_ms"]
other = p["relight_call"] - p["source_and_shadows"] - p["solve"]
print("| %s | %d | %d | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %d |" % (
  sys.argv[2], r["dim"], r["cells"], r["updates_per_second"], p["total"], p["source_and_shadows"], p["solve"],
  other, p["vertex_exitance"], p["attribute_write"], r["factorizations_after_live"]))
PY
)$'\n'
  done
done
{
  echo "# Live relight in Blender: updates per second"
  echo
  echo "Measured by \`scripts/live-rate.sh\` on $(date -u +%F) ($(nproc) cores): Spot, 50 mm, marble (three"
  echo "channels), one point light at 110 mm with shadow rays against the mesh, moved"
  echo "$MOVES times around the object; each update is what the *Live relight* timer does"
  echo "(\`operators.live_step\`): the new light handed to ohm, shadow rays and sources, the solve from"
  echo "the kept set-up (the panel's Solver: *direct*, three factors; *mg*, three hierarchies, each"
  echo "relight starting from the last fluence, to the default tolerance 1e-10), the exitance at each"
  echo "vertex, the colour attribute written (with Blender's depsgraph evaluated before and after it,"
  echo "as the add-on does).  Times in ms per update; *other* is the rest of the relight call (lights"
  echo "parsed, solution booked and logged)."
  echo
  echo "| solver | dim | cells | updates/s | whole update | shadows + sources | solve (3 channels) | other | vertex exitance | attribute write | factorizations |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  printf "%s" "$rows"
  echo
  echo "Targets: ≥ 30 updates/s at 3·10⁴ cells, ≥ 5 at 3·10⁵ (and ≥ 10 at 3·10⁵ for a relight"
  echo "through the library, docs/multigrid.md).  The factorizations column is the count after every"
  echo "move: the first solve's (none for mg), never more."
  echo
  echo "![the add-on's colour attribute in Blender's viewport shading](blender-live.png)"
} > docs/live.md
cat docs/live.md
