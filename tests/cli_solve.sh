#!/usr/bin/env bash
# -material / -light / -solve through the real command: stats, grids, errors.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# marble on spot, lit from above: three distinct channels, three factorizations
expect_exit 0 "solve spot marble" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=24 \
  -material preset=marble -light type=directional dir=0,-1,0 intensity=1 -solve solver=direct \
  -write file="$T/spot.vdb" -stats file="$T/spot.json"
check "stats: physics fields" $PY - "$T/spot.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
for k in ("cells", "channels", "factors", "nnz_A", "nnz_L", "flops", "t_voxelize", "t_network", "t_assemble", "t_analyze",
          "t_factor", "t_source", "t_solve", "residual", "power_incident", "power_in", "power_absorbed", "power_out"):
    assert k in s, k
assert s["channels"] == 3 and s["factors"] == 3, s
assert s["residual"] < 1e-12, s["residual"]
assert abs(s["power_in"] - s["power_absorbed"] - s["power_out"]) < 1e-10 * s["power_in"], s
# light arrives, some is reflected by Fresnel / absorbed directly, the rest enters
assert 0 < s["power_in"] < s["power_incident"], s
assert s["nnz_L"] >= s["nnz_A"] > s["cells"], s
PY
check "vdb: fluence and exitance per channel" $PY - "$T/spot.vdb" <<'PY'
import sys, pyopenvdb as vdb
g = {x.name: x for x in vdb.readAll(sys.argv[1])[0]}
want = {"surface", "density", "fluence_r", "fluence_g", "fluence_b", "exitance_r", "exitance_g", "exitance_b"}
assert want <= set(g), sorted(g)
d, f, e = g["density"], g["fluence_g"], g["exitance_g"]
assert f.activeVoxelCount() == d.activeVoxelCount(), (f.activeVoxelCount(), d.activeVoxelCount())
assert 0 < e.activeVoxelCount() < d.activeVoxelCount()
lo, hi = f.evalMinMax()
assert lo >= 0 and hi > 0, (lo, hi)
assert f["ohm_material"] == "marble" and "boundary=robin" in f["ohm_solve"], f["ohm_solve"]
assert f["ohm_value_scale"] == 1.0 and f["ohm_scaling"].startswith("none"), f["ohm_scaling"]
# lit from above (+y): boundary cells in the top quarter leave far more light
# per cell than those in the bottom quarter (the hooves)
(x0, y0, z0), (x1, y1, z1) = e.evalActiveVoxelBoundingBox()
top, bottom = [], []
for it in e.citerOnValues():
    y = it.min[1]
    if y > y1 - (y1 - y0) / 4: top.append(it.value)
    elif y < y0 + (y1 - y0) / 4: bottom.append(it.value)
mt, mb = sum(top) / len(top), sum(bottom) / len(bottom)
assert mt > 3 * mb, (mt, mb)
PY

# grey material, grey light: one channel, grids without suffix
expect_exit 0 "grey solve" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=16 \
  -material sigma_a=0.01 sigma_s=1 -light type=point pos=0,100,0 intensity=1000 -solve solver=direct -write file="$T/cow.vdb" -stats file="$T/cow.json"
check "grey: one channel, one factor" $PY -c "
import json; s = json.load(open('$T/cow.json')); assert s['channels'] == 1 and s['factors'] == 1, s"
check "grey: the uniform material's coefficients in the stats (what the Blender add-on's volume reads)" $PY -c "
import json; s = json.load(open('$T/cow.json'))
assert s['medium_varies'] == 0 and s['sigma_a'] == 0.01 and s['sigma_s'] == 1 and 'sigma_a_r' not in s, s"
check "grey: fluence and exitance grids" $PY -c "
import pyopenvdb as vdb; n = {g.name for g in vdb.readAll('$T/cow.vdb')[0]}; assert {'fluence', 'exitance'} <= n, n"

# neumann (the paper's boundary) lets nothing out
expect_exit 0 "neumann" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=16 \
  -material sigma_a=0.01 sigma_s=1 -light dir=0,-1,0 -solve solver=direct boundary=neumann -stats file="$T/n.json"
check "neumann: power_out is 0" $PY -c "
import json; s = json.load(open('$T/n.json')); assert s['power_out'] == 0 and s['power_absorbed'] > 0, s"

