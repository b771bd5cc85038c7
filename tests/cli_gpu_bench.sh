#!/usr/bin/env bash
# cli_gpu_bench.sh — ohm-gpu-bench, the benchmark that travels (docs/devices.md):
# it needs nothing at run time but libc and libm (libOpenCL.so.1 is loaded
# when asked for), and scripts/gpu-pack.sh's folder runs it with its own
# ICD loader and a vendors folder of its own (PoCL's .icd here), solving on
# the device as the host does.  Without an OpenCL device: SKIP, unless
# CI=true or OHM_REQUIRE_OPENCL is set.
set -eu
source "$(dirname "$0")/lib.sh" "$1"
BENCH="$(dirname "$(realpath "$OHM")")/ohm-gpu-bench"
# a release artefact: a sanitizer build does not make it (CMakeLists.txt)
if [ "$SANITIZED" = 1 ]; then echo "SKIP: ohm-gpu-bench is not built with the sanitizers"; exit 0; fi
check "the build made ohm-gpu-bench" test -x "$BENCH"
needs=$(ldd "$BENCH" | awk '/=>/ {print $1}' | sort | tr '\n' ' ')
check "ohm-gpu-bench needs only libc and libm (it needs: $needs)" test "$needs" = "libc.so.6 libm.so.6 "
if ! "$OHM" devices >/dev/null 2>&1; then
  if [ "${CI:-}" = true ] || { [ -n "${OHM_REQUIRE_OPENCL:-}" ] && [ "$OHM_REQUIRE_OPENCL" != 0 ]; }; then
    bad "no OpenCL device, but CI=true or OHM_REQUIRE_OPENCL is set"
  else
    echo "SKIP: no OpenCL device"
  fi
  finish; exit
fi
# the pack, run as on a machine without ohm: its own loader, a vendors
# folder holding the .icd files of this machine's drivers
expect_exit 0 "scripts/gpu-pack.sh" -- bash scripts/gpu-pack.sh "$(dirname "$(realpath "$OHM")")"
PACK="$(dirname "$(realpath "$OHM")")/gpu-pack"
mkdir -p "$T/vendors"
cp /etc/OpenCL/vendors/*.icd "$T/vendors/" 2>/dev/null || true
expect_exit 0 "the pack's run.sh on an OpenCL CPU device" -- \
  env -i PATH=/usr/bin:/bin OCL_ICD_VENDORS="$T/vendors" DEVICE=cpu SIZES=24 PHOTONS=32000 HOST_PHOTONS=32000 \
  "$PACK/run.sh"
cat "$T/stdout"
check "the pack listed a device that passed its kernel test" grep -q "kernel test: ok" "$T/stdout"
check "the pack solved on the device as on the host (within 1e-6 of the peak)" $PY -c "
import sys
row = [l for l in open('$T/stdout') if l.startswith('| 24^3')][0].split('|')
its_host, its_dev, diff = row[4].split('(')[1].split()[0], row[8].split('(')[1].split()[0], float(row[10])
assert its_host == its_dev and diff <= 1e-6, (its_host, its_dev, diff)"
check "the pack traced cube60 on the device and the host, each within 4 se of MCX's 17.69708%" $PY -c "
rows = [l.split('|') for l in open('$T/stdout') if '% ±' in l]
assert len(rows) == 2 and rows[1][1].strip().startswith('host'), rows
for r in rows: assert abs(float(r[6])) <= 4 and float(r[4]) > 0, r"
finish
