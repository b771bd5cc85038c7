#!/usr/bin/env bash
# cli_devices.sh — `ohm devices` (docs/devices.md): the machine's OpenCL devices
# listed, each with its kernel test passed (PoCL's CPU device in CI); no
# runtime, and a runtime without a driver, each one error line and exit 1;
# a stray argument exit 2.  Then -solve solver=mg device=: refusals (no
# runtime, another solver), device=auto falling back to the host, and a
# solve on the first device with double precision against the host's.  Without an OpenCL device this prints SKIP,
# unless CI=true or OHM_REQUIRE_OPENCL is set (tests/test_device.c too).
set -eu
source "$(dirname "$0")/lib.sh" "$1"

expect_exit 1 "no runtime" -- env OHM_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1 "$OHM" devices
expect_error_line "no runtime" "no OpenCL runtime: /nonexistent/libOpenCL.so.1 cannot be loaded .*install"
mkdir -p "$T/vendors"
expect_exit 1 "no driver" -- env OCL_ICD_VENDORS="$T/vendors" "$OHM" devices
expect_error_line "no driver" "found no device: install a driver"
expect_exit 2 "a stray argument" -- "$OHM" devices fast
expect_error_line "a stray argument" "devices: unexpected 'fast'"

# -solve device=: a solve on a device that is not there is one line, and
# nothing is written; device= with another solver that traces no photons
# is a usage error;
# device=auto without a GPU, or on a grid too small to pay for one, runs
# on the host
SCENE=(-read file=samples/spot.obj size=50 -material preset=skin1 -voxelize dim=24
       -light type=point pos=100,40,40 intensity=100)
expect_exit 2 "device= with solver=direct" -- "$OHM" "${SCENE[@]}" -solve solver=direct device=gpu
expect_error_line "device= with solver=direct" "device=gpu runs solver=mg's solve and traced photons \\(solver=mc, hybrid=\\); solver=direct traces none here and runs on the host"
expect_exit 1 "device=gpu without a runtime" -- env OHM_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1 \
  "$OHM" "${SCENE[@]}" -solve solver=mg device=gpu -write file="$T/none.vdb"
expect_error_line "device=gpu without a runtime" "no OpenCL runtime"
check "nothing written after a refused device" test ! -e "$T/none.vdb"
expect_exit 0 "device=auto without a runtime: the host" -- env OHM_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1 \
  "$OHM" --verbose "${SCENE[@]}" -solve solver=mg device=auto -stats file="$T/auto.json"
check "device=auto on a grid too small to pay for a device: the host" \
  grep -q "device=auto: [0-9]* cells, fewer than 65536: the cycle runs on the host" "$T/stderr"
expect_exit 0 "solver=mc device=auto, few photons: the host" -- \
  "$OHM" --verbose "${SCENE[@]}" -solve solver=mc photons=2000 device=auto -stats file="$T/mcauto.json"
check "solver=mc device=auto, few photons: too few to pay for a device" \
  grep -q "monte carlo: device=auto: 2000 photons, fewer than 131072: they run on the host" "$T/stderr"
check "solver=mc device=auto, few photons: the stats say host" $PY -c "
import json; assert json.load(open('$T/mcauto.json'))['device'] == 'host'"
expect_exit 0 "solver=mc device=auto without a runtime: the host" -- env OHM_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1 \
  "$OHM" --verbose "${SCENE[@]}" -voxelize dim=8 -solve solver=mc photons=140000 device=auto
check "device=auto without a runtime says it runs on the host" \
  grep -q "monte carlo: device=auto: no GPU with double precision, it runs on the host" "$T/stderr"
check "device=auto without a runtime: the stats say host" $PY -c "
import json; assert json.load(open('$T/auto.json'))['device'] == 'host'"

set +e; "$OHM" devices >"$T/list" 2>"$T/err"; rc=$?; set -e
if [ "$rc" != 0 ] && grep -qE "no OpenCL runtime|found no device" "$T/err"; then
  if [ "${CI:-}" = true ] || { [ -n "${OHM_REQUIRE_OPENCL:-}" ] && [ "$OHM_REQUIRE_OPENCL" != 0 ]; }; then
    bad "no OpenCL device, but CI=true or OHM_REQUIRE_OPENCL is set: $(cat "$T/err")"
  else
    echo "SKIP: no OpenCL device: $(cat "$T/err")"
  fi
  finish; exit
fi
cat "$T/list"
check "ohm devices exits 0" test "$rc" = 0
check "device opencl:0 is listed with its memory and precision" \
  grep -qE "^opencl:0  .*(CPU|GPU), (fp64|no fp64), [0-9]+ compute units, [0-9.]+ GiB" "$T/list"
check "every device passed its kernel test" \
  test "$(grep -c "kernel test: ok, triad [0-9.]* GB/s" "$T/list")" = "$(grep -c "^opencl:" "$T/list")"

# the solve on the first device with double precision: the same power as
# on the host (test_mg_scenes compares every cell)
dev=$(grep -m1 -oE "^opencl:[0-9]+ .*, fp64," "$T/list" | cut -d' ' -f1 || true)
if [ -n "$dev" ]; then
  expect_exit 0 "solve on $dev" -- "$OHM" "${SCENE[@]}" -solve solver=mg device="$dev" -stats file="$T/dev.json"
  expect_exit 0 "solve on the host" -- "$OHM" "${SCENE[@]}" -solve solver=mg -stats file="$T/host.json"
  check "$dev and the host: the same power out, the device named" $PY -c "