# singular: sigma_a = 0 with neumann is refused with the physical cause, exit 1
expect_exit 1 "singular" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 \
  -material sigma_a=0 sigma_s=1 -light dir=0,-1,0 -solve solver=direct boundary=neumann
expect_error_line "singular" "sigma_a = 0 with boundary=neumann.*neither leave nor be absorbed"
# the same with robin solves
expect_exit 0 "sigma_a=0 robin" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 \
  -material sigma_a=0 sigma_s=1 -light dir=0,-1,0 -solve solver=direct

# paper mode: resistances, neumann boundary; robin needs optics (usage error)
expect_exit 0 "paper resistances" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 \
  -material resistance=1000 ground=1000 -light dir=0,-1,0 -solve solver=direct boundary=neumann
expect_exit 2 "resistances with robin" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 \
  -material resistance=1000 ground=1000 -light dir=0,-1,0 -solve solver=direct
expect_error_line "resistances with robin" "boundary=robin needs optical coefficients"

# low albedo gets a warning; pencil beam and missing pieces give clear errors
expect_exit 0 "ketchup" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 -material preset=ketchup
check "ketchup warns: albedo < 0.8" grep -q "albedo 0.0.* < 0.8: the diffusion approximation is poor" <<<"$LAST_ERR"
expect_exit 0 "pencil" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 -material preset=skin1 \
  -light type=pencil pos=0,100,0 dir=0,-1,0 -solve
expect_exit 2 "solve without light" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 -material preset=marble -solve
expect_error_line "solve without light" "no lights"
expect_exit 2 "light without pos" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 -light type=point
expect_error_line "light without pos" "type=point needs pos="
expect_exit 2 "two material kinds" -- "$OHM" -material preset=marble sigma_a=1 sigma_s=1
expect_exit 2 "bad rgb" -- "$OHM" -material sigma_a=1,2 sigma_s=1

# ohm validate: the table, all passing
expect_exit 0 "ohm validate" -- "$OHM" validate
check "validate prints the summary" grep -q " 0 failed" "$T/stdout"

# ordering=best keeps the smallest of the METIS, AMD and grid factors
for o in metis amd grid best; do
  "$OHM" --quiet -read file=samples/spot.obj size=50 -voxelize dim=28 -material sigma_a=0.01 sigma_s=1 \
    -light dir=0,-1,0 -solve solver=direct ordering=$o -stats file="$T/o_$o.json" -export csv="$T/o_$o.csv"
done
check "ordering=best picks the smallest factor" $PY -c "
import json
L = {o: json.load(open('$T/o_%s.json' % o)) for o in ('metis', 'amd', 'grid', 'best')}
assert L['best']['nnz_L'] == min(L[o]['nnz_L'] for o in ('metis', 'amd', 'grid')), L
assert L['best']['ordering'] in ('metis', 'amd', 'grid')"
# ordering=grid (geometric nested dissection) solves to METIS's fluence, cell
# by cell, on a mesh and on a scan
"$OHM" --quiet -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 -voxelize dim=24 threshold=5000 \
  -material transfer=samples/walnut.transfer -light dir=0,-1,0 -solve solver=direct ordering=grid -export csv="$T/w_grid.csv"
"$OHM" --quiet -read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 -voxelize dim=24 threshold=5000 \
  -material transfer=samples/walnut.transfer -light dir=0,-1,0 -solve solver=direct ordering=metis -export csv="$T/w_metis.csv"
for pair in "o_grid o_metis" "w_grid w_metis"; do
  set -- $pair
  check "ordering=grid = metis to 1e-12 ($1)" $PY - "$T/$1.csv" "$T/$2.csv" <<'PYEOF'
import csv, sys
a, b = (list(csv.DictReader(open(p))) for p in sys.argv[1:])
assert len(a) == len(b) > 0, (len(a), len(b))
scale = max(abs(float(r[k])) for r in b for k in r if k.startswith("fluence"))
worst = max(abs(float(x[k]) - float(y[k])) for x, y in zip(a, b) for k in x if k.startswith("fluence"))
assert worst <= 1e-12 * scale, worst / scale
PYEOF
done

# relighting: a 16-frame orbit is one factorization per distinct channel and a
# numbered .vdb sequence
expect_exit 0 "orbit" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=16 -material preset=skin1 \
  -light type=point pos=0,30,60 intensity=1000 orbit=16 -solve solver=direct -write file="$T/orbit.vdb" -stats file="$T/orbit.json"
