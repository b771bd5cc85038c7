#!/usr/bin/env bash
# cli_devices.sh — `ohm devices` (issue 37): the machine's OpenCL devices
# listed, each with its kernel test passed (PoCL's CPU device in CI); no
# runtime, and a runtime without a driver, each one error line and exit 1;
# a stray argument exit 2.  Without an OpenCL device this prints SKIP,
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
finish
