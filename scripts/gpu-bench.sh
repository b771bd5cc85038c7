#!/usr/bin/env bash
# gpu-bench.sh — ohm on this machine's OpenCL devices (docs/devices.md): `ohm
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
  # the hierarchy's device memory per cell, from the largest row: what 1e9 cells would need
  awk -F'|' '/^\| [0-9]+\^3/ {cells = $3 + 0; mib = $8 + 0} END {
    if (cells > 0) printf("The device holds %.0f B per cell (the largest row: %.0f MiB for %.3g cells), so 10⁹ cells would need %.0f GB of device memory.\n", mib * 1048576 / cells, mib, cells, mib * 1048576 / cells)
  }' <<<"$rows"
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
    echo "to be measured; none are estimated here."
  fi
  echo
  cat <<'DESIGN'
## What runs where, and in what precision

| part | where | precision | why |
|---|---|---|---|
| voxelizing, materials, the network's conductances, light entries and sources, shadow rays | host | double | done once per scene or per light; the device would wait on them either way |
| mg's hierarchy (aggregation, Galerkin coarse operators, the coarsest factor) | host, once; copied to the device | single (cycle), double (coarsest factor) | built once and kept for every relight (`keep=1`, the library's relight, the add-on's Live) |
| mg's solve: the outer flexible CG, the K-cycle, smoothing, restriction, prolongation, the coarsest solve | device | outer CG double on the network's own stencil; cycle single | a preconditioner need only approximate A⁻¹, and floats halve what its passes stream; the outer iteration in double keeps the solution and the power books as exact as direct's (agreement 10⁻¹⁴–10⁻¹⁵ of the peak here) |
| Monte Carlo photons (solver=mc, the hybrid's, `ohm validate`) | device | double paths, double tallies | the same physics as the host's tracer step for step (one source: mc_step.h); tallies by 64-bit compare-and-swap (a device needs cl_khr_int64_base_atomics); a seed's photon k follows the same path whatever the launch (Philox4x32-10) |
| batches' sums, standard errors, the books, `.vdb` output | host | double | the host's code (mc_tally.c, the solution's books) for both |

A device without double precision is refused in one line (the outer iteration and the tracer need it);
`device=auto` falls back to the host where there is no GPU, and leaves grids under 2¹⁶ cells and traces
of fewer than 2¹⁷ photons there.

DESIGN
  echo "On PoCL a kernel is compiled when it is first launched, so the first solve in a process also pays for"
  echo "the compilation (about a second here); the rows above are each a fresh hierarchy in one process."
  echo "\`scripts/gpu-pack.sh\` packs \`ohm-gpu-bench\` (libc and libm only), Debian's ICD loader and a vendors"
  echo "folder for a GPU machine that has none of ohm's packages; its \`run.sh\` prints these tables there."
} > docs/gpu.md
cat docs/gpu.md