check "orbit: 16 files" test "$(ls "$T"/orbit_00*.vdb | wc -l)" = 16
check "orbit: stats" $PY -c "
import json; s = json.load(open('$T/orbit.json'))
assert s['frames'] == 16 and s['factors'] == 3 and s['solves'] == 48, s
assert s['t_update_per_frame'] > 0 and s['shadows'] == 'mesh', s"
check "orbit: frames differ, first and ninth opposite" $PY - "$T" <<'PY'
import sys, pyopenvdb as vdb
def total(k):
    g = [x for x in vdb.readAll('%s/orbit_%04d.vdb' % (sys.argv[1], k))[0] if x.name == 'exitance_r'][0]
    lo, hi = g.evalActiveVoxelBoundingBox()
    xs = [(it.min[0], it.value) for it in g.citerOnValues()]
    mid = (lo[0] + hi[0]) / 2
    return sum(v for x, v in xs if x > mid), sum(v for x, v in xs if x <= mid)
a, b = total(5), total(13)   # the light at +x, then at -x
assert a[0] > a[1] and b[1] > b[0], (a, b)
PY
# spot and area lights, shadows by grid, a second orbit rejected
expect_exit 0 "spot + area" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 -material preset=marble \
  -light type=spot pos=0,60,0 dir=0,-1,0 angle=25 falloff=5 -light type=area pos=0,0,60 dir=0,0,-1 shape=disk width=20 samples=16 \
  -solve shadows=grid
expect_exit 2 "two orbits" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 -light type=point pos=0,1,9 orbit=4 \
  -light type=point pos=0,1,9 orbit=4
expect_error_line "two orbits" "only one orbiting light"
expect_exit 2 "falloff wider than the cone" -- "$OHM" -light type=spot pos=0,1,0 dir=0,-1,0 angle=10 falloff=20

# the boundary constant: the exact Fresnel moments by default (A = 2.34 at
# eta 1.3), Egan & Hilgeman's fit on request (2.60).  A larger A reflects
# more of the light arriving at the surface back in, so less leaves and more
# is absorbed; both conserve exactly.
for f in exact polynomial; do
  expect_exit 0 "fresnel=$f" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=20 \
    -material sigma_a=0.05 sigma_s=1 eta=1.3 -light dir=0,-1,0 -solve solver=direct fresnel=$f -stats file="$T/fr_$f.json"
done
check "fresnel: polynomial A keeps more light in" $PY - "$T/fr_exact.json" "$T/fr_polynomial.json" <<'PY'
import json, sys
e, p = (json.load(open(f)) for f in sys.argv[1:3])
assert e["fresnel"] == "exact" and p["fresnel"] == "polynomial", (e["fresnel"], p["fresnel"])
assert e["power_in"] == p["power_in"], (e["power_in"], p["power_in"])  # the source does not depend on A
for s in (e, p):
    assert abs(s["power_in"] - s["power_absorbed"] - s["power_out"]) < 1e-10 * s["power_in"], s
assert p["power_absorbed"] > e["power_absorbed"] * 1.01 and p["power_out"] < e["power_out"], (e, p)
PY
expect_exit 2 "fresnel: unknown formula" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=8 \
  -material preset=marble -light dir=0,-1,0 -solve fresnel=fit

# solver=mc: Monte Carlo transport through the same cells and lights (its
# physics is tested against published values in test_mc); here the command:
# the same light arriving as the diffusion solve's, exact bookkeeping, a seed
# that repeats, and the standard-error grids.
MC=(-read file=samples/spot.obj size=50 -voxelize dim=16 -material sigma_a=0.05 sigma_s=1 eta=1.3 g=0.5
    -light dir=0,-1,0)
expect_exit 0 "mc: seed 3" -- "$OHM" "${MC[@]}" -solve solver=mc photons=32000 seed=3 \
  -write file="$T/mc.vdb" -stats file="$T/mc3.json"
