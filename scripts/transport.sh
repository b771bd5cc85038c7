#!/usr/bin/env bash
# The transport study (docs/transport.md): ohm at default settings against its
# Monte Carlo transport on the study's scenes (`ohm validate transport`:
# slabs at eta 1.0 and 1.4, a 60 mm cube at 1.37, the cube with a sphere;
# the MCX benchmark's medium), at h = 1 and 0.5 mm (the pencil beam's default:
# the hybrid, its first 10 reduced scatterings traced), then at h = 1 mm
# diffusion alone (hybrid=0), and that with the older polynomial boundary
# constant (fresnel=polynomial), for the before/after; the Monte Carlo
# reference's own rows against published values come first in each table.
# Writes OUTDIR/transport-table.md.  About 20 minutes on 2 cores.
#   scripts/transport.sh [OUTDIR=docs] [PHOTONS=4e6]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs}
photons=${2:-4e6}
ohm=${OHM:-build/ohm}
[ -x "$ohm" ] || { echo "transport: $ohm not built: run ./scripts/demo.sh or cmake --build build" >&2; exit 1; }
mkdir -p "$out"
tmp=$(mktemp); trap 'rm -f "$tmp"' EXIT
{
  echo "# Diffusion against Monte Carlo transport: the measured table"
  echo
  echo "Made by \`scripts/transport.sh\` on $(date -u +%Y-%m-%d) ($(nproc) cores), $photons photons per scene,"
  echo "ohm $("$ohm" --version | cut -d' ' -f2). Rows and tolerances: docs/transport.md."
  for run in "h=1" "h=0.5" "h=1 hybrid=0" "h=1 hybrid=0 fresnel=polynomial"; do
    echo
    echo "## \`ohm validate transport $run photons=$photons\`"
    echo
    echo '```'
    # a failed row exits 1: the table is the point, keep going
    "$ohm" -q validate transport $run photons="$photons" 2>/dev/null || true
    echo '```'
  done
} > "$tmp"
mv "$tmp" "$out/transport-table.md"
echo "transport: wrote $out/transport-table.md"
