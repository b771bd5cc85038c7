#!/usr/bin/env bash
# The bad-input corpus (tests/data/corpus/MANIFEST.tsv): every file must make
# ohm stop (a 60 s safety limit, 5x under the sanitizers, catches hangs) with
# its expected exit code (1 or 2, never 0, never a signal) and exactly one
# "ohm: error:" line that names the file (and, for text formats, the line)
# and matches the manifest's regex. Inputs that need
# the file system (FIFO, directory, non-UTF-8 name, 5 MB pipeline, .vdb files
# with the wrong grids) are made here at run time.
set -eu
source "$(dirname "$0")/lib.sh" "$1"
export LC_ALL=C    # the non-UTF-8 file name below is plain bytes to grep
C=tests/data/corpus
M=$C/MANIFEST.tsv

# run_case NAME HOW FILE CODE REGEX [no-name]: run ohm on FILE as HOW says;
# check it. "no-name" skips the check that the error line names the file.
run_case() {
  local name=$1 how=$2 f=$3 want=$4 pat=$5 noname=${6:-} got cmd
  # every chain first writes a .vdb over an old file, then meets the bad
  # input: the run is all or nothing, so the old file must stay as it was
  local first=(-read file=samples/cow.obj -voxelize dim=8 -write "file=$T/kept.vdb")
  case $how in
    mesh)     cmd=("${first[@]}" -read "file=$f" -voxelize dim=8) ;;
    pipeline) cmd=(run "$f") ;;
    transfer) cmd=("${first[@]}" -material "transfer=$f") ;;
    raw:*)    local a=${how#raw:}; cmd=("${first[@]}" -read "file=$f" "dims=${a%%:*}" "type=${a#*:}") ;;
    nifti)    cmd=("${first[@]}" -read "file=$f" -voxelize dim=8 threshold=1) ;;
    vdb|scan) cmd=("${first[@]}" -read "file=$f") ;;
    *) bad "$name: unknown kind '$how' in the manifest"; return ;;
  esac
  echo old >"$T/kept.vdb"
  # a bomb's run also has its peak memory measured (BOMB_MB: its ceiling)
  local measure=(); [ -n "${BOMB_MB:-}" ] && measure=("$PY" tests/peak_rss.py "$T/rss")
  set +e; "${measure[@]}" timeout "$(SAFETY 60)" "$OHM" "${cmd[@]}" >"$T/out" 2>"$T/err" </dev/null; got=$?; set -e
  LAST_ERR=$(cat "$T/err")
  if [ "$got" = 124 ]; then bad "$name: timed out (hang) running: ohm ${cmd[*]}"; return; fi
  if [ "$got" -gt 128 ]; then bad "$name: killed by signal $((got - 128)) running: ohm ${cmd[*]}"; return; fi
  if [ "$want" = 0 ]; then
    if [ "$got" = 0 ]; then ok; else bad "$name: exit $got, expected 0: $(tail -2 "$T/err")"; fi
    return
  fi
  if [ "$got" != "$want" ]; then bad "$name: exit $got, expected $want: $(tail -3 "$T/err")"; return; fi
  ok
  expect_error_line "$name" "$pat"
  check "$name: the .vdb the run wrote before it failed is not in place" test "$(cat "$T/kept.vdb")" = old
  if [ -n "${BOMB_MB:-}" ]; then
    local kb; kb=$(cat "$T/rss")
    check "$name: peak memory $((kb / 1024)) MB, at most $BOMB_MB" test "$kb" -le $((BOMB_MB * 1024))
  fi
  [ "$noname" = no-name ] && return
  # the error line names the file by its basename
  local base; base=$(basename -- "$f")
  if ! grep -a '^ohm: error:' <<<"$LAST_ERR" | grep -a -F -q -- "$base"; then
    bad "$name: error line does not name '$base': $LAST_ERR"
  else ok; fi
}

# ---- the committed corpus --------------------------------------------------
n=0
while IFS=$'\t' read -r file how code pat note; do
  case $file in ''|'#'*) continue ;; esac
  n=$((n + 1))
  # exit 0 only for inputs the manifest documents as accepted
  case $code in 1|2) ;; 0) case $note in VALID-RUNS*|'KNOWN GAP'*) ;; *) bad "$file: exit 0 without a VALID-RUNS/KNOWN GAP note" ;; esac ;;
    *) bad "$file: manifest expects exit $code" ;; esac
  if [ ! -e "$C/$file" ]; then bad "$file: listed in the manifest but missing"; continue; fi
  nn=; case $note in '[no-name]'*) nn=no-name ;; esac
  # a bomb is refused before anything is allocated: ohm's own ~75 MB
  # (its libraries), the sanitizers' shadow memory on top
  bomb_mb=; case $note in bomb:*) bomb_mb=$((SANITIZED ? 1200 : 400)) ;; esac
  BOMB_MB=$bomb_mb run_case "$file" "$how" "$C/$file" "$code" "$pat" $nn
