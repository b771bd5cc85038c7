#!/usr/bin/env bash
# cli_blender_reports.sh — the Blender add-on's words and exposure, headless
# (tests/blender_reports.py): failures and warnings as Blender reports in the
# artist's words with no command-line syntax (reports), Live relight keeping
# its exposure so the light's power and colour show (live), and the default
# Suzanne at the default Scale showing light through its ears in Cycles
# (suzanne).  Skipped without Blender and under the sanitizers
# (lib.sh: require_blender_addon).
set -eu
source "$(dirname "$0")/lib.sh" "$1"
require_blender_addon
for mode in reports live suzanne; do
  mkdir -p "$T/$mode"
  expect_exit 0 "blender add-on's words: $mode" -- "$BLENDER" -b --factory-startup --python-exit-code 1 \
    -P tests/blender_reports.py -- "$ZIP" "$T/$mode" "$T/$mode.json" "$mode"
  if [ -s "$T/$mode.json" ]; then
    $PY -c 'import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2]+":", {k: r[k] for k in r if k != "problems"}); [print("PROBLEM:", p) for p in r["problems"]]' "$T/$mode.json" "$mode"
  else
    grep -E "PROBLEM|Error|Traceback" "$T/stdout" "$T/stderr" >&2 || true
  fi
done
grep -h "^SUZANNE" "$T/stdout" || true  # the last mode's
finish
