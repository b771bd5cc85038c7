#!/usr/bin/env bash
# Blender opens what ohm writes: the grids it lists, where it puts the object
# and how big, and a frame sequence NAME_0001.vdb .. NAME_0004.vdb, checked
# against OpenVDB's own Python module (pyopenvdb). Two Blender runs in all:
# one that must pass, one of controls that must fail (so the checks can fail).
# See docs/blender.md for what these checks found.
#
# Blender is optional on a developer's machine: without it this prints
# "SKIP: blender not installed" and passes, unless CI=true or
# OHM_REQUIRE_BLENDER is set (to anything but 0), when it fails.
# OHM_BLENDER names another Blender binary (default: blender on PATH).
set -eu
source "$(dirname "$0")/lib.sh" "$1"

require_blender

check "pyopenvdb imports" $PY -c 'import pyopenvdb'
GRIDS=surface,density,fluence_r,fluence_g,fluence_b,exitance_r,exitance_g,exitance_b
BASE=(-read file=samples/spot.obj size=50 -voxelize dim=32)
LIT=(-material preset=marble)

# One lit, solved object; the same object unsolved (surface and density only).
expect_exit 0 "write spot" -- "$OHM" "${BASE[@]}" "${LIT[@]}" -light type=directional dir=0,-1,-1 -solve -write file="$T/spot.vdb" -stats file="$T/spot.json"
expect_exit 0 "write plain" -- "$OHM" "${BASE[@]}" -write file="$T/plain.vdb"

# A 4-frame sequence as ohm writes one: -light orbit=4 turns the light about
# the object (y axis) and -write emits spot_0001.vdb .. spot_0004.vdb. An ohm
# without orbit= gets the same names from one run per frame.
mkdir -p "$T/seq" "$T/gap"
if "$OHM" help light | grep -q 'orbit='; then
  expect_exit 0 "write an orbit of 4 frames" -- "$OHM" "${BASE[@]}" "${LIT[@]}" \
    -light type=directional dir=0,-1,-1 orbit=4 -solve -write file="$T/seq/spot.vdb"
  check "orbit=4 writes exactly spot_0001..0004.vdb" test "$(cd "$T/seq" && echo *)" = "spot_0001.vdb spot_0002.vdb spot_0003.vdb spot_0004.vdb"
else
  n=0
  for dir in 0,-1,-1 -1,-1,0 0,-1,1 1,-1,0; do
    n=$((n + 1))
    expect_exit 0 "write frame $n" -- "$OHM" "${BASE[@]}" "${LIT[@]}" -light type=directional dir=$dir -solve \
      -write file="$T/seq/spot_$(printf %04d $n).vdb"
  done
fi
# controls: a sequence with frame 3 missing, and a file that is not a VDB
cp "$T/seq/spot_0001.vdb" "$T/seq/spot_0002.vdb" "$T/seq/spot_0004.vdb" "$T/gap/" || bad "no sequence to copy"
printf 'ohm: this is not a VDB file\n' >"$T/text.vdb"

# run_blender JSON ARGS...: import_check.py in a factory-fresh background
# Blender. BL_RC is its exit code; the JSON file is what the checks read.
run_blender() {
  local json=$1; shift
  set +e
  timeout 120 "$BLENDER" -b --factory-startup --python-exit-code 3 \
    -P pipelines/blender/import_check.py -- "$@" --json "$json" >"$json.log" 2>&1
  BL_RC=$?
  set -e
  if [ ! -s "$json" ]; then
    bad "blender wrote no $json (exit $BL_RC); its log ends: $(tail -5 "$json.log")"
  fi
}

# --- run 1: what must work ------------------------------------------------
run_blender "$T/good.json" \
  --vdb "$T/spot.vdb" --expect-grids "$GRIDS" --mesh density:0.5 \
  --vdb "$T/seq/spot_0001.vdb" --sequence --expect-grids "$GRIDS" --mesh fluence_r:0.5
check "blender exits 0 on ohm's files (exit $BL_RC; see problems below)" test "$BL_RC" = 0
check "blender reports no problem" $PY - "$T/good.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
for c in d["checks"]:
    for p in c["problems"]:
        print("  %s: %s" % (c["vdb"], p), file=sys.stderr)
