#!/usr/bin/env bash
# cli_blender_addon.sh — the Blender add-on (blender/ohm_blender, installed
# from the build's ohm_blender.zip) in a headless Blender: Solve and Live
# relight (tests/blender_addon.py live), then Bake sequence and Solve's volume
# object (bake), then Solve and Live relight with solver=mg, and with the
# panel's default, Auto.  Skipped without Blender as cli_blender.sh is, and under the
# sanitizers (Blender's own process is not ours to instrument; the library
# code it calls is covered there by api_scene and api_python).
set -eu
source "$(dirname "$0")/lib.sh" "$1"
require_addon
# live and bake with the factor, then live with the multigrid (on the host,
# and on an OpenCL CPU device: PoCL) and with Auto (the panel's Solver and
# Device, OHM_ADDON_SOLVER and OHM_ADDON_DEVICE in the script)
for run in live bake live:mg live:mg:cpu live:auto; do
  mode=${run%%:*} solver=${run#*:} device=host
  [ "$solver" != "$run" ] || solver=direct
  case $solver in *:*) device=${solver#*:} solver=${solver%%:*} ;; esac
  mkdir -p "$T/$run"
  OHM_ADDON_SOLVER=$solver OHM_ADDON_DEVICE=$device expect_exit 0 "blender add-on: $mode, solver=$solver, device=$device" -- "$BLENDER" -b --factory-startup \
    --python-exit-code 1 -P tests/blender_addon.py -- "$ZIP" samples/spot.obj "$T/$run" "$T/$run.json" "$mode"
  mode=$run
  if [ -s "$T/$mode.json" ]; then
    $PY -c 'import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2]+":", {k: r[k] for k in r if k != "problems"}); [print("PROBLEM:", p) for p in r["problems"]]' "$T/$mode.json" "$mode"
  else
    tail -20 "$T/stderr" >&2 || true; tail -20 "$T/stdout" >&2 || true
  fi
done
finish
