#!/usr/bin/env bash
# addon-window.sh — the Blender add-on in a real window under Xvfb (docs/blender.md):
# a Solve's main-thread gaps, Blender's own redraw time, a cancel inside the
# factorization, Esc (a real key press, by xdotool) while voxelizing, Live
# relight's rate with and without a 3D view, and the artist's material
# through Solve, Ctrl-Z, Bake, renders and Remove.  Prints the figures
# docs/blender.md quotes ("The add-on in a real window").  Needs xvfb-run
# (Debian's xvfb), xdotool and ImageMagick.  About 3 minutes.  With "words":
# instead, the add-on's messages and Live relight's exposure
# (scripts/addon-window-words.py), its screenshots and render in OUT
# (default /tmp/ohm-window-words).
#   scripts/addon-window.sh [build]        SOLVE_DIM=112 LIVE_DIM=60
#   scripts/addon-window.sh build words [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
export BLENDER_USER_CONFIG="$T/config" BLENDER_USER_SCRIPTS="$T/scripts"
blender -b --factory-startup --python-expr "
import bpy
bpy.ops.preferences.addon_install(filepath='$PWD/$BUILD/ohm_blender.zip', overwrite=True)
bpy.ops.preferences.addon_enable(module='ohm_blender')
bpy.context.preferences.view.show_splash = False
bpy.ops.wm.save_userpref()" > "$T/install.log" 2>&1 || { tail "$T/install.log"; exit 1; }
if [ "${2:-}" = words ]; then
  xvfb-run -a -s "-screen 0 1280x800x24" blender -P scripts/addon-window-words.py -- "${3:-/tmp/ohm-window-words}" \
    2>&1 | grep -E "^(WORDS|Traceback|Error)"
  exit 0
fi
window() { xvfb-run -a -s "-screen 0 1280x800x24" blender -P scripts/addon-window.py -- "$@" 2>&1 \
  | grep -E "^(SOLVE|REDRAW|CANCEL|ESC|GAPS|MAIN THREAD|LIVE|MATERIAL|SHOT|PROBLEM|Error)"; }
window solve "${SOLVE_DIM:-112}" || true  # Blender exits 1 after the real Esc it was sent
window live "${LIVE_DIM:-60}"
NO3D=1 window live "${LIVE_DIM:-60}"
# screenshots and renders in ${OHM_WINDOW_OUT:-/tmp/ohm-window}; this Blender exits 1
# after its real Esc press (runs without the Esc exited 0): its lines say how it went
window material 0 || true
