#!/usr/bin/env bash
# The speed/accuracy study (docs/accuracy.md): `ohm accuracy` on spot at 50 mm for
# marble, skin1 and ketchup (dims 16..128, both solvers, reference 192 with CG,
# depth bands at 128, the half-space against its exact solution), then a
# log-log plot of error against time with gnuplot.
#   scripts/accuracy.sh [OUTDIR=docs] [extra ohm accuracy options...]
# Writes OUTDIR/accuracy.csv, OUTDIR/accuracy-tables.md (the tables) and
# OUTDIR/accuracy.png.  About 5 minutes on 2 cores.  Needs a built build/ohm
# (./scripts/demo.sh or cmake --build build) and gnuplot (gnuplot-nox).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs}; shift || true
ohm=${OHM:-build/ohm}
[ -x "$ohm" ] || { echo "accuracy: $ohm not built: run ./scripts/demo.sh or cmake --build build" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "accuracy: needs gnuplot (apt-get install gnuplot-nox)" >&2; exit 1; }
mkdir -p "$out"
"$ohm" accuracy csv="$out/accuracy.csv" "$@" > "$out/accuracy-tables.md.tmp"
mv "$out/accuracy-tables.md.tmp" "$out/accuracy-tables.md"
# one data file per curve (gnuplot joins points only within a block)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
awk -F, -v d="$tmp" 'NR > 1 && $1 == "series" && $20 > 0 { print $18, $20, $4 > (d "/" $2 "-" $5 ".dat") }
                     NR > 1 && $1 == "halfspace" { print $18, $20, $4 > (d "/halfspace.dat") }' "$out/accuracy.csv"
mats=$(awk -F, 'NR > 1 && $1 == "series" { print $2 }' "$out/accuracy.csv" | uniq | tr '\n' ' ')
gnuplot <<GP
set terminal pngcairo size 1100,480 font ",10"
set output "$out/accuracy.png.tmp"
set multiplot layout 1,2 title "ohm: error of the surface exitance (binned, relative L1) against cost and voxel size"
set logscale xy
set grid
set key bottom left
set xlabel "time for one solve, all stages (s)"
set ylabel "error against the finer reference"
plot for [m in "$mats"] "$tmp/".m."-cg.dat" using 1:2 with linespoints lw 2 title m." (cg)", \
     for [m in "$mats"] "$tmp/".m."-direct.dat" using 1:2 with linespoints dt 2 title m." (direct)"
set xlabel "voxel size h (mm)"
set key top left
plot for [m in "$mats"] "$tmp/".m."-cg.dat" using 3:2 with linespoints lw 2 title m, \
     "$tmp/halfspace.dat" using 3:2 with linespoints lw 2 title "half-space vs exact solution", \
     x*x*0.05 with lines dt 3 lc "gray" title "h^2", x*0.1 with lines dt 4 lc "gray" title "h"
unset multiplot
GP
mv "$out/accuracy.png.tmp" "$out/accuracy.png"
echo "accuracy: wrote $out/accuracy.csv, $out/accuracy-tables.md, $out/accuracy.png"
