#!/usr/bin/env bash
# Bad input through the real command: a one-line error naming the file and the
# place, exit 1, no crash, and an existing output file left untouched.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# An earlier result that every failing run below must leave byte-identical.
"$OHM" --quiet -read file=samples/spot.obj -voxelize dim=8 -write file="$T/keep.vdb" -stats file="$T/keep.json"
cp "$T/keep.vdb" "$T/keep.ref"
cp "$T/keep.json" "$T/keep.json.ref"

run_bad() { # NAME PATTERN MESH
  local name=$1 pat=$2 mesh=$3
  expect_exit 1 "$name" -- "$OHM" -read file="$mesh" -voxelize dim=8 -write file="$T/keep.vdb" -stats file="$T/keep.json"
  expect_error_line "$name" "$pat"
  check "$name: old output intact" cmp -s "$T/keep.vdb" "$T/keep.ref"
  check "$name: old stats intact" cmp -s "$T/keep.json" "$T/keep.json.ref"
}

: >"$T/empty.obj"
run_bad "empty file" "empty.obj: empty file" "$T/empty.obj"

# binary STL declaring 12 triangles, cut after 5
$PY - "$T/cut.stl" <<'PY'
import struct, sys
tris = [((0,0,0),(1,0,0),(0,1,0))] * 12
data = b"\0" * 80 + struct.pack("<I", len(tris))
for t in tris:
    data += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
open(sys.argv[1], "wb").write(data[:84 + 50 * 5 + 17])
PY
run_bad "truncated binary STL" "cut.stl: .*triangle 5" "$T/cut.stl"

# binary PLY whose face data stops early
$PY - "$T/cut.ply" <<'PY'
import struct, sys
v = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
f = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5)]
hdr = ("ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
       "property float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n").encode()
body = b"".join(struct.pack("<3f", *p) for p in v) + b"".join(struct.pack("<B3i", 3, *t) for t in f)
open(sys.argv[1], "wb").write(hdr + body)
PY
run_bad "truncated binary PLY" "cut.ply: .*(face 4|element)" "$T/cut.ply"

printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 9\n' >"$T/range.obj"
run_bad "face index out of range" "range.obj:6: .*9" "$T/range.obj"

printf 'OFF\n4 4 0\n0 0 0\n1 0 0\nnan 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n' >"$T/nan.off"
run_bad "NaN coordinate" "nan.off:5: .*nan" "$T/nan.off"

mkdir "$T/dir.obj"
# a folder is read as a stack of slices (docs/scans.md), whatever its name: one without
# images says so (the chain is a volume's, with threshold=, so that the
# chain's check lets the read run)
expect_exit 1 "directory instead of a file" -- "$OHM" -read file="$T/dir.obj" -voxelize dim=8 threshold=1
expect_error_line "directory instead of a file" "dir.obj: no DICOM files, DICOMDIR or .tif, .tiff or .png images in the folder"
run_bad "missing file" "nothere.obj: cannot open" "$T/nothere.obj"

# unwritable output: a missing directory, and a directory in the file's place
expect_exit 1 "unwritable path" -- "$OHM" -read file=samples/spot.obj -voxelize dim=8 -write file="$T/no/such/dir/x.vdb"
expect_error_line "unwritable path" "cannot write '$T/no/such/dir/x.vdb'"
mkdir "$T/taken.vdb"
expect_exit 1 "output is a directory" -- "$OHM" -read file=samples/spot.obj -voxelize dim=8 -write file="$T/taken.vdb"
expect_error_line "output is a directory" "is a directory"
expect_exit 1 "stats to a missing dir" -- "$OHM" -read file=samples/spot.obj -stats file="$T/no/such.json"
expect_error_line "stats to a missing dir" "cannot write '$T/no/such.json'"

# read-only directory: root ignores permissions, so only test as a normal user
if [ "$(id -u)" != 0 ]; then
  mkdir "$T/ro"; chmod 555 "$T/ro"
  expect_exit 1 "read-only dir" -- "$OHM" -read file=samples/spot.obj -voxelize dim=8 -write file="$T/ro/x.vdb"
  expect_error_line "read-only dir" "cannot write"
fi

# numbers at the edge of double (docs/bad-input.md): a direction whose length
# overflows is still a direction (the light must not vanish), and a zero one
# is refused naming the argument
expect_exit 0 "dir 1e308,1e308,1e308" -- "$OHM" -read file=samples/cow.obj -voxelize dim=12 -material preset=marble \
  -light type=directional dir=1e308,1e308,1e308 -solve -stats file="$T/far.json"
