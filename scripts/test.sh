#!/usr/bin/env bash
# The README's second command (and what CI runs): install what is missing,
# build with warnings as errors, run the whole test suite; then build again
# with AddressSanitizer + UndefinedBehaviorSanitizer and run it again.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

scripts/install-deps.sh

echo "== build (warnings are errors) =="
# Release, as the README's first command (scripts/demo.sh) builds: -O3 is where
# -Wmaybe-uninitialized speaks, and a newcomer's first build must print nothing
cmake -S . -B build-test -DOHM_WERROR=ON -DOHM_TEST_HOOKS=ON -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build-test -j"$jobs"
echo "== tests =="
ctest --test-dir build-test --output-on-failure -j"$jobs"

echo "== build with ASan + UBSan =="
cmake -S . -B build-asan -DOHM_WERROR=ON -DOHM_SANITIZE=ON -DOHM_TEST_HOOKS=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build-asan -j"$jobs"
echo "== tests under ASan + UBSan =="
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp
ctest --test-dir build-asan --output-on-failure -j"$jobs"
