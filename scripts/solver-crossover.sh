#!/usr/bin/env bash
# Where solver=auto switches: spot at 50 mm, marble, a directional light
# orbiting the x axis (every frame a different light), solved with
# solver=direct, cg and auto for a grid of sizes and frame counts.  Times are
# the solver's own (analysis + factorizations + CG setup + solves; the light
# sources are the same for all three).  Markdown on stdout.
#   scripts/solver-crossover.sh [DIMS="32 64 96"] [FRAMES="1 4 16 64 256"]
set -euo pipefail
cd "$(dirname "$0")/.."
ohm=${OHM:-build/ohm}
dims=${1:-32 64 96}; frames=${2:-1 4 16 64 256}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
echo "| dim | cells | frames | direct (s) | cg (s) | auto (s) | auto chose | faster |"
echo "|---|---|---|---|---|---|---|---|"
for d in $dims; do
  for f in $frames; do
    for sv in direct cg auto; do
      "$ohm" --quiet -read file=samples/spot.obj size=50 -voxelize dim=$d -material preset=marble \
        -light type=directional dir=0,-1,0 intensity=1 orbit=$f axis=x -solve solver=$sv -stats file="$T/$sv.json" 2>/dev/null
    done
    /usr/bin/python3 - "$T" $d $f <<'PY'
import json, sys
T, d, f = sys.argv[1], sys.argv[2], sys.argv[3]
t = {}
for sv in ("direct", "cg", "auto"):
    s = json.load(open(f"{T}/{sv}.json"))
    t[sv] = s["t_analyze"] + s["t_factor"] + s.get("t_cg_setup", 0) + s["t_solve"]
    if sv == "auto": chose, cells = s["solver"], s["cells"]
faster = "direct" if t["direct"] < t["cg"] else "cg"
print(f"| {d} | {cells} | {f} | {t['direct']:.3g} | {t['cg']:.3g} | {t['auto']:.3g} | {chose} | {faster} |")
PY
  done
done
