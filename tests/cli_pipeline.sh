#!/usr/bin/env bash
# The action pipeline: help generated from the table, usage errors with
# suggestions (exit 2), and a pipeline file replaying the command line exactly.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# help lists every action of the table; help ACTION shows options + defaults
"$OHM" help >"$T/help" 2>&1
for a in read voxelize write stats; do check "help lists -$a" grep -q -- "-$a " "$T/help"; done
"$OHM" help voxelize >"$T/hv" 2>&1
check "help voxelize: dim with default 64" grep -Eq 'dim=<integer>.*default 64' "$T/hv"
check "help voxelize: voxel=" grep -q 'voxel=<number>' "$T/hv"
check "help voxelize: units choices" grep -q 'units=<mm|cm|m|in>.*default mm' "$T/hv"
expect_exit 0 "--help" -- "$OHM" --help
expect_exit 0 "--version" -- "$OHM" --version

# usage errors: exit 2, one line, name the culprit and suggest the fix
expect_exit 2 "misspelled option" -- "$OHM" -read file=samples/spot.obj -voxelize dimm=64
expect_error_line "misspelled option" "unknown option 'dimm'; did you mean 'dim'"
expect_exit 2 "misspelled action" -- "$OHM" -raed file=samples/spot.obj
expect_error_line "misspelled action" "unknown action '-raed'; did you mean '-read'"
expect_exit 2 "bad integer" -- "$OHM" -read file=samples/spot.obj -voxelize dim=sixty
expect_error_line "bad integer" "dim=sixty: expected a whole number from 1 to 4096"
expect_exit 2 "out of range" -- "$OHM" -read file=samples/spot.obj -voxelize dim=0
expect_error_line "out of range" "dim=0"
expect_exit 2 "bad enum" -- "$OHM" -read file=samples/spot.obj units=furlong
expect_error_line "bad enum" "expected one of mm\|cm\|m\|in"
expect_exit 2 "missing required" -- "$OHM" -read units=mm
expect_error_line "missing required" "-read needs file="
expect_exit 2 "not key=value" -- "$OHM" -read samples/spot.obj
expect_error_line "not key=value" "'samples/spot.obj' is not key=value"
expect_exit 2 "help for unknown action" -- "$OHM" help voxelise
expect_error_line "help for unknown action" "did you mean 'voxelize'"
expect_exit 2 "no actions" -- "$OHM"
expect_exit 2 "unknown command" -- "$OHM" rnu x.ohm
# a typo late in a chain fails before anything runs (no output written)
expect_exit 2 "late typo" -- "$OHM" -read file=samples/spot.obj -voxelize dim=16 -write file="$T/late.vdb" -stats fiel=x
check "late typo wrote nothing" test ! -e "$T/late.vdb"
# -light's options that do not go together: refused as parsed, before the
# steps ahead of it run (nothing written)
expect_exit 2 "environment orbit" -- "$OHM" -read file=samples/spot.obj -voxelize dim=8 -write file="$T/orbit.vdb" \
  -light type=environment orbit=4
expect_error_line "environment orbit" "argument 7: -light type=environment orbit=4: an environment light is all around"
check "environment orbit wrote nothing" test ! -e "$T/orbit.vdb"
expect_exit 2 "sky= on a lamp" -- "$OHM" -read file=samples/spot.obj -voxelize dim=8 -write file="$T/sky.vdb" \
  -light type=point pos=0,0,50 sky=samples/none.hdr
expect_error_line "sky= on a lamp" "argument 7: -light type=point sky=: sky= is an environment light's image"
check "sky= on a lamp wrote nothing" test ! -e "$T/sky.vdb"
# a step that needs what no step before it makes is a usage error of the
# chain, found before anything runs
expect_exit 2 "voxelize before read" -- "$OHM" -voxelize dim=8
expect_error_line "voxelize before read" "no mesh yet"

# a later step that cannot use an earlier step's result: found before any
# step runs (nothing written, the long solve never started), one line
# naming both steps, exit 2
head=(-read file=samples/ch2_2mm.nii.gz -voxelize dim=24 threshold=40 -material transfer=samples/mri-head.transfer
      -light type=directional dir=0,-1,0)
expect_exit 2 "render after a scan" -- "$OHM" "${head[@]}" -solve -write file="$T/head.vdb" -render file="$T/head.png"
expect_error_line "render after a scan" "argument 14: -render: needs the mesh the solution was computed on .*-read at argument 1 gave a volume"
check "render after a scan wrote nothing" test ! -e "$T/head.vdb"
check "render after a scan solved nothing" bash -c "! grep -q 'solved' <<<\"\$1\"" _ "$LAST_ERR"
cow=(-read file=samples/cow.obj size=40 -voxelize dim=12 -material preset=marble -light type=directional dir=0,-1,0)
expect_exit 2 "render after a light that follows the solve" -- "$OHM" "${cow[@]}" -solve -write file="$T/c.vdb" \
  -light type=point pos=0,60,0 -render file="$T/c.png"
