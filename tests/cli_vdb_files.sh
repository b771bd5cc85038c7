#!/usr/bin/env bash
# What -write produces, read back by OpenVDB's own Python module: grid names,
# classes, voxel size, and the object's box in millimetres.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

check "pyopenvdb imports" $PY -c 'import pyopenvdb'

# spot scaled to 50 mm along its longest axis, 40 cells along it
expect_exit 0 "write spot" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=40 -write file="$T/spot.vdb" -stats file="$T/spot.json"
$PY tests/vdb_inspect.py "$T/spot.vdb" >"$T/spot.info"
check "spot grids as expected" $PY - "$T/spot.info" "$T/spot.json" <<'PY'
import json, sys
info = json.load(open(sys.argv[1])); stats = json.load(open(sys.argv[2]))
g = {x["name"]: x for x in info["grids"]}
assert sorted(g) == ["density", "surface"], sorted(g)
assert g["surface"]["class"] == "level set", g["surface"]["class"]
assert g["density"]["class"] == "fog volume", g["density"]["class"]
h = 50.0 / 40
for x in g.values():
    assert all(abs(v - h) < 1e-9 for v in x["voxel_size"]), x["voxel_size"]
    assert x["meta"]["ohm_units"] == "mm" and x["meta"]["ohm_source"] == "samples/spot.obj", x["meta"]
    assert abs(x["meta"]["ohm_mesh_scale_mm"] / stats["mesh_scale_mm"] - 1) < 1e-8
    assert min(min(c) for c in x["index_bbox"]) >= 0, "indices must be >= 0"
d = g["density"]
assert d["active"] == stats["cells"], (d["active"], stats["cells"])
# the interior's box spans the object's box to within a voxel: 50 mm long
ext = [b - a for a, b in zip(d["world_min"], d["world_max"])]
assert abs(max(ext) - 50.0) <= h, ext
# and sits where the mesh is: spot.obj is centred near the origin in x
assert abs(0.5 * (d["world_min"][0] + d["world_max"][0])) < 2 * h, d["world_min"]
# the level set's band surrounds the interior
s = g["surface"]
assert all(s["world_min"][i] < d["world_min"][i] and s["world_max"][i] > d["world_max"][i] for i in range(3))
assert abs(s["background"] - 3 * h) < 1e-5
PY

# the level set is negative inside and positive outside, and the fog is 1 inside
check "surface sign agrees with density" $PY - "$T/spot.vdb" <<'PY'
import sys, pyopenvdb as vdb
grids, _ = vdb.readAll(sys.argv[1])
g = {x.name: x for x in grids}
sa, da = g["surface"].getConstAccessor(), g["density"].getConstAccessor()
lo, hi = g["surface"].evalActiveVoxelBoundingBox()
agree = total = 0
for i in range(lo[0], hi[0] + 1, 2):
    for j in range(lo[1], hi[1] + 1, 2):
        for k in range(lo[2], hi[2] + 1, 2):
            inside = da.getValue((i, j, k)) > 0.5
            total += 1
            agree += (sa.getValue((i, j, k)) < 0) == inside
assert agree == total, (agree, total)
PY

# units: a mesh in cm is 10x larger in mm; the voxel size follows dim
expect_exit 0 "units=cm" -- "$OHM" -read file=samples/larger_sphere.off units=cm -voxelize dim=20 -write file="$T/sphere.vdb"
check "sphere in cm: radius 10 mm" $PY - "$T/sphere.vdb" <<'PY'
import sys, pyopenvdb as vdb
g = [x for x in vdb.readAll(sys.argv[1])[0] if x.name == "density"][0]
assert abs(g.transform.voxelSize()[0] - 1.0) < 0.02, g.transform.voxelSize()
assert abs(g["ohm_mesh_scale_mm"] - 10.0) < 1e-12
PY
# voxel= in another unit
expect_exit 0 "voxel=0.1 units=cm" -- "$OHM" -read file=samples/larger_sphere.off units=cm -voxelize voxel=0.1 units=cm -write file="$T/sphere1.vdb"
check "voxel 1 mm" $PY -c "
import pyopenvdb as vdb
g = vdb.readAll('$T/sphere1.vdb')[0][0]
assert abs(g.transform.voxelSize()[0] - 1.0) < 1e-12, g.transform.voxelSize()"

# open meshes are warnings, not errors: head.off (open neck, inside-out) and
# teapot.obj (four open pieces) voxelize, say what they found, exit 0
for m in head.off teapot.obj stanford-bunny.obj.gz; do
  expect_exit 0 "open mesh $m" -- "$OHM" -read file=samples/$m -voxelize dim=24 -write file="$T/open.vdb"
  check "$m: warns about open edges" grep -q "warning: samples/$m is not closed: [1-9][0-9]* open (boundary) edges" <<<"$LAST_ERR"
done
expect_exit 0 "inside-out head" -- "$OHM" -read file=samples/head.off -voxelize dim=24
check "head.off: warns it is inside-out" grep -q "wound inside-out" <<<"$LAST_ERR"

finish
