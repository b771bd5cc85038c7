#!/usr/bin/env bash
# gpu-pack.sh — the benchmark that travels (docs/devices.md): a folder
# to copy to a GPU machine that has the vendor's OpenCL library but none of
# ohm's packages, and perhaps no ICD loader or vendors folder.  It holds
#   ohm-gpu-bench   tests/bench_device.c built on libc and libm alone
#   libOpenCL.so.1  Debian's ICD loader (ocl-icd), loaded by ohm at run time
#   vendors/        nvidia.icd: one line, the NVIDIA driver's OpenCL library
#   run.sh          `ohm devices`, then solver=mg on the device against the
#                   host's cores on the block medium (10^6, 10^7, 10^8 cells),
#                   then the Monte Carlo tracer on MCX's cube60 (10^8 photons
#                   on the device, 10^6 on the host)
# run.sh prints the Markdown that scripts/gpu-bench.sh writes to docs/gpu.md.
#   scripts/gpu-pack.sh [BUILD_DIR]      -> BUILD_DIR/gpu-pack
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
cmake --build "$BUILD" --target ohm-gpu-bench >/dev/null
PACK="$BUILD/gpu-pack"
rm -rf "$PACK"
mkdir -p "$PACK/vendors"
cp "$BUILD/ohm-gpu-bench" "$PACK/"
loader=$(readlink -f /usr/lib/x86_64-linux-gnu/libOpenCL.so.1 2>/dev/null || true)
[ -f "$loader" ] || { echo "gpu-pack: no libOpenCL.so.1 here (install ocl-icd-libopencl1)" >&2; exit 1; }
cp "$loader" "$PACK/libOpenCL.so.1"
echo "libnvidia-opencl.so.1" > "$PACK/vendors/nvidia.icd"
cat > "$PACK/run.sh" <<'RUN'
#!/bin/sh
# ohm's travelling GPU benchmark: DEVICE (default gpu) and SIZES (default
# 100 216 464: 1e6, 1e7, 1e8 cells; 464 needs ~30 GB of host memory), then
# cube60 with PHOTONS on the device (default 1e8) and HOST_PHOTONS on the
# host (default 1e6).
# The machine's own vendors folder is used when it has one, else ours.
set -e
cd "$(dirname "$0")"
export OHM_OPENCL_LIBRARY="$PWD/libOpenCL.so.1"
if [ -z "${OCL_ICD_VENDORS:-}" ] && ! ls /etc/OpenCL/vendors/*.icd >/dev/null 2>&1; then
  export OCL_ICD_VENDORS="$PWD/vendors"
fi
echo "## $(uname -n), $(date -u +%F), $(nproc) host cores"
echo
echo '```'
./ohm-gpu-bench devices
echo '```'
echo
./ohm-gpu-bench "${DEVICE:-gpu}" ${SIZES:-100 216 464}
echo
./ohm-gpu-bench "${DEVICE:-gpu}" mc ${PHOTONS:-1e8} ${HOST_PHOTONS:-1e6}
RUN
chmod +x "$PACK/run.sh"
echo "gpu-pack: $PACK ($(du -sh "$PACK" | cut -f1)): ohm-gpu-bench needs $(ldd "$PACK/ohm-gpu-bench" | awk '/=>/{print $1}' | tr '\n' ' ')"