assert d["ok"] and len(d["checks"]) == 2, "import_check says not ok"
PY

# The single file: grids, types, transform, and the object's box.
check "single file: grids, transform and place" $PY - "$T/good.json" "$T/spot.vdb" "$GRIDS" <<'PY'
import json, sys
import pyopenvdb as vdb
d = json.load(open(sys.argv[1]))
c = d["checks"][0]
want = sys.argv[3].split(",")
assert c["is_loaded"], "grids not loaded"
assert c["error_message"] == "", c["error_message"]
names = [g["name"] for g in c["grids"]]
assert sorted(names) == sorted(want) and len(names) == len(want), ("grids", names)
assert c["missing_grids"] == [] and c["unexpected_grids"] == []
for g in c["grids"]:
    assert g["data_type"] == "FLOAT" and g["channels"] == 1, g
# the import operator put the object at the world origin, unrotated, scale 1
for i in range(4):
    for j in range(4):
        assert abs(c["matrix_world"][i][j] - (i == j)) < 1e-9, c["matrix_world"]

grids = {g.name: g for g in vdb.readAll(sys.argv[2])[0]}
h = grids["density"].transform.voxelSize()[0]
for g in c["grids"]:
    vg = grids[g["name"]]
    o = vg.transform.indexToWorld((0, 0, 0))
    M = g["matrix_object"]          # index -> object, row-major
    for i in range(3):
        assert abs(M[i][i] - h) < 1e-6 * h, ("voxel size", g["name"], M)
        assert abs(M[i][3] - o[i]) < 1e-4, ("origin", g["name"], M, o)

def box(lo, hi, g, pad):
    a, b = g.transform.indexToWorld(lo), g.transform.indexToWorld(hi)
    return [x - pad for x in a], [x + pad for x in b]

def union(boxes):
    return ([min(b[0][i] for b in boxes) for i in range(3)],
            [max(b[1][i] for b in boxes) for i in range(3)])

bl = c["bbox_world"]
# Blender 3.4's bound_box is the union over grids of each grid's *leaf-node*
# box (evalLeafBoundingBox: whole 8^3 blocks), whose integer corners go
# through indexToWorld: OpenVDB index points, i.e. cell centres. So it is
# leaf-aligned, and half a voxel inside the faces of the outermost voxels.
# Predict exactly that from pyopenvdb:
lo, hi = union([box(*g.evalLeafBoundingBox(), g, 0.0) for g in grids.values()])
for i in range(3):
    assert abs(bl["min"][i] - lo[i]) < 1e-3 and abs(bl["max"][i] - hi[i]) < 1e-3, \
        ("bound_box is not the leaf box", bl, lo, hi)
# ... and the .vdb's world extent (faces of the active voxels, all grids)
# lies inside that box, once the half voxel between a centre and its face
# is allowed for; the box overshoots by less than one 8-voxel leaf.
elo, ehi = union([box(*g.evalActiveVoxelBoundingBox(), g, 0.5 * h) for g in grids.values()])
for i in range(3):
    assert bl["min"][i] - 0.5 * h - 1e-3 <= elo[i] <= bl["min"][i] + 8 * h, (i, bl, elo)
    assert bl["max"][i] - 8 * h <= ehi[i] <= bl["max"][i] + 0.5 * h + 1e-3, (i, bl, ehi)
PY

