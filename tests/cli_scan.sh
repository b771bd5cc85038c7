#!/usr/bin/env bash
# Scans end to end: a CT alone (iso-surface) and an MRI alone, materials from
# transfer functions, material and fluence grids written; a scan placed in a
# mesh; errors.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

for p in walnut walnut-dicom head liver; do
  # the factor, named (the bundled pipelines take the default, solver=auto):
  # one analysis shared by the channels' factors is what is checked
  sed -e "s|out/|$T/|g" -e 's/^solve\b/solve solver=direct/' "pipelines/$p.ohm" >"$T/$p.ohm"
  expect_exit 0 "pipeline $p" -- "$OHM" run "$T/$p.ohm"
  check "$p: grids, one analysis, conservation" $PY - "$T/$p.vdb" "$T/$p.json" <<'PY'
import json, sys, pyopenvdb as vdb
grids = {g.name: g for g in vdb.readAll(sys.argv[1])[0]}
s = json.load(open(sys.argv[2]))
want = {"surface", "density", "fluence_r", "exitance_r", "sigma_a_r", "sigma_a_g", "sigma_a_b", "sigma_s_r", "sigma_s_b"}
assert want <= set(grids), sorted(grids)
# the material varies cell by cell (shell / kernel, tissue types)
lo, hi = grids["sigma_s_g"].evalMinMax()
assert hi > 1.5 * lo > 0, (lo, hi)
assert grids["sigma_a_r"].activeVoxelCount() == s["cells"] == grids["density"].activeVoxelCount()
assert s["analyses"] == 1 and s["factors"] == 3, s
assert s["conservation_error"] < 1e-10 and s["residual"] < 1e-12, s
assert s["transfer"].endswith(".transfer") and s["scan_file"], s
PY
done

# the walnut as a DICOM series (rescaled values, patient coordinates) lights
# up as the raw walnut does, mirrored: the same cells and powers; and each
# .vdb sits where its scan is (the DICOM one at its RAS position)
check "walnut-dicom: walnut.ohm mirrored, placed where the scan is" $PY - "$T" <<'PY'
import json, sys, numpy as np, pyopenvdb as vdb
d = sys.argv[1]
raw, dcm = (json.load(open(f"{d}/{n}.json")) for n in ("walnut", "walnut-dicom"))
assert raw["cells"] == dcm["cells"], (raw["cells"], dcm["cells"])
# (each cell's density is kept as a float, the scan's own precision; the
# DICOM's rescaled values round differently there: ~2e-9 of the powers)
for k in ("power_in", "power_absorbed", "power_out"):
    assert abs(raw[k] - dcm[k]) <= 1e-8 * raw[k], (k, raw[k], dcm[k])
def world_box(path):
    g = {x.name: x for x in vdb.readAll(path)[0]}["fluence_g"]
    lo, hi = g.evalActiveVoxelBoundingBox()
    return np.array(g.transform.indexToWorld(lo)), np.array(g.transform.indexToWorld(hi)), g.transform.voxelSize()[0]
# the scans' voxel centres: raw (0..39.375, 0..29.375, 0..35); DICOM, LPS origin
# (-20, -15, -17.5) mirrored to RAS: (20 - 39.375 .. 20, 15 - 29.375 .. 15, -17.5 .. 17.5)
for name, lo_want, hi_want in (("walnut", (0, 0, 0), (39.375, 29.375, 35)),
                               ("walnut-dicom", (-19.375, -14.375, -17.5), (20, 15, 17.5))):
    lo, hi, h = world_box(f"{d}/{name}.vdb")
    assert np.all(lo >= np.array(lo_want) - 1.5 * h) and np.all(hi <= np.array(hi_want) + 1.5 * h), (name, lo, hi, h)
    assert np.all(hi - lo > 0.5 * (np.array(hi_want) - np.array(lo_want))), (name, lo, hi)
PY
expect_exit 2 "dicom: an unknown series" -- "$OHM" -read file=samples/walnut-dicom series=1.2.3
expect_error_line "dicom: an unknown series" "walnut-dicom: no series 1.2.3 here; there are 1.2.826.0.1.3680043.8.498"

# the liver INR's geometry as the log reports it (CGAL's voxel size), and a
# folder of slices read through -read (it went to the mesh reader once)
expect_exit 0 "liver geometry" -- "$OHM" -read file=samples/liver.inr.gz
check "liver: 0.617188 x 0.617188 x 1.33333 mm, axis-aligned" \
  grep -q "voxels 0.617188 x 0.617188 x 1.33333 mm, the first one's centre at (0, 0, 0) mm (RAS); axes along the world's" "$T/stderr"
mkdir -p "$T/slices"
$PY -c "
import sys; from PIL import Image
for z in range(3): Image.new('L', (8, 6), 40 * z + 10).save('$T/slices/s%02d.png' % z)"
expect_exit 0 "slice folder" -- "$OHM" -read file="$T/slices" spacing=0.5
check "slice folder: 8 x 6 x 3 voxels of 0.5 mm" grep -q "8 x 6 x 3 voxels, values 10 .. 90, 3.5 x 2.5 x 1 mm" "$T/stderr"

# a scan placed in a mesh: the head MRI stretched over spot's box
expect_exit 0 "place" -- "$OHM" -read file=samples/spot.obj size=50 -read file=samples/ch2_2mm.nii.gz -place fit=1 \
  -voxelize dim=24 -material transfer=samples/mri-head.transfer -light dir=0,-1,0 -solve -write file="$T/placed.vdb" \
  -stats file="$T/placed.json"
