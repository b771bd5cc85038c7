#!/usr/bin/env bash
# cli_blender_material.sh — the add-on leaves the artist's material alone,
# and a bake renders as it plays (tests/blender_material.py): Solve, Ctrl-Z,
# Show result, Remove ohm result, Live and a 20-frame Bake with a volume
# object in a headless Blender with the add-on; then the saved file reopened
# by a Blender WITHOUT the add-on (--factory-startup) renders frames 1, 10
# and 20 from the command line (-f), and the script checks the material and
# the renders' brightness against the light's power.  Skipped without
# Blender as cli_blender.sh is, and under the sanitizers (Blender's process
# is not ours to instrument).
set -eu
source "$(dirname "$0")/lib.sh" "$1"
require_blender_addon
mkdir -p "$T/out"
show() {  # the report's figures and problems, or the log's end
  if [ -s "$1" ]; then
    $PY -c 'import json,sys; r=json.load(open(sys.argv[1])); [print(k+":", r[k]) for k in r if k != "problems"]; [print("PROBLEM:", p) for p in r["problems"]]' "$1"
  else
    tail -20 "$T/stderr" >&2 || true; tail -20 "$T/stdout" >&2 || true
  fi
}
expect_exit 0 "blender: the artist's material, Solve, undo, Remove, Live, Bake" -- "$BLENDER" -b --factory-startup \
  --python-exit-code 1 -P tests/blender_material.py -- "$ZIP" samples/spot.obj "$T/out" "$T/material.json" material
show "$T/material.json"
if [ -s "$T/out/material.blend" ]; then
  # (the same user folders: no add-on was enabled there for this file, and --factory-startup enables none)
  expect_exit 0 "blender without the add-on: the saved file's frames 1, 10, 20 from the command line" -- \
    "$BLENDER" -b --factory-startup "$T/out/material.blend" -f 1,10,20 --python-exit-code 1 \
    -P tests/blender_material.py -- - - "$T/out" "$T/reopen.json" reopen
  show "$T/reopen.json"
else
  bad "the material run saved no material.blend"
fi
finish