import json; d, h = (json.load(open('$T/%s.json' % w)) for w in ('dev', 'host'))
assert d['device'] != 'host' and h['device'] == 'host', (d['device'], h['device'])
assert abs(d['power_out'] - h['power_out']) <= 1e-9 * h['power_out'] and d['conservation_error'] < 1e-10, (d, h)"
  # solver=mc on the device: the photons there, the books exact, the power
  # out the host's within the two runs' noise (test_mc_device compares
  # every cell); a device that is not there is one line, nothing written
  MC=(-solve solver=mc photons=20000 seed=3)
  expect_exit 0 "solver=mc on $dev" -- "$OHM" "${SCENE[@]}" "${MC[@]}" device="$dev" -stats file="$T/mcdev.json"
  expect_exit 0 "solver=mc on the host" -- "$OHM" "${SCENE[@]}" "${MC[@]}" -stats file="$T/mchost.json"
  check "solver=mc on $dev and the host: the device named, the books exact, the same light out" $PY -c "
import json; d, h = (json.load(open('$T/%s.json' % w)) for w in ('mcdev', 'mchost'))
assert d['device'] != 'host' and h['device'] == 'host', (d['device'], h['device'])
assert d['conservation_error'] < 1e-10, d
assert abs(d['power_out'] / h['power_out'] - 1) < 0.03, (d['power_out'], h['power_out'])"
  # a solve keeps the device open across its frames and channels: one
  # opening for an orbit of 2 frames x 3 channels, for solver=mc and for
  # the hybrid's photons beside direct
  expect_exit 0 "solver=mc on $dev, 2 frames x 3 channels" -- "$OHM" --verbose "${SCENE[@]}" orbit=2 "${MC[@]}" \
    device="$dev" -stats file="$T/mcorbit.json"
  check "solver=mc on $dev opened the device once for 6 traces" test "$(grep -c "monte carlo: on " "$T/stderr")" = 1
  check "solver=mc on $dev: 6 traces' photons, the books exact" $PY -c "
import json; d = json.load(open('$T/mcorbit.json'))
assert d['mc_photons'] == 6 * 20000 and d['frames'] == 2 and d['conservation_error'] < 1e-10, d"
  expect_exit 1 "solver=mc on a device that is not there" -- \
    "$OHM" "${SCENE[@]}" "${MC[@]}" device=opencl:99 -write file="$T/mc99.vdb"
  expect_error_line "solver=mc on a device that is not there" "device=opencl:99: there are [0-9]+ OpenCL device"
  check "nothing written after solver=mc on a device that is not there" test ! -e "$T/mc99.vdb"
  # the tracer's published values on the device (ohm validate mc)
  expect_exit 0 "ohm validate mc device=$dev" -- "$OHM" validate mc photons=50000 device="$dev"
  check "ohm validate mc on $dev: the five published values pass" test "$(grep -c " pass$" "$T/stdout")" = 5
  # solver=direct with the hybrid's photons on the device: they ran there
  BEAM=(-read file=samples/spot.obj size=50 -material preset=skin1 -voxelize dim=24
        -light type=pencil pos=0,0,100 dir=0,0,-1 intensity=1)
  expect_exit 0 "solver=direct, the hybrid's photons on $dev" -- \
    "$OHM" --verbose "${BEAM[@]}" orbit=2 -solve hybrid=5 photons=20000 device="$dev" -stats file="$T/hyb.json"
  check "the hybrid's photons: the device opened once per channel's solve, not per frame" \
    test "$(grep -c "monte carlo: on " "$T/stderr")" -le 3
  check "solver=direct, the hybrid's photons on $dev: the device named, the books exact" $PY -c "
import json; d = json.load(open('$T/hyb.json'))
assert d['device'] != 'host' and d['hybrid'] == 5 and d['conservation_error'] < 1e-10, d"
  # a device too small for the hierarchy: refused before anything is copied
  if [ "${OHM_HAVE_TEST_HOOKS:-0}" = 1 ]; then
    expect_exit 1 "a device too small" -- env OHM_TEST_DEVICE_MEMORY_MB=1 \
      "$OHM" "${SCENE[@]}" -solve solver=mg device="$dev" -write file="$T/small.vdb"
    expect_error_line "a device too small" "the hierarchy needs [0-9.]+ GiB, more than 90% of the device's 0.00 GiB"
    check "nothing written after a device too small" test ! -e "$T/small.vdb"
    # kernels that do not build (a negative work-group size): one line with the compiler's words
    expect_exit 1 "kernels that do not build" -- env OHM_TEST_KERNEL_OPTIONS="-D WG=-1" \
      "$OHM" "${SCENE[@]}" -solve solver=mg device="$dev" -write file="$T/broken.vdb"
    expect_error_line "kernels that do not build" "a kernel failed to build for .*\\(CL_BUILD_PROGRAM_FAILURE\\): .*error"
    check "nothing written after kernels that do not build" test ! -e "$T/broken.vdb"
    # a device without double precision (mg), or without 64-bit atomics (mc)
    expect_exit 1 "a device without double precision" -- env OHM_TEST_DEVICE_LACKS=fp64 \
      "$OHM" "${SCENE[@]}" -solve solver=mg device="$dev" -write file="$T/nofp64.vdb"
    expect_error_line "a device without double precision" "has no double precision \\(cl_khr_fp64\\)"
    check "nothing written after a device without double precision" test ! -e "$T/nofp64.vdb"
    expect_exit 1 "solver=mc on a device without 64-bit atomics" -- env OHM_TEST_DEVICE_LACKS=atomics64 \
      "$OHM" "${SCENE[@]}" "${MC[@]}" device="$dev" -write file="$T/noatom.vdb"
    expect_error_line "solver=mc on a device without 64-bit atomics" "has no 64-bit atomics \\(cl_khr_int64_base_atomics\\)"
    check "nothing written after a device without 64-bit atomics" test ! -e "$T/noatom.vdb"
  fi
else
  bad "no device with double precision to solve on"
fi
finish
