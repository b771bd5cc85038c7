# lib.sh — the little harness the cli_*.sh tests share.
# usage: source tests/lib.sh "$1"   (the ohm binary)
OHM=${1:?usage: $0 path/to/ohm}
PY=/usr/bin/python3     # Debian's python, where python3-openvdb lives
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
passed=0 failed=0
# SAFETY S: a limit that only ends a hang, never a slow run: S seconds on a
# plain build, 5x that under the sanitizers (a busy 2-core machine runs
# `ohm validate` in ~20 s plain and ~60 s under ASan)
SANITIZED=0
# (no grep -q: under pipefail its early exit would fail the pipeline by SIGPIPE)
if ldd "$OHM" 2>/dev/null | grep libasan >/dev/null; then SANITIZED=1; fi
SAFETY() { echo $(( $1 * (SANITIZED ? 5 : 1) )); }

ok()   { passed=$((passed + 1)); }
bad()  { failed=$((failed + 1)); echo "FAIL: $*" >&2; }
check() { local what=$1; shift; if "$@"; then ok; else bad "$what"; fi; }

# expect_exit CODE NAME -- command...: exit code, one-line error on stderr.
expect_exit() {
  local want=$1 name=$2; shift 3
  local out="$T/stdout" err="$T/stderr" got
  set +e; timeout "$(SAFETY 600)" "$@" >"$out" 2>"$err"; got=$?; set -e
  LAST_ERR=$(cat "$err")
  if [ "$got" != "$want" ]; then bad "$name: exit $got, expected $want; stderr: $(tail -3 "$err")"; return; fi
  ok
}
# expect_error_line NAME PATTERN: the last command printed exactly one
# "ohm: error:" line and it matches PATTERN (grep -E).
expect_error_line() {
  local name=$1 pat=$2 n
  n=$(grep -c '^ohm: error:' <<<"$LAST_ERR" || true)
  if [ "$n" != 1 ]; then bad "$name: expected one 'ohm: error:' line, got $n: $LAST_ERR"; return; fi
  if ! grep -E -q -- "$pat" <<<"$(grep '^ohm: error:' <<<"$LAST_ERR")"; then
    bad "$name: error line does not match /$pat/: $LAST_ERR"; return
  fi
  ok
}
# require_blender: BLENDER (OHM_BLENDER, default blender on PATH) is there,
# or the test prints "SKIP: blender not installed" and passes, unless CI=true
# or OHM_REQUIRE_BLENDER is set (to anything but 0), when it fails.
require_blender() {
  BLENDER=${OHM_BLENDER:-blender}
  if ! command -v "$BLENDER" >/dev/null 2>&1; then
    if [ "${CI:-}" = true ] || { [ -n "${OHM_REQUIRE_BLENDER:-}" ] && [ "$OHM_REQUIRE_BLENDER" != 0 ]; }; then
      bad "blender not installed ('$BLENDER' not found), but CI=true or OHM_REQUIRE_BLENDER is set"
      finish
      exit 1
    fi
    echo "SKIP: blender not installed"
    exit 0
  fi
}
finish() { echo "$passed passed, $failed failed"; [ "$failed" = 0 ]; }
# require_test_hooks WHAT: the OHM_TEST_* hooks are compiled in (CMake's
# OHM_TEST_HOOKS, which scripts/test.sh turns on), or WHAT is skipped with a
# note; under CI=true a build without them fails.
require_test_hooks() {
  [ "${OHM_HAVE_TEST_HOOKS:-0}" = 1 ] && return 0
  if [ "${CI:-}" = true ]; then bad "$1 needs the test hooks: configure with -DOHM_TEST_HOOKS=ON"; return 1; fi
  echo "SKIP: $1 (no test hooks in this build: configure with -DOHM_TEST_HOOKS=ON, as scripts/test.sh does)"
  return 1
}
# require_addon: the build's ohm_blender.zip (ZIP) in a Blender (BLENDER)
# whose user folders are fresh for this run (Blender keeps installed add-ons
# there); skipped under the sanitizers (Blender's own process is not ours to
# instrument) and without Blender (require_blender).
require_addon() {
  ZIP="$(dirname "$(realpath "$OHM")")/ohm_blender.zip"
  if [ "$SANITIZED" = 1 ]; then echo "SKIP: the Blender add-on under the sanitizers"; exit 0; fi
  require_blender
  check "the build made ohm_blender.zip" test -s "$ZIP"
  export BLENDER_USER_CONFIG="$T/config" BLENDER_USER_SCRIPTS="$T/scripts"
}