# The object itself, to within a voxel: Blender's Volume to Mesh of the
# density (1 inside, 0 outside; the 0.5 level is the cells' faces) against
# the density's world extent from pyopenvdb, and against OpenVDB's own
# volumeToMesh of the same grid.
check "single file: Blender's density surface is where the voxels and the mesh are" $PY - "$T/good.json" "$T/spot.vdb" "$T/spot.json" <<'PY'
import json, sys
import pyopenvdb as vdb
d = json.load(open(sys.argv[1]))
c = d["checks"][0]
g = vdb.read(sys.argv[2], "density")
h = g.transform.voxelSize()[0]
m = c["mesh"]
pts, quads = g.convertToQuads(0.5)
assert m["vertices"] == len(pts), ("vertex count", m["vertices"], len(pts))
# Half-voxel offset. OpenVDB puts voxel (i,j,k)'s value at index point
# (i,j,k), the cell centre. Blender 3.4 renders it as the cell [i,i+1] in
# index space (EEVEE's and Cycles' texture-to-object matrices have no -1/2),
# and its Volume to Mesh adds voxel_size/2 to every vertex OpenVDB returns
# "to align the mesh with the volume" (volume_to_mesh.cc, T85312). Measure
# that shift here: h/2 on every axis for Blender 3.x; a later Blender that
# drops it would show 0.
shift = [m["min"][i] - float(pts[:, i].min()) for i in range(3)] + \
        [m["max"][i] - float(pts[:, i].max()) for i in range(3)]
s = shift[0]
assert all(abs(x - s) < 1e-3 for x in shift), ("shift not uniform", shift)
if d["blender"].startswith("3."):
    assert abs(s - 0.5 * h) < 1e-3, ("expected the half-voxel shift of Blender 3.x", s, h)
else:
    assert abs(s) < 1e-3 or abs(s - 0.5 * h) < 1e-3, ("unknown shift", s, h)
print("  Blender's volume-to-mesh shift: %+.5f mm = %+.3f voxel (voxel %.4f mm)" % (s, s / h, h), file=sys.stderr)
# with the shift taken out, the surface spans the density's voxels to
# within one voxel on every side
lo, hi = g.evalActiveVoxelBoundingBox()
wlo = [x - 0.5 * h for x in g.transform.indexToWorld(lo)]
whi = [x + 0.5 * h for x in g.transform.indexToWorld(hi)]
for i in range(3):
    assert abs(m["min"][i] - s - wlo[i]) <= h, ("min", i, m["min"], wlo)
    assert abs(m["max"][i] - s - whi[i]) <= h, ("max", i, m["max"], whi)
# and that is where the mesh is: samples/spot.obj's vertices times ohm's
# mm per unit, 50 mm along the longest axis, in Blender units (1 BU = 1 mm)
scale = json.load(open(sys.argv[3]))["mesh_scale_mm"]
vs = [[float(t) * scale for t in l.split()[1:4]] for l in open("samples/spot.obj") if l.startswith("v ")]
for i in range(3):
    lo_i, hi_i = min(v[i] for v in vs), max(v[i] for v in vs)
    assert abs(m["min"][i] - s - lo_i) <= h and abs(m["max"][i] - s - hi_i) <= h, \
        ("not where the mesh is", i, m["min"][i] - s, m["max"][i] - s, lo_i, hi_i)
ext = max(m["max"][i] - m["min"][i] for i in range(3))
assert abs(ext - 50.0) <= 2 * h, ("size in Blender units", ext)
PY

# The sequence: Blender's own detection sees 4 frames; frame k reads file
# _000k, shown by its path and by its values (Volume to Mesh of fluence_r at
# 0.5 matches OpenVDB's volumeToMesh of that file, and not the other frames).
check "sequence: 4 frames, frame k loads _000k" $PY - "$T/good.json" "$T/seq" "$GRIDS" <<'PY'
import json, os, sys
import pyopenvdb as vdb
c = json.load(open(sys.argv[1]))["checks"][1]
want = sorted(sys.argv[3].split(","))
v = c["volume"]
assert v["is_sequence"] and c["frames_seen"] == 4, ("frames seen", c["frames_seen"], v)
assert v["frame_start"] == 1 and v["frame_offset"] == 0 and v["sequence_mode"] == "CLIP", v
fr = {f["frame"]: f for f in c["frames"]}
assert sorted(fr) == [0, 1, 2, 3, 4, 5], sorted(fr)
# with the default 'Clip' mode, frames before 1 and after 4 show nothing
assert not fr[0]["grid_names"] and not fr[5]["grid_names"], (fr[0]["grid_names"], fr[5]["grid_names"])
assert c["frames_loaded"] == 4, c["frames_loaded"]
expect = {}
for k in range(1, 5):
    path = os.path.join(sys.argv[2], "spot_%04d.vdb" % k)
    f = fr[k]
    assert os.path.samefile(f["frame_filepath"], path), (k, f["frame_filepath"])
    assert f["is_loaded"] and f["error_message"] == "", (k, f["error_message"])
    assert sorted(f["grid_names"]) == want, (k, f["grid_names"])
    g = vdb.read(path, "fluence_r")
    h = g.transform.voxelSize()[0]
    pts, _ = g.convertToQuads(0.5)
    expect[k] = (len(pts), [float(pts[:, i].min()) + 0.5 * h for i in range(3)] +
                           [float(pts[:, i].max()) + 0.5 * h for i in range(3)])
