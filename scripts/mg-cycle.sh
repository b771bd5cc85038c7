#!/usr/bin/env bash
# The multigrid cycle against this machine's memory bandwidth
# (docs/multigrid.md): tests/bench_mg.c times one application of solver=mg's
# preconditioner on the scale study's block medium, counts the bytes it
# streams kernel by kernel, and measures STREAM's triad in the same process
# just before and after.  Prints a Markdown table (docs/multigrid.md holds a
# measured one); it asserts nothing.
#
#   scripts/mg-cycle.sh [BUILD_DIR] [N ...]
#
# BUILD_DIR (default build) is a CMake build of ohm; each N (default 100 216:
# 1e6 and 1e7 cells) is an N^3 grid.  About 1.5 GB and 20 s at N = 216.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
shift || true
SIZES=("$@")
[ ${#SIZES[@]} -gt 0 ] || SIZES=(100 216)
cmake --build "$BUILD" --target bench_mg >/dev/null
BENCH="$BUILD/tests/bench_mg"
[ -x "$BENCH" ] || { echo "mg-cycle: no $BENCH after building its target" >&2; exit 1; }
echo "## mg's cycle against the triad ($BUILD, $(date -u +%F), $(nproc) cores)"
echo
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
"$BENCH" "${SIZES[@]}"
