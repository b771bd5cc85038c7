#!/usr/bin/env bash
# cli_light_environment.sh — the environment light (docs/lights.md) as each
# front end gives it: the same scene from the command line, from Python
# (python/ohm) and from the Blender add-on (the World's colour, then its
# Environment Texture's image; tests/blender_environment.py) gives the same
# fluence cell by cell (tests/light_environment_fronts.py).  Without Blender
# (or under the sanitizers, whose runtimes Blender's process does not load)
# the command line and Python are compared on the bundled cow, under a
# uniform sky.  Also: the POV-Ray scene carries the sky, the preview renders
# it, and bad sky= / orbit= fail in one line.
set -eu
source "$(dirname "$0")/lib.sh" "$1"
BUILD="$(dirname "$(realpath "$OHM")")"
export PYTHONPATH="$BUILD/python" OHM_CLI="$OHM"
# Debian's python loads a sanitized libohm only with the sanitizers' runtimes first
PYENV=()
if [ "$SANITIZED" = 1 ]; then
  PYENV=(env LD_PRELOAD="$(cc -print-file-name=libasan.so):$(cc -print-file-name=libubsan.so)" ASAN_OPTIONS=detect_leaks=0)
fi
names=""
BLENDER=${OHM_BLENDER:-blender}
if [ "$SANITIZED" = 0 ] && command -v "$BLENDER" >/dev/null 2>&1; then
  export BLENDER_USER_CONFIG="$T/config" BLENDER_USER_SCRIPTS="$T/scripts"
  expect_exit 0 "the add-on lights the object by the World" -- "$BLENDER" -b --factory-startup --python-exit-code 1 \
    -P tests/blender_environment.py -- "$BUILD/ohm_blender.zip" samples/cow.obj "$T"
  grep -E '^(colour|sky|blender_environment):' "$T/stdout" || tail -20 "$T/stderr" >&2
  names="colour sky"
else
  echo "(no Blender here: the command line against Python only)"
  cp samples/cow.obj "$T/mesh.obj"
  echo '{"type": "environment", "intensity": [8e-7, 5e-7, 3e-7]}' > "$T/colour.json"
  names="colour"
fi
for name in $names; do
  # the light's options as -light words
  read -r -a words < <($PY -c 'import json,sys
l = json.load(open(sys.argv[1]))
print(" ".join("%s=%s" % (k, ",".join(repr(float(x)) for x in v) if isinstance(v, list) else v) for k, v in l.items()))' "$T/$name.json")
  expect_exit 0 "$name: the command line solves it" -- "$OHM" -read file="$T/mesh.obj" -material preset=marble \
    -light "${words[@]}" -voxelize dim=24 -solve solver=direct shadows=mesh -export csv="$T/$name.csv"
done
expect_exit 0 "the command line, Python and the add-on agree" -- "${PYENV[@]}" $PY tests/light_environment_fronts.py "$T" $names
cat "$T/stdout"

# the preview and the POV-Ray scene
expect_exit 0 "render and export under a sky" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=24 \
  -material preset=marble -light type=environment intensity=0.001 -solve shadows=mesh \
  -render file="$T/env.png" size=64,48 compare=1 -export df3="$T/env"
check "the preview was written" test -s "$T/env.png"
check "the POV-Ray scene has the sky" grep -q 'sky_sphere { pigment { rgb <0.001, 0.001, 0.001> }' "$T/env.pov"

# bad input: one line naming the option
echo "not an image" > "$T/bad.exr"
expect_exit 1 "sky= that is not an image" -- "$OHM" -light type=environment sky="$T/bad.exr"
expect_error_line "sky= that is not an image" "sky=.*bad.exr"
expect_exit 2 "orbit= on an environment" -- "$OHM" -read file=samples/cow.obj -light type=environment orbit=4
expect_error_line "orbit= on an environment" "orbit=4.*environment"
finish