check "dir 1e308,1e308,1e308: the light reaches the object" $PY -c "
import json; s = json.load(open('$T/far.json')); assert s['power_in'] > 0, s['power_in']"
expect_exit 2 "dir 0,0,0" -- "$OHM" -light type=directional dir=0,0,0
expect_error_line "dir 0,0,0" "argument 1: -light dir=0,0,0 has no direction"
printf 'ohm-transfer 1\n0 1e300 1\n100 0.1 1\n' >"$T/huge.transfer"
expect_exit 1 "sigma_a 1e300 in a transfer function" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz \
  dims=64,48,57 type=u16 spacing=0.625 -voxelize dim=12 threshold=5000 -material transfer="$T/huge.transfer" \
  -light dir=0,-1,0 -solve -stats file="$T/keep.json"
expect_error_line "sigma_a 1e300 in a transfer function" "huge.transfer:2: column 2 \\(sigma_a\\) must be in"
check "sigma_a 1e300: old stats intact" cmp -s "$T/keep.json" "$T/keep.json.ref"

# one policy for lights that reach nothing, whatever their type: a warning
# naming the -light argument, and no light from them (the same powers as
# without them; a pencil beam that misses does not turn hybrid=auto's
# transport on either)
expect_exit 0 "lights that miss" -- "$OHM" -read file=samples/cow.obj -voxelize dim=12 -material preset=marble \
  -light type=pencil pos=1000,1000,1000 dir=0,0,1 -light dir=0,-1,0 -light type=spot pos=0,100,0 dir=0,1,0 angle=10 \
  -solve -stats file="$T/missing.json"
check "lights that miss: the pencil is named" \
  grep -q "warning: argument 7: -light type=pencil reaches no part of the object" "$T/stderr"
check "lights that miss: the spot is named" \
  grep -q "warning: argument 13: -light type=spot reaches no part of the object" "$T/stderr"
check "lights that miss: the directional one is not" bash -c "! grep -q 'argument 11: -light' '$T/stderr'"
expect_exit 0 "the light that reaches" -- "$OHM" -read file=samples/cow.obj -voxelize dim=12 -material preset=marble \
  -light dir=0,-1,0 -solve -stats file="$T/reaching.json"
check "lights that miss add nothing" $PY -c "
import json; a, b = (json.load(open('$T/' + n)) for n in ('missing.json', 'reaching.json'))
assert abs(a['power_in'] - b['power_in']) <= 1e-12 * b['power_in'], (a['power_in'], b['power_in'])
assert abs(a['power_absorbed'] - b['power_absorbed']) <= 1e-9 * b['power_absorbed'], (a, b)
assert a['lights_reaching_nothing'] == 2 and b['lights_reaching_nothing'] == 0
assert a['hybrid'] == 0 and 'mc_photons' not in a, a"
# a pencil that reaches still turns it on
expect_exit 0 "a pencil that reaches" -- "$OHM" -read file=samples/cow.obj -voxelize dim=12 -material preset=marble \
  -light type=pencil pos=0,1000,0 dir=0,-1,0 -solve photons=2e4 -stats file="$T/pencil.json"
check "a pencil that reaches: hybrid=auto traces it" $PY -c "
import json; a = json.load(open('$T/pencil.json'))
assert a['hybrid'] == 10 and a['mc_photons'] > 0 and a['lights_reaching_nothing'] == 0, a"

# an empty object: the warning and the error say why, naming the scan
expect_exit 1 "threshold above the scan" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 \
  type=u16 spacing=0.625 -voxelize dim=12 threshold=1e9 -material preset=marble -light dir=0,-1,0 -solve
expect_error_line "threshold above the scan" \
  "argument [0-9]+: -solve: the voxel object from samples/walnut_64x48x57_uint16.raw.gz is empty: no cell reaches"
check "threshold above the scan: the warning names the scan's range" \
  grep -q "walnut_64x48x57_uint16.raw.gz: no cell reaches threshold=1e+09 (the scan's values are 0 .. 16875)" "$T/stderr"
check "threshold above the scan: no word about meshes" bash -c "! grep -q 'inside the mesh' '$T/stderr'"

# all or nothing (docs/cli.md): a chain that writes and then fails leaves every
# file it wrote as it was, and creates none
expect_exit 1 "write, then a failing step" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -write file="$T/keep.vdb" -stats file="$T/fresh.json" -read file="$T/no-such.obj"
expect_error_line "write, then a failing step" "no-such.obj: cannot open"
check "write, then a failing step: the .vdb it wrote is the old one" cmp -s "$T/keep.vdb" "$T/keep.ref"
check "write, then a failing step: no new file" test ! -e "$T/fresh.json"
# a chain that reads back what it wrote finds it on disk
expect_exit 0 "write, then read it back" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material preset=marble -light dir=0,-1,0 -solve -write file="$T/back.vdb" -read file="$T/back.vdb" grid=density
check "write, then read it back: read" grep -q "read $T/back.vdb: " "$T/stderr"

# no temporary files are left behind by any failure
check "no temporaries left" test -z "$(find "$T" -name '.*.ohm-*')"
# and a successful overwrite does replace the file
expect_exit 0 "overwrite" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 -write file="$T/keep.vdb"
check "overwrite replaced the file" bash -c "! cmp -s '$T/keep.vdb' '$T/keep.ref'"

finish