done <"$M"
check "the corpus has at least 50 files (has $n)" test "$n" -ge 50
# every committed file is in the manifest
for f in "$C"/*; do
  b=$(basename "$f")
  case $b in MANIFEST.tsv|generate.py) continue ;; esac
  check "$b is listed in MANIFEST.tsv" grep -q "^$(sed 's/[.[\*^$]/\\&/g' <<<"$b")	" "$M"
done

# ---- made at run time ---------------------------------------------------------
# a non-UTF-8 file name (Latin-1 "é"): broken, so it must fail, and name it
bad_name=$(printf 'caf\351.off')
head -c 30 "$C/trunc-4.off" >"$T/$bad_name"
run_case "non-UTF-8 name" mesh "$T/$bad_name" 1 ""

# a directory, under each reader
mkdir "$T/adir.obj" "$T/adir.ohm" "$T/adir.transfer" "$T/adir.nii" "$T/adir.vdb" "$T/adir.raw"
run_case "directory (mesh)" mesh "$T/adir.obj" 1 "adir\.obj"
run_case "directory (pipeline)" pipeline "$T/adir.ohm" 1 "adir\.ohm"
run_case "directory (transfer)" transfer "$T/adir.transfer" 1 "adir\.transfer"
run_case "directory (raw)" raw:4,4,4:u8 "$T/adir.raw" 1 "adir\.raw"
run_case "directory (vdb)" vdb "$T/adir.vdb" 1 "adir\.vdb"

# a FIFO with no writer: ohm must refuse it, not block in open()
for ext in obj ohm transfer nii raw vdb; do mkfifo "$T/fifo.$ext"; done
run_case "FIFO (mesh)" mesh "$T/fifo.obj" 1 "fifo\.obj"
run_case "FIFO (pipeline)" pipeline "$T/fifo.ohm" 1 "fifo\.ohm"
run_case "FIFO (transfer)" transfer "$T/fifo.transfer" 1 "fifo\.transfer"
run_case "FIFO (nifti)" nifti "$T/fifo.nii" 1 "fifo\.nii"
run_case "FIFO (raw)" raw:4,4,4:u8 "$T/fifo.raw" 1 "fifo\.raw"
run_case "FIFO (vdb)" vdb "$T/fifo.vdb" 1 "fifo\.vdb"

# a 5 MB pipeline: refused as too large, without parsing it
$PY - "$T/big.ohm" <<'PY'
import sys
line = "# " + "x" * 97 + "\n"
open(sys.argv[1], "w").write("ohm-pipeline 1\n" + line * (5 * 1024 * 1024 // len(line)) + "read file=samples/cow.obj\n")
PY
run_case "5 MB pipeline" pipeline "$T/big.ohm" 2 "big\.ohm.*(large|big|size)"

# .vdb files with the wrong grids: a vec3 grid only, and no grids at all
$PY - "$T/vec3.vdb" "$T/nogrids.vdb" <<'PY'
import sys, numpy, pyopenvdb as vdb
g = vdb.Vec3SGrid(); g.name = "velocity"
g.copyFromArray(numpy.ones((4, 4, 4, 3), dtype=numpy.float32))
vdb.write(sys.argv[1], grids=[g])
vdb.write(sys.argv[2], grids=[])
PY
run_case "vec3 .vdb" vdb "$T/vec3.vdb" 1 "vec3\.vdb"
# a grid whose transform has a zero or NaN voxel size (the 0.37 mm scale's
# doubles overwritten): OpenVDB's exception, named with the file (docs/bad-input.md)
$PY - "$T/zero-voxel.vdb" "$T/nan-voxel.vdb" <<'PY'
import struct, sys, numpy, pyopenvdb as vdb
g = vdb.FloatGrid(); g.name = "density"
g.copyFromArray(numpy.ones((4, 4, 4), dtype=numpy.float32))
g.transform = vdb.createLinearTransform(voxelSize=0.37)
vdb.write(sys.argv[1], grids=[g])
b = open(sys.argv[1], "rb").read()
scale = struct.pack("<d", 0.37)
assert b.count(scale) >= 3, b.count(scale)
open(sys.argv[1], "wb").write(b.replace(scale, struct.pack("<d", 0.0)))
open(sys.argv[2], "wb").write(b.replace(scale, struct.pack("<d", float("nan"))))
PY
run_case "zero voxel size .vdb" vdb "$T/zero-voxel.vdb" 1 "zero-voxel\.vdb: OpenVDB: ArithmeticError"
run_case "NaN voxel size .vdb" vdb "$T/nan-voxel.vdb" 1 "nan-voxel\.vdb: OpenVDB: ArithmeticError"
# a data error (exit 1), refused by the .vdb checker before OpenVDB reads it
run_case ".vdb with no grids" vdb "$T/nogrids.vdb" 1 "nogrids\.vdb: the file holds no grids"

# bombs that are not gzip streams (docs/bad-input.md): a .vdb with two voxels
# 1000 apart (its dense box, 10^9 voxels) and a PNG slice of 8192 x 8192
# zeros; both refused by the readers' budget before anything is allocated
mkdir -p "$T/stack-bomb"
$PY - "$T/far-apart.vdb" "$T/stack-bomb/s00.png" <<'PY'
import sys, pyopenvdb as vdb
from PIL import Image
g = vdb.FloatGrid(); g.name = "density"
a = g.getAccessor(); a.setValueOn((0, 0, 0), 1.0); a.setValueOn((999, 999, 999), 1.0)
vdb.write(sys.argv[1], grids=[g])
Image.new("L", (8192, 8192), 0).save(sys.argv[2])
PY
BOMB_MB=$((SANITIZED ? 1200 : 400)) run_case ".vdb bomb: two voxels far apart" vdb "$T/far-apart.vdb" 1 \
  "far-apart\.vdb: .*decompression bomb"
BOMB_MB=$((SANITIZED ? 1200 : 400)) run_case "slice-folder bomb: one 8192^2 PNG of zeros" scan "$T/stack-bomb" 1 \
  "stack-bomb: .*decompression bomb"

# slice folders (docs/scans.md): an empty one, one whose slices differ in size, and
# one with a slice that is not an image
mkdir -p "$T/stack-empty" "$T/stack-sizes" "$T/stack-junk"
$PY -c "
from PIL import Image
Image.new('L', (8, 6), 10).save('$T/stack-sizes/s00.png'); Image.new('L', (8, 7), 20).save('$T/stack-sizes/s01.png')
Image.new('L', (8, 6), 10).save('$T/stack-junk/s00.png')
open('$T/stack-junk/s01.png', 'wb').write(b'not a png at all')"
run_case "slice folder: empty" scan "$T/stack-empty" 1 "stack-empty: no DICOM files, DICOMDIR or .tif, .tiff or .png"
run_case "slice folder: sizes differ" scan "$T/stack-sizes" 1 "s01\.png: slice 1 is 8 x 7 pixels, expected 8 x 6"
run_case "slice folder: not an image" scan "$T/stack-junk" 1 "s01\.png: cannot read image"

# DICOM series that must be refused (tests/write_dicom.py, pydicom): a missing
# slice, a duplicated position, a slice turned, a file cut short, two series
# and none chosen, a DICOMDIR whose record points at a file that is gone; each
# names the folder or the slice
$PY -c "import numpy; numpy.arange(48, dtype='<i2').tofile('$T/vol.raw')"
dicom() { # dicom FOLDER OPTIONS...: a 4 x 3 x 4 volume as a series in T/FOLDER
  local dir=$1; shift
  $PY tests/write_dicom.py "$T/$dir" --raw "$T/vol.raw" --dims 4,3,4 --matrix=0.5,0,0,0,0,0.5,0,0,0,0,1,0 \
    --stored i16 "$@" || bad "$dir: tests/write_dicom.py failed"
}
dicom gap --case missing
run_case "DICOM: a missing slice" scan "$T/gap" 1 "gap: .*a missing slice"
dicom twice --case duplicate
run_case "DICOM: a duplicated position" scan "$T/twice" 1 "twice: .*duplicated slice"
dicom turned --case tilted
run_case "DICOM: one slice turned" scan "$T/turned" 1 "IM[0-9]+\.dcm: orientation .*one orientation"
dicom cut --case truncated
run_case "DICOM: a truncated slice" scan "$T/cut" 1 "IM[0-9]+\.dcm: data element \(7fe0,0010\) .* the file is truncated"
dicom two --prefix A
dicom two --prefix B
run_case "DICOM: two series, none chosen" scan "$T/two" 2 "two: 2 series here, choose one with series=UID"
dicom set --dicomdir
rm -f "$T/set/PT000000/ST000000/SE000000/IM000001"
run_case "DICOMDIR: a referenced file gone" scan "$T/set" 1 "DICOMDIR: record [0-9]+ references .*, which is missing"

finish
