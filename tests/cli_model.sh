#!/usr/bin/env bash
# -solve model= (docs/transport.md, "Which model"): with -voxelize error=,
# model=auto measures diffusion's own error against transport in the scene
# and traces ketchup (whose error does not fall with the grid) as transport,
# whose result is solver=mc's bit for bit and conserves power; marble is not
# probed and stays diffusion; an explicit diffusion solver is kept, with a
# warning; contradictory model= and solver= are refused.
set -eu
source "$(dirname "$0")/lib.sh" "$1"
scene=(-read file=samples/cow.obj size=60 -light type=directional dir=0,-1,0 intensity=1)
mc=(photons=1e5 seed=3 threads=2)
expect_exit 0 "ketchup, error=0.1, model=auto" -- "$OHM" "${scene[@]}" -material preset=ketchup \
  -voxelize error=0.1 -solve "${mc[@]}" -stats file="$T/auto.json"
check "ketchup: the probe finds diffusion's own error above the target, and transport is chosen" $PY - "$T/auto.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
assert s["model"] == "transport" and s["solver"] == "mc", (s["model"], s["solver"])
assert s["model_error_probe"] > 0.1 and s["model_diff_probe"] >= s["model_error_probe"], s["model_error_probe"]
assert abs(s["power_in"] - s["power_out"] - s["power_absorbed"]) <= 1e-9 * s["power_in"], s
print("  ketchup: diffusion's own error at least %.3f, transport chosen" % s["model_error_probe"])
PY
dim=$($PY -c "import json; print(json.load(open('$T/auto.json'))['dim_chosen'])")
expect_exit 0 "ketchup, the same grid, solver=mc" -- "$OHM" "${scene[@]}" -material preset=ketchup \
  -voxelize dim="$dim" -solve solver=mc "${mc[@]}" -stats file="$T/mc.json"
check "model=auto's transport is solver=mc's" $PY - "$T/auto.json" "$T/mc.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:])
for k in ("cells", "power_in", "power_out", "power_absorbed"):
    assert a[k] == b[k], (k, a[k], b[k])
PY
expect_exit 0 "ketchup, error=0.1, solver=direct" -- "$OHM" "${scene[@]}" -material preset=ketchup \
  -voxelize error=0.1 -solve solver=direct -stats file="$T/direct.json"
check "an explicit diffusion solver is kept, with a warning" grep -q \
  "warning: -solve solver=direct is diffusion, whose own error against transport in this scene is at least" \
  <<<"$LAST_ERR"
check "solver=direct stays diffusion" $PY -c "
import json; s = json.load(open('$T/direct.json')); assert s['model'] == 'diffusion' and s['solver'] == 'direct', s['model']"
expect_exit 0 "marble, error=0.1" -- "$OHM" "${scene[@]}" -material preset=marble -voxelize error=0.1 -solve \
  -stats file="$T/marble.json"
check "marble (albedo 0.998) is not probed and stays diffusion" $PY -c "
import json; s = json.load(open('$T/marble.json')); assert s['model'] == 'diffusion' and 'model_error_probe' not in s, s['model']"
expect_exit 0 "model=transport" -- "$OHM" "${scene[@]}" -material preset=marble -voxelize dim=16 \
  -solve model=transport "${mc[@]}" -stats file="$T/transport.json"
check "model=transport is Monte Carlo" $PY -c "
import json; s = json.load(open('$T/transport.json')); assert s['model'] == 'transport' and s['solver'] == 'mc', s['solver']"
expect_exit 2 "model=transport solver=direct" -- "$OHM" "${scene[@]}" -material preset=marble -voxelize dim=16 \
  -solve model=transport solver=direct
expect_error_line "model=transport solver=direct" "model=transport is Monte Carlo \\(solver=mc\\); solver=direct solves diffusion"
expect_exit 2 "model=diffusion solver=mc" -- "$OHM" "${scene[@]}" -material preset=marble -voxelize dim=16 \
  -solve model=diffusion solver=mc
expect_error_line "model=diffusion solver=mc" "model=diffusion and solver=mc contradict"
finish