check "placed: material varies inside spot (grids, and medium_varies in the stats)" $PY -c "
import json, pyopenvdb as vdb
g = {x.name: x for x in vdb.readAll('$T/placed.vdb')[0]}
lo, hi = g['sigma_s_g'].evalMinMax(); assert hi > lo > 0, (lo, hi)
assert json.load(open('$T/placed.json'))['medium_varies'] == 1"

# a refractive index per density (eta=column): the walnut's kernel at 1.33
# under a shell at 1.55; diffusion and Monte Carlo both conserve power, and
# the index changes the light (against the same media at one index)
printf 'ohm-transfer 1 eta=column\n5000 0.01 1.0 1.33\n15000 0.1 3.0 1.55\n' >"$T/eta.transfer"
printf 'ohm-transfer 1 eta=1.33\n5000 0.01 1.0\n15000 0.1 3.0\n' >"$T/one.transfer"
# and an anisotropy per density (g=column) with full sigma_s: the same sigma_s' as eta.transfer
printf 'ohm-transfer 1 eta=column g=column scattering=full\n5000 0.01 2.0 1.33 0.5\n15000 0.1 30 1.55 0.9\n' \
  >"$T/g.transfer"
for run in "eta diffusion:eta:solver=direct" "one index:one:solver=direct" "eta mc:eta:solver=mc photons=20000 seed=3" "g diffusion:g:solver=direct" \
  "g mc:g:solver=mc photons=20000 seed=3"; do
  IFS=: read -r what tf opts <<<"$run"
  expect_exit 0 "$what" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 spacing=0.625 \
    -voxelize dim=24 threshold=5000 -material transfer="$T/$tf.transfer" -light dir=0,-1,0 -solve $opts \
    -write file="$T/${what// /_}.vdb" -stats file="$T/${what// /_}.json"
done
check "eta column: conservation, and the index matters" $PY - "$T" <<'PY'
import json, sys
d = sys.argv[1]
eta, one, mc, gd, gmc = (json.load(open(f"{d}/{n}.json"))
                         for n in ("eta_diffusion", "one_index", "eta_mc", "g_diffusion", "g_mc"))
for s in (eta, one, mc, gd, gmc):
    assert s["conservation_error"] < 1e-10, s["conservation_error"]
# diffusion sees only sigma_s' = sigma_s (1 - g): the g column changes nothing there (but
# the round-off of 30 x (1 - 0.9))
assert abs(gd["power_out"] - eta["power_out"]) < 1e-12 * eta["power_out"], (gd["power_out"], eta["power_out"])
# transport sees the phase function: another sample, close (similarity)
assert gmc["power_out"] != mc["power_out"] and abs(gmc["power_out"] - mc["power_out"]) < 0.1 * mc["power_out"]
assert eta["residual"] < 1e-12, eta["residual"]
# the shell's 1.55 reflects more light back inside at the surface: less leaves
rel = abs(eta["power_out"] - one["power_out"]) / one["power_out"]
assert rel > 0.01 and eta["power_out"] < one["power_out"], (eta["power_out"], one["power_out"])
# diffusion and transport agree on what leaves to the model error (loosely)
assert abs(mc["power_out"] - eta["power_out"]) / mc["power_out"] < 0.25, (mc["power_out"], eta["power_out"])
PY

# the paper's mode through a transfer function (density -> resistances): the
# solver keeps the per-cell resistances for its whole life (an earlier build
# freed them before the solve: garbage, caught here by the sanitizer pass)
printf 'ohm-transfer 1 mode=resistance\n5000 2000 5e4\n15000 500 2e4\n' >"$T/paper.transfer"
expect_exit 0 "paper mode scan" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 \
  spacing=0.625 -voxelize dim=24 threshold=5000 -material transfer="$T/paper.transfer" -light dir=0,-1,0 \
  -solve boundary=neumann -stats file="$T/paper.json"
check "paper mode scan: conserved, all of it absorbed (neumann)" $PY - "$T/paper.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
assert s["conservation_error"] < 1e-10 and s["residual"] < 1e-12, (s["conservation_error"], s["residual"])
assert s["power_in"] > 0 and abs(s["power_absorbed"] - s["power_in"]) < 1e-10 * s["power_in"], s
PY

# errors
expect_exit 2 "volume without threshold" -- "$OHM" -read file=samples/ch2_2mm.nii.gz -voxelize dim=16
expect_error_line "volume without threshold" "needs threshold="
expect_exit 2 "transfer without a volume" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material transfer=samples/walnut.transfer -light dir=0,-1,0 -solve
expect_error_line "transfer without a volume" "maps a volume's density"
expect_exit 2 "raw without dims" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz
expect_error_line "raw without dims" "walnut_64x48x57_uint16.raw.gz"
expect_exit 1 "raw with wrong dims" -- "$OHM" -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,56
expect_error_line "raw with wrong dims" "walnut_64x48x57_uint16.raw.gz.*bytes"
printf 'ohm-transfer 1\n0 0.1 1\n0 0.2 1\n' >"$T/bad.transfer"
expect_exit 1 "bad transfer" -- "$OHM" -material transfer="$T/bad.transfer"
expect_error_line "bad transfer" "bad.transfer:3:"
expect_exit 2 "place without a volume" -- "$OHM" -read file=samples/cow.obj -place
expect_error_line "place without a volume" "no volume to place"

finish
