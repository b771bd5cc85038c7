#!/usr/bin/env bash
# Blender renders what ohm writes: pipelines/blender/render.py on spot (50 mm
# marble, dim 32) lit from +x (dir=-1,0,0), 64x64 pixels, 8 Cycles samples.
# Two Blender runs: the exitance render, which must show the object with its
# lit half (render.py puts it on the image's right) brighter than the far
# half, and a CONTROL with a grid name the file lacks, which must be reported
# and render black (so the image checks can fail).
#
# Blender is optional on a developer's machine: without it this prints
# "SKIP: blender not installed" and passes, unless CI=true or
# OHM_REQUIRE_BLENDER is set (to anything but 0), when it fails.
# OHM_BLENDER names another Blender binary (default: blender on PATH).
set -eu
source "$(dirname "$0")/lib.sh" "$1"

require_blender

GRIDS=surface,density,fluence_r,fluence_g,fluence_b,exitance_r,exitance_g,exitance_b
expect_exit 0 "write spot lit from +x" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=32 \
  -material preset=marble -light type=directional dir=-1,0,0 -solve \
  -write file="$T/spot.vdb" -stats file="$T/spot.json"
SCALE=$($PY -c 'import json,sys; print(repr(json.load(open(sys.argv[1]))["mesh_scale_mm"]))' "$T/spot.json") \
  || { bad "no mesh_scale_mm in spot.json"; finish; exit 1; }

# run_render NAME ARGS...: render.py in a factory-fresh background Blender,
# writing $T/NAME.png and $T/NAME.json. BL_RC is its exit code; the JSON is
# what the checks read.
run_render() {
  local name=$1; shift
  set +e
  timeout 120 "$BLENDER" -b --factory-startup --python-exit-code 3 \
    -P pipelines/blender/render.py -- --vdb "$T/spot.vdb" --mesh samples/spot.obj --scale-mm "$SCALE" \
    --light-dir -1,0,0 --size 64 64 --samples 8 --out "$T/$name.png" --json "$T/$name.json" "$@" \
    >"$T/$name.log" 2>&1
  BL_RC=$?
  set -e
  if [ ! -s "$T/$name.json" ]; then
    bad "blender wrote no $name.json (exit $BL_RC); its log ends: $(tail -5 "$T/$name.log")"
  fi
}

# Reads a PNG (8-bit RGB/RGBA, non-interlaced) with zlib alone, and prints
# the sum of (r+g+b)/3 over the image's left half, over its right half, the
# brightest pixel and the number of pixels brighter than 8/255.
cat >"$T/png_halves.py" <<'PY'
import struct, sys, zlib
def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and ctype in (2, 6) and interlace == 0, (depth, ctype, interlace)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    bpp = 3 if ctype == 2 else 4
    raw, stride, rows, prev = zlib.decompress(idat), w * bpp, [], bytearray(w * bpp)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], (prev[i - bpp] if i >= bpp else 0)
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line); prev = line
    return w, h, [[sum(r[x * bpp:x * bpp + 3]) / 3.0 for x in range(w)] for r in rows]
w, h, px = read_png(sys.argv[1])
left = sum(v for r in px for v in r[:w // 2])
right = sum(v for r in px for v in r[w - w // 2:])
print(w, h, left, right, max(max(r) for r in px), sum(1 for r in px for v in r if v > 8))
PY

# --- run 1: the exitance render -------------------------------------------
run_render good --grid exitance_r,exitance_g,exitance_b
check "blender exits 0 (exit $BL_RC)" test "$BL_RC" = 0
check "render: no grid error, the expected grids, an image" $PY - "$T/good.json" "$GRIDS" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
for p in d["problems"]:
    print("  problem: %s" % p, file=sys.stderr)
print("  Blender lists: %s; render %s s" % (", ".join(d.get("grids", [])), d.get("render_seconds")), file=sys.stderr)
assert d["ok"], "render.py says not ok"
assert d["is_loaded"] and d["error_message"] == "", d["error_message"]
assert sorted(d["grids"]) == sorted(sys.argv[2].split(",")), d["grids"]
assert d["missing_grids"] == [] and d["grid_used"] == ["exitance_r", "exitance_g", "exitance_b"]
assert abs(d["voxel_mm"] - 1.5625) < 1e-6 and d["offset_applied"] == [-d["voxel_mm"] / 2] * 3, d["offset_applied"]
assert d["camera"]["lit_side_in_image"] == "right"
assert len(d["images"]) == 1
PY
read -r W H LEFT RIGHT MAX NLIT < <($PY "$T/png_halves.py" "$T/good.png" || echo "0 0 0 0 0 0")
echo "  exitance render ${W}x$H: left (far) half $LEFT, right (lit) half $RIGHT, max $MAX, $NLIT pixels > 8/255" >&2
check "the image is 64x64" test "$W $H" = "64 64"
check "the image is not black (max $MAX, $NLIT lit pixels)" $PY -c "import sys; sys.exit(not ($MAX >= 64 and $NLIT >= 100))"
check "the lit half is brighter than the far half ($RIGHT vs $LEFT)" $PY -c "import sys; sys.exit(not ($RIGHT > 1.5 * $LEFT))"

# --- run 2: CONTROL, a grid the file lacks ----------------------------------
run_render control --grid no_such_grid
check "control: blender exits non-zero (exit $BL_RC)" test "$BL_RC" != 0 -a "$BL_RC" != 124
check "control: the missing grid is reported" $PY - "$T/control.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
assert not d["ok"] and d["missing_grids"] == ["no_such_grid"], (d["ok"], d.get("missing_grids"))
assert any("no_such_grid" in p for p in d["problems"]), d["problems"]
assert d["error_message"] == "" and len(d["images"]) == 1   # still renders, and says so
PY
read -r W H LEFT RIGHT MAX NLIT < <($PY "$T/png_halves.py" "$T/control.png" || echo "0 0 999 999 999 999")
echo "  control render ${W}x$H: max $MAX, $NLIT pixels > 8/255" >&2
check "control: the image is (near) black (max $MAX)" $PY -c "import sys; sys.exit(not ($W == 64 and $MAX <= 8 and $NLIT == 0))"

if [ "$failed" != 0 ]; then
  echo "blender logs:" >&2
  tail -n 20 "$T/good.log" "$T/control.log" >&2 || true
fi
finish
