#!/usr/bin/env bash
# The serial stages' cost per interior cell (docs/serial-stages.md): ns per cell
# and bytes per cell for everything ohm times outside the solver, printed as
# Markdown tables (docs/serial-stages.md holds measured ones).  It reports; it
# asserts nothing.
#
#   scripts/serial-stages.sh [BUILD_DIR] [DIM ...]
#
# BUILD_DIR (default build) is a CMake build of ohm; DIMs
# (default 190 410: ~1e6 and ~1e7 interior cells) are -voxelize dim= values
# for the bundled Spot scaled to 100 mm.
#
# 1. tests/bench_serial.c (BUILD_DIR's bench_serial target: built with the
#    tests, not a ctest — no timed tests) times ohm_network_build and
#    ohm_network_assemble alone on an ellipsoid (thread CPU time; the first
#    call, into memory the process never wrote, as in a run, and the best of
#    5), refills a matrix (ohm_network_assemble_into), and counts the
#    network's bytes.
# 2. ohm itself, per DIM: read + voxelize alone, then the whole chain with a
#    grey absorbing material (one channel; CG converges in few iterations, so
#    the solve does not dominate) and, at the first DIM, marble (three
#    channels, three assemblies: the first into a fresh matrix, the others
#    refilling it).  Stage times come from -stats (wall clock, per stage:
#    t_network is the topology, t_assemble every channel's matrix); peak
#    memory from /usr/bin/time -v (whole process).
#
# The machine may be shared: the load average is printed with each table,
# and wall times under load are upper bounds.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
shift || true
DIMS=("$@")
[ ${#DIMS[@]} -gt 0 ] || DIMS=(190 410)
OHM="$BUILD/ohm"
[ -x "$OHM" ] || { echo "serial-stages: no $OHM (build ohm first)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# --- 1. the network alone --------------------------------------------------
cmake --build "$BUILD" --target bench_serial >/dev/null
BENCH="$BUILD/tests/bench_serial"
[ -x "$BENCH" ] || { echo "serial-stages: no $BENCH after building its target" >&2; exit 1; }

echo "## network build and assembly alone ($BUILD, $(date -u +%F))"
echo
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
"$BENCH" time 1e6 1e7
echo

# --- 2. ohm's stages ---------------------------------------------------------
run() { # label, then ohm's arguments; prints one table row
  local label=$1
  shift
  /usr/bin/time -v "$OHM" --quiet "$@" -stats file="$tmp/s.json" 2>"$tmp/time.txt" >/dev/null || {
    cat "$tmp/time.txt" >&2
    return 1
  }
  local rss
  rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$tmp/time.txt")
  /usr/bin/python3 - "$label" "$tmp/s.json" "$rss" <<'PY'
import json, sys
label, s, rss = sys.argv[1], json.load(open(sys.argv[2])), float(sys.argv[3]) * 1024
n = s["cells"]
grid = s["grid_x"] * s["grid_y"] * s["grid_z"]
def ns(k):
    return f"{1e9 * s[k] / n:.0f}" if k in s else "–"
print(f"| {label} | {n} | {grid / n:.2f} | {s.get('channels', '–')} | {s.get('cg_iterations', '–')} | "
      f"{ns('t_voxelize')} | {ns('t_network')} | {ns('t_assemble')} | {ns('t_shadow_setup')} | {ns('t_source')} | {ns('t_cg_setup')} | "
      f"{ns('t_solve')} | {ns('t_write')} | {rss / n:.0f} |")
PY
}

echo "## ohm's stages, Spot at 100 mm (ns per interior cell; peak RSS of the whole process per interior cell)"
echo
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| run | interior cells | grid cells per cell | channels | CG iterations | voxelize | network | assemble (every channel) | shadow setup | source | CG setup | solve | write .vdb | peak RSS (B/cell) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
mesh=(-read file=samples/spot.obj size=100)
first=1
for d in "${DIMS[@]}"; do
  run "dim=$d read + voxelize" "${mesh[@]}" -voxelize dim="$d"
  run "dim=$d grey" "${mesh[@]}" -voxelize dim="$d" -material sigma_a=0.05 sigma_s=1.5 \
    -light type=directional dir=0,-1,0 -solve solver=cg -write file="$tmp/out.vdb"
  if [ $first = 1 ]; then
    run "dim=$d marble" "${mesh[@]}" -voxelize dim="$d" -material preset=marble \
      -light type=directional dir=0,-1,0 -solve solver=cg
    first=0
  fi
done
echo
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