expect_exit 0 "mc: seed 3 again" -- "$OHM" "${MC[@]}" -solve solver=mc photons=32000 seed=3 -stats file="$T/mc3b.json"
expect_exit 0 "mc: seed 4" -- "$OHM" "${MC[@]}" -solve solver=mc photons=32000 seed=4 -stats file="$T/mc4.json"
expect_exit 0 "mc: diffusion beside it" -- "$OHM" "${MC[@]}" -solve solver=direct -stats file="$T/mcd.json"
check "mc: stats" $PY - "$T/mc3.json" "$T/mc3b.json" "$T/mc4.json" "$T/mcd.json" <<'PY'
import json, sys
a, b, c, d = (json.load(open(f)) for f in sys.argv[1:5])
assert a["solver"] == "mc" and a["mc_photons"] == 32000 and a["mc_seed"] == 3 and a["mc_g"] == 0.5, a
assert a["mc_photons_per_ms"] > 0 and a["mc_truncated"] == 0, a
assert a["power_incident"] == d["power_incident"], (a["power_incident"], d["power_incident"])
assert abs(a["power_in"] - a["power_absorbed"] - a["power_out"]) < 1e-12 * a["power_in"], a
assert a["power_out"] == b["power_out"] and a["power_absorbed"] == b["power_absorbed"], (a, b)
assert a["power_out"] != c["power_out"] and abs(a["power_out"] - c["power_out"]) < 0.02 * a["power_out"], (a, c)
PY
check "mc: vdb with standard errors" $PY - "$T/mc.vdb" <<'PY'
import sys, pyopenvdb as vdb
g = {x.name: x for x in vdb.readAll(sys.argv[1])[0]}
assert {"fluence", "exitance", "fluence_se", "exitance_se"} <= set(g), sorted(g)
f, se = g["fluence"], g["fluence_se"]
assert f.activeVoxelCount() == se.activeVoxelCount()
acc = se.getConstAccessor()
lit = [(it.value, acc.getValue(it.min)) for it in f.citerOnValues() if it.value > 0]
assert lit and all(s >= 0 for v, s in lit), lit[:5]
# where most light is, the noise of 32000 photons is a small part of it
lit.sort(reverse=True)
top = lit[: max(1, len(lit) // 10)]
assert all(s < 0.2 * v for v, s in top), top[:5]
PY
# sigma_s_full= with g= is sigma_s' = sigma_s (1 - g): the same diffusion
expect_exit 0 "material: sigma_s_full" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=16 \
  -material sigma_a=0.05 sigma_s_full=2 g=0.5 eta=1.3 -light dir=0,-1,0 -solve solver=direct -stats file="$T/full.json"
check "sigma_s_full=2 g=0.5 is sigma_s'=1" $PY - "$T/full.json" "$T/mcd.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
assert a["power_out"] == b["power_out"] and a["power_absorbed"] == b["power_absorbed"], (a, b)
PY
expect_exit 2 "material: sigma_s and sigma_s_full" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=8 \
  -material sigma_a=0.05 sigma_s=1 sigma_s_full=2 g=0.5
expect_exit 2 "material: g out of range" -- "$OHM" -read file=samples/spot.obj size=50 -voxelize dim=8 \
  -material sigma_a=0.05 sigma_s=1 g=1
expect_exit 2 "mc: boundary= is diffusion's" -- "$OHM" "${MC[@]}" -solve solver=mc boundary=dirichlet
expect_exit 2 "mc: depth band" -- "$OHM" "${MC[@]}" -solve solver=mc depth_band=3
expect_exit 1 "mc: tallies refused beyond max_memory" -- "$OHM" "${MC[@]}" -solve solver=mc photons=1e3 max_memory=0.01
check "mc: the refusal names both figures" grep -q "tallies need about .* more than the 10 KiB max_memory= allows" "$T/stderr"

# hybrid=: a pencil beam's first reduced scatterings traced, diffusion after;
# auto is 10 for a pencil beam and 0 otherwise; the books close exactly
BEAM=(-read file=samples/spot.obj size=50 -voxelize dim=16 -material sigma_a=0.05 sigma_s=1 eta=1.3
      -light type=pencil pos=0,40,0 dir=0,-1,0)
expect_exit 0 "hybrid: auto on a pencil beam" -- "$OHM" "${BEAM[@]}" -solve photons=20000 -stats file="$T/hy.json"
expect_exit 0 "hybrid: off" -- "$OHM" "${BEAM[@]}" -solve hybrid=0 -stats file="$T/hy0.json"
expect_exit 0 "hybrid: auto on a directional light" -- "$OHM" "${MC[@]}" -solve -stats file="$T/hyd.json"
check "hybrid: stats" $PY - "$T/hy.json" "$T/hy0.json" "$T/hyd.json" <<'PY'
import json, sys
h, off, d = (json.load(open(f)) for f in sys.argv[1:4])
assert h["hybrid"] == 10 and h["mc_photons"] == 20000 and h["solver"] != "mc", h
assert off["hybrid"] == 0 and "mc_photons" not in off and d["hybrid"] == 0, (off, d)
assert abs(h["power_in"] - h["power_absorbed"] - h["power_out"]) < 1e-10 * h["power_in"], h
assert abs(h["power_in"] - h["power_entered"]) < 1e-12 * h["power_entered"], h
assert h["power_entered"] == off["power_entered"], (h, off)
# the same light leaves, to the model's difference near the beam
assert abs(h["power_out"] - off["power_out"]) < 0.1 * off["power_out"], (h["power_out"], off["power_out"])
PY
expect_exit 2 "hybrid: not a number" -- "$OHM" "${BEAM[@]}" -solve hybrid=ten
expect_error_line "hybrid: not a number" "hybrid=ten: expected auto or a whole number"
expect_exit 2 "hybrid: with solver=mc" -- "$OHM" "${BEAM[@]}" -solve solver=mc hybrid=5
expect_exit 2 "hybrid: with boundary=neumann" -- "$OHM" "${BEAM[@]}" -solve hybrid=5 boundary=neumann
expect_error_line "hybrid: with boundary=neumann" "use hybrid=0"
# auto steps aside where the tracer does not model the scene
expect_exit 0 "hybrid: auto with boundary=neumann" -- "$OHM" "${BEAM[@]}" -solve boundary=neumann -stats file="$T/hyn.json"
expect_exit 0 "hybrid: auto with a depth band" -- "$OHM" "${BEAM[@]}" -solve depth_band=3 -stats file="$T/hyb.json"
check "hybrid: auto off there" $PY -c "
import json
for f in ('$T/hyn.json', '$T/hyb.json'): assert json.load(open(f))['hybrid'] == 0, f"

# clear=radiosity's reach (clear_reach=): the walnut CT with its least dense
# class clear; a nearer reach links fewer pairs, the books close either way;
# clear_reach= with another treatment is refused
cat >"$T/clear.transfer" <<'TF'
ohm-transfer 1 eta=column
0 0.0004 0.001 1.0
5300 0.0004 0.001 1.0
6100 0.02 1 1.45
15000 0.2 5 1.6
TF
WALNUT=(-read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16 -voxelize threshold=5000
        -material transfer="$T/clear.transfer" -light type=point pos=0,0,60 intensity=1000)
expect_exit 0 "clear=radiosity, ohm's reach" -- "$OHM" "${WALNUT[@]}" -solve clear=radiosity solver=mg \
  -stats file="$T/reach_auto.json"
expect_exit 0 "clear=radiosity clear_reach=2" -- "$OHM" "${WALNUT[@]}" -solve clear=radiosity clear_reach=2 \
  solver=mg -stats file="$T/reach_2.json"
check "clear_reach=2: fewer pairs, linked within 2 mm, the books exact" $PY - "$T/reach_auto.json" "$T/reach_2.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
assert a["clear_action"] == b["clear_action"] == "radiosity", (a["clear_action"], b["clear_action"])
assert b["clear_reach_mm"] == 2 and a["clear_reach_mm"] > 2, (a["clear_reach_mm"], b["clear_reach_mm"])
assert 0 < b["clear_pairs"] < a["clear_pairs"], (a["clear_pairs"], b["clear_pairs"])
assert a["clear_nodes"] == b["clear_nodes"] > 0, (a["clear_nodes"], b["clear_nodes"])
for s in (a, b): assert s["conservation_error"] < 1e-10, s["conservation_error"]
PY
expect_exit 2 "clear_reach= with clear=effective" -- "$OHM" "${WALNUT[@]}" -solve clear=effective clear_reach=5
expect_error_line "clear_reach= with clear=effective" "clear_reach= is the reach of clear=radiosity's coupling; clear=effective has none"

# the paper's Figure 1 profiles: 15 rows, symmetric, peaked in the middle
expect_exit 0 "figure 1" -- "$OHM" validate figure1 "$T/fig1.csv"
check "figure 1 csv" $PY - "$T/fig1.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert len(rows) == 15, len(rows)
for col in ("paper_norm", "dipole_norm", "ohm3d_norm", "milk_network_norm"):
    v = [float(r[col]) for r in rows]
    assert abs(max(v) - 1) < 1e-9 and v[7] == max(v), (col, v)
    assert all(abs(v[i] - v[14 - i]) < 1e-6 for i in range(15)), (col, v)
PY

finish
