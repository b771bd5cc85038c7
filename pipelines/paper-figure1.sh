#!/usr/bin/env bash
# The seed paper's Figure 1, reproduced: a 15 x 15 single-layer grid (1 mm
# cells), every resistor 1 kOhm, Neumann boundary, a 1.18 V step source
# (behind 1 kOhm) in the middle 3 x 3 cells — against the Jensen dipole for
# milk (sigma_a 0.0041, sigma_s' 2.6 /mm) lit on the same 3 x 3 mm square, a
# network built from those milk coefficients, and ohm's own 3-D Robin model.
#   pipelines/paper-figure1.sh [build/ohm] [outdir]
# Writes OUTDIR/figure1.csv and OUTDIR/figure1.png (gnuplot).
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=${1:-build/ohm}
out=${2:-out}
mkdir -p "$out"
"$OHM" validate figure1 "$out/figure1.csv"
command -v gnuplot >/dev/null || { echo "paper-figure1: gnuplot not found (apt-get install gnuplot-nox)" >&2; exit 1; }
tmp="$out/.figure1.png.tmp"
gnuplot <<GP
set terminal pngcairo size 900,560 font ",11"
set output "$tmp"
set datafile separator ","
set key bottom center box opaque font ",10"
set termoption noenhanced
set title "Seed paper, Figure 1: profile along the middle row (each curve normalised to its peak)"
set xlabel "x (mm), 1 mm cells"
set ylabel "relative response"
set logscale y
set yrange [0.001:1.5]
set xrange [0:15]
set grid
plot "$out/figure1.csv" skip 1 using 1:6 with linespoints lw 2 pt 7 title "paper's network: all resistors 1 kOhm, Neumann", \
     "" skip 1 using 1:8 with lines lw 3 dt 2 title "Jensen dipole, milk (sigma_a 0.0041, sigma_s' 2.6 /mm)", \
     "" skip 1 using 1:9 with linespoints lw 2 pt 5 title "ohm 3-D, Robin, h = 0.25 mm, same milk", \
     "" skip 1 using 1:7 with linespoints lw 2 pt 9 title "single-layer network from the milk coefficients"
GP
mv "$tmp" "$out/figure1.png"
echo "paper-figure1: wrote $out/figure1.csv and $out/figure1.png" >&2