def mbox(f):
    return f["mesh"]["min"] + f["mesh"]["max"]
for k in range(1, 5):
    n, b = expect[k]
    assert fr[k]["mesh"]["vertices"] == n, (k, fr[k]["mesh"]["vertices"], n)
    assert max(abs(x - y) for x, y in zip(mbox(fr[k]), b)) < 1e-3, (k, mbox(fr[k]), b)
# the check tells frames apart: frame 3's surface is more than a voxel away
# from each other file's
for k in (1, 2, 4):
    assert max(abs(x - y) for x, y in zip(mbox(fr[3]), expect[k][1])) > h, ("frame 3 looks like file", k)
PY

# --- run 2: controls, each must be reported --------------------------------
run_blender "$T/bad.json" \
  --vdb "$T/plain.vdb" --expect-grids "$GRIDS" \
  --vdb "$T/text.vdb" --expect-grids surface,density \
  --vdb "$T/gap/spot_0001.vdb" --sequence --expect-grids "$GRIDS"
check "blender exits non-zero on the controls (exit $BL_RC)" test "$BL_RC" != 0 -a "$BL_RC" != 124
check "controls: missing grids, not a VDB, a gap in the sequence" $PY - "$T/bad.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
assert not d["ok"]
plain, text, gap = d["checks"]
# an unsolved file has no solution grids: reported as missing, not as an error
assert not plain["ok"] and plain["is_loaded"] and plain["error_message"] == "", plain
assert sorted(plain["missing_grids"]) == sorted(
    ["fluence_r", "fluence_g", "fluence_b", "exitance_r", "exitance_g", "exitance_b"]), plain["missing_grids"]
assert any("missing grids" in p for p in plain["problems"]), plain["problems"]
# not a VDB: Blender's own error message comes through
assert not text["ok"] and "not a VDB" in text["error_message"], text.get("error_message")
# frames 1, 2, 4: Blender 3.4 makes one object of frames 1-2 and drops 4
assert not gap["ok"] and gap["frames_seen"] == 2, (gap["objects"], gap.get("frames_seen"))
assert any("sees 2 frames of 3 files" in p for p in gap["problems"]), gap["problems"]
PY

# Precision: EEVEE always uploads volumes as half floats (Cycles in this
# build reads full floats). Half floats flush values below ~6e-8 to 0, keep
# only a few digits below 6.1e-5, and overflow above 65504. For this scene
# (1 W/mm^2 on a 50 mm marble object) no fluence value may vanish or
# overflow; the count in the reduced-precision band is printed.
check "fluence of the test scene survives half floats" $PY - "$T/spot.vdb" <<'PY'
import sys
import pyopenvdb as vdb
for name in ("fluence_r", "fluence_g", "fluence_b"):
    g = vdb.read(sys.argv[1], name)
    vals = [it.value for it in g.citerOnValues()]
    lo, hi = min(vals), max(vals)
    sub = sum(1 for v in vals if v < 6.1e-5)
    print("  %s: %.3g .. %.3g W/mm^2, %d of %d cells below 6.1e-5" % (name, lo, hi, sub, len(vals)), file=sys.stderr)
    assert 6e-8 <= lo and hi < 65504, (name, lo, hi)
PY

if [ "$failed" != 0 ]; then
  echo "blender logs:" >&2
  tail -n 20 "$T/good.json.log" "$T/bad.json.log" >&2 || true
fi
finish
