#!/usr/bin/env bash
# The speed/accuracy study (issue 7): `ohm accuracy` on spot at 50 mm for
# marble, skin1 and ketchup (dims 16..128, both solvers, reference 192 with CG,
# depth bands at 128, the half-space against its exact solution), then a
# log-log plot of error against time with gnuplot.
#   scripts/accuracy.sh [OUTDIR=docs] [extra ohm accuracy options...]
# Writes OUTDIR/accuracy.csv, OUTDIR/accuracy.md (the tables) and
# OUTDIR/accuracy.png.  About 5 minutes on 2 cores.  Needs a built build/ohm
# (./scripts/demo.sh or cmake --build build) and gnuplot (gnuplot-nox).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs}; shift || true
ohm=${OHM:-build/ohm}
[ -x "$ohm" ] || { echo "accuracy: $ohm not built: run ./scripts/demo.sh or cmake --build build" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "accuracy: needs gnuplot (apt-get install gnuplot-nox)" >&2; exit 1; }
mkdir -p "$out"
"$ohm" accuracy csv="$out/accuracy.csv" "$@" > "$out/accuracy.md.tmp"
mv "$out/accuracy.md.tmp" "$out/accuracy.md"
gnuplot <<GP
set terminal pngcairo size 1100,480 font ",10"
set output "$out/accuracy.png.tmp"
set datafile separator ","
set multiplot layout 1,2 title "ohm: error of the surface exitance (spot, 50 mm) against cost"
set logscale xy
set grid
set key bottom left
set xlabel "time per solve, all stages (s)"
set ylabel "relative L1 error vs Richardson-extrapolated reference"
sel(m, s) = (strcol(1) eq "series" && strcol(2) eq m && strcol(5) eq s)
plot for [m in "marble skin1 ketchup"] "$out/accuracy.csv" using (sel(m,"cg") ? \$18 : 1/0):(sel(m,"cg") ? \$22 : 1/0) with linespoints lw 2 title m." (cg)", \
     for [m in "marble skin1 ketchup"] "$out/accuracy.csv" using (sel(m,"direct") ? \$18 : 1/0):(sel(m,"direct") ? \$22 : 1/0) with linespoints dt 2 title m." (direct)"
set xlabel "voxel size h (mm)"
set ylabel "relative L1 error"
set key top left
plot for [m in "marble skin1 ketchup"] "$out/accuracy.csv" using (sel(m,"cg") ? \$4 : 1/0):(sel(m,"cg") ? \$22 : 1/0) with linespoints lw 2 title m." vs Richardson", \
     "$out/accuracy.csv" using (strcol(1) eq "halfspace" ? \$4 : 1/0):(strcol(1) eq "halfspace" ? \$20 : 1/0) with linespoints lw 2 title "half-space vs exact", \
     x*x*0.05 with lines dt 3 lc "gray" title "h^2 slope", x*0.1 with lines dt 4 lc "gray" title "h slope"
unset multiplot
GP
mv "$out/accuracy.png.tmp" "$out/accuracy.png"
echo "accuracy: wrote $out/accuracy.csv, $out/accuracy.md, $out/accuracy.png"
