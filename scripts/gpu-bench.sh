#!/usr/bin/env bash
# gpu-bench.sh — ohm on this machine's OpenCL devices (issue 37): `ohm
# devices` (each device's memory, precision and checked triad), then
# solver=mg on the chosen device against the host's cores on the scale
# study's block medium (tests/bench_device.c: one light to 1e-10, the
# device's answer against the host's), and the Monte Carlo tracer on MCX's
# cube60 on the device and on the host's cores (photons/ms, the absorbed
# fraction against MCX's 17.69708%).  Writes docs/gpu.md.  On a GPU
# machine without ohm's packages, run scripts/gpu-pack.sh's folder instead
# (its run.sh prints the same table).
#   scripts/gpu-bench.sh [BUILD_DIR] [DEVICE] [N ...]
# DEVICE default auto (a GPU), falling back to cpu (PoCL) where there is no
# GPU; N default 100 216 (1e6 and 1e7 cells: about 2 GB on the host).
# PHOTONS (default 1e8 on a GPU, 1e6 on PoCL) and HOST_PHOTONS (default
# 1e6) set cube60's photons.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
DEVICE=${2:-auto}
shift 2 || shift $# || true
SIZES=("$@")
[ ${#SIZES[@]} -gt 0 ] || SIZES=(100 216)
cmake --build "$BUILD" --target ohm bench_device >/dev/null
devices=$("$BUILD/ohm" devices 2>&1) || { echo "$devices" >&2; exit 1; }
if [ "$DEVICE" = auto ] && ! grep -q ", GPU, fp64" <<<"$devices"; then DEVICE=cpu; fi
rows=$("$BUILD/tests/bench_device" "$DEVICE" "${SIZES[@]}")
if grep -q ", GPU, fp64" <<<"$devices"; then photons=${PHOTONS:-1e8}; else photons=${PHOTONS:-1e6}; fi
mc_rows=$("$BUILD/tests/bench_device" "$DEVICE" mc "$photons" "${HOST_PHOTONS:-1e6}")
{
  echo "# ohm on OpenCL devices"
  echo
  echo "Measured by \`scripts/gpu-bench.sh\` on $(date -u +%F), $(nproc) host cores, device=$DEVICE."
  echo
  echo '```'
  echo "$devices"
  echo '```'
  echo
  echo "solver=mg on the scale study's block medium (blocks of 8³ cells, σs′ 1 or 10⁶ at random, σa 0.001/mm),"
  echo "one light solved to 1e-10 from zero. The hierarchy is built on the host and copied to the device once"
  echo "(a kept solver keeps it there for every relight); the host solve uses all the host's cores."
  echo
  echo "$rows"
  echo
  echo "The Monte Carlo tracer (solver=mc, \`ohm validate transport|mc\`, the hybrid's photons) on MCX's cube60:"
  echo "60³ cells of 1 mm, σa 0.005, σs 1/mm, g 0.01, a pencil beam, no reflection, a 5 ns gate. One photon per"
  echo "work-item, Philox4x32-10 random numbers, tallies in double by 64-bit compare-and-swap; the time includes"
  echo "opening the device, building the kernels and copying the scene. MCX's 1e8-photon absorbed fraction"
  echo "is 17.69708%; the last column is our difference from it in our standard errors."
  echo
  echo "$mc_rows"
  if ! grep -q ", GPU, fp64" <<<"$devices"; then
    echo
    echo "This machine has no GPU: the device here is the CPU through PoCL, which runs the same kernels and"
    echo "shows they agree with the host, not how fast a GPU is. The GPU figures wait for a machine with one"
    echo "(issue 37); none are estimated here."
  fi
  echo
  echo "On PoCL a kernel is compiled when it is first launched, so the first solve in a process also pays for"
  echo "the compilation (about a second here); the rows above are each a fresh hierarchy in one process."
  echo "\`scripts/gpu-pack.sh\` packs \`ohm-gpu-bench\` (libc and libm only), Debian's ICD loader and a vendors"
  echo "folder for a GPU machine that has none of ohm's packages; its \`run.sh\` prints these tables there."
} > docs/gpu.md
cat docs/gpu.md