expect_error_line "render after a light that follows the solve" \
  "argument 17: -render: no solution yet.*-light at argument 14 comes after -solve at argument 11"
check "stale render wrote nothing" test ! -e "$T/c.vdb"
expect_exit 2 "export after a new mesh" -- "$OHM" "${cow[@]}" -solve -read file=samples/spot.obj -export csv="$T/c.csv"
expect_error_line "export after a new mesh" "-export: nothing to export.*-read at argument 12 comes after -solve at argument 11"
check "export after a new mesh wrote nothing" test ! -e "$T/c.csv"
expect_exit 2 "solve after a new mesh" -- "$OHM" "${cow[@]}" -read file=samples/spot.obj -solve
expect_error_line "solve after a new mesh" "-solve: no voxel object.*-read at argument 11 comes after -voxelize at argument 4"
expect_exit 2 "export ply of a scan" -- "$OHM" "${head[@]}" -solve -export ply="$T/h.ply"
expect_error_line "export ply of a scan" "-export: ply=: no mesh to export .*-read at argument 1 gave a volume"
expect_exit 2 "transfer without a volume" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material transfer=samples/mri-head.transfer -light type=directional dir=0,-1,0 -solve
expect_error_line "transfer without a volume" "-solve: transfer= maps a volume's density.*-read at argument 1 gave a mesh"
expect_exit 2 "voxelize error= without a light" -- "$OHM" -read file=samples/cow.obj -voxelize error=0.05 \
  -material preset=marble -solve
expect_error_line "voxelize error= without a light" "-voxelize: error= probes the scene: it needs -material .* and -light"
# the steps a -voxelize error= waits for, written after it, count
expect_exit 0 "voxelize error= before its scene" -- "$OHM" --quiet -read file=samples/cow.obj size=40 \
  -voxelize error=0.3 max_dim=40 -material preset=marble -light type=directional dir=0,-1,0

# the same job from a pipeline file and from the command line: identical grids
cat >"$T/job.ohm" <<OHM
ohm-pipeline 1
# comments and blank lines are fine

read file=samples/cow.obj size="40"   # trailing comment
-voxelize dim=32
write file=$T/from_file.vdb
OHM
expect_exit 0 "pipeline file" -- "$OHM" run "$T/job.ohm"
expect_exit 0 "command line" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=32 -write file="$T/from_cli.vdb"
check "pipeline file == command line" $PY tests/vdb_inspect.py --same "$T/from_file.vdb" "$T/from_cli.vdb"

# pipeline file errors name file:line
printf 'ohm-pipeline 1\nread file=samples/cow.obj\nvoxelize dimm=3\n' >"$T/bad.ohm"
expect_exit 2 "pipeline typo" -- "$OHM" run "$T/bad.ohm"
expect_error_line "pipeline typo" "bad.ohm:3: -voxelize: unknown option 'dimm'; did you mean 'dim'"
printf 'read file=samples/cow.obj\n' >"$T/nohdr.ohm"
expect_exit 2 "pipeline without header" -- "$OHM" run "$T/nohdr.ohm"
expect_error_line "pipeline without header" "nohdr.ohm:1: expected the header line 'ohm-pipeline 1'"
printf 'ohm-pipeline 9\nread file=a.obj\n' >"$T/future.ohm"
expect_exit 2 "pipeline from the future" -- "$OHM" run "$T/future.ohm"
expect_error_line "pipeline from the future" "version 9 is newer"
printf 'ohm-pipeline 1\nread file="samples/cow.obj\n' >"$T/quote.ohm"
expect_exit 2 "unterminated quote" -- "$OHM" run "$T/quote.ohm"
expect_error_line "unterminated quote" "quote.ohm:2: unterminated"
expect_exit 1 "missing pipeline file" -- "$OHM" run "$T/nope.ohm"
expect_error_line "missing pipeline file" "nope.ohm: cannot open"
expect_exit 1 "pipeline is a directory" -- "$OHM" run "$T"
expect_error_line "pipeline is a directory" "is a directory"

# the bundled example pipeline parses (run from a scratch dir so out/ lands there)
check "bundled pipeline parses" grep -q '^ohm-pipeline 1' pipelines/spot.ohm

# -stats: JSON on stdout, with the stage fields
"$OHM" --quiet -read file=samples/spot.obj size=50 -voxelize dim=16 -stats >"$T/stats.json"
check "stats is JSON with cells and t_voxelize" $PY -c "
import json,sys; s=json.load(open('$T/stats.json'))
assert s['cells'] > 0 and s['t_voxelize'] >= 0 and s['mesh_scale_mm'] > 0, s
assert abs(s['interior_volume_mm3'] - s['mesh_volume_mm3']) < 0.1 * s['mesh_volume_mm3'], s"

finish
