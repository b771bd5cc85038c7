#!/usr/bin/env bash
# Spot in marble rendered with POV-Ray from ohm's .df3 media:
#   pipelines/povray-spot.sh [build/ohm] [outdir]
# Writes OUTDIR/spot-pov.ply (vertex-coloured mesh), OUTDIR/spot_r/g/b.df3,
# OUTDIR/spot.pov and renders OUTDIR/spot-povray.png.
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=${1:-build/ohm}
out=${2:-out}
mkdir -p "$out"
"$OHM" -read file=samples/spot.obj size=50 -voxelize dim=48 -material preset=marble \
  -light type=directional dir=0,-1,-1 -solve -export ply="$out/spot-pov.ply" df3="$out/spot"
command -v povray >/dev/null || { echo "povray-spot: povray not found (apt-get install povray)" >&2; exit 1; }
# the .pov names its .df3 files without a directory: render from there
(cd "$out" && povray +Ispot.pov +Ospot-povray.png +W480 +H360 +A0.3 -D Display=off >/dev/null 2>&1)
echo "povray-spot: wrote $out/spot-povray.png, $out/spot-pov.ply" >&2
