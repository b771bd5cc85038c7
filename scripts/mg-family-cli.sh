#!/usr/bin/env bash
# solver=mg against solver=amg on a block medium of many levels, through the
# user's route (a scan and a transfer function: scripts/family-medium.py),
# in one run that alternates them: setup, time per light, iterations and
# peak memory of each run, and their medians, into docs/mg-family-cli.md
# (docs/multigrid.md, "Any medium", cites it).  It reports; it asserts nothing.
#   scripts/mg-family-cli.sh [build/ohm]     N=216 LEVELS=9 RUNS=5 SOLVERS="mg amg"
# At 216^3 and nine levels, five runs of both take about 5 minutes on the
# project's 2-core machine; run it with nothing else busy.
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=$(realpath "${1:-build/ohm}")
N=${N:-216} LEVELS=${LEVELS:-9} RUNS=${RUNS:-5} SOLVERS=${SOLVERS:-"mg amg"}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scripts/family-medium.py "$N" "$LEVELS" "$tmp/m.raw" "$tmp/m.transfer"
d=$((N + 1))
rows="$tmp/rows.csv"
for run in $(seq "$RUNS"); do
  for solver in $SOLVERS; do
    echo "mg-family-cli: run $run of $RUNS, solver=$solver" >&2
    /usr/bin/time -f "%M" -o "$tmp/rss" "$OHM" -read file="$tmp/m.raw" dims="$d,$d,$d" type=u8 spacing=1 \
      -voxelize voxel=1 threshold=5 -material transfer="$tmp/m.transfer" \
      -light type=directional dir=0,-1,0 intensity=1 -solve solver="$solver" -stats file="$tmp/s.json" \
      >"$tmp/out" 2>"$tmp/err" || { tail -3 "$tmp/err" >&2; exit 1; }
    python3 - "$tmp/s.json" "$tmp/rss" "$solver" "$run" >>"$rows" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
cols = max(1, s["solves"])
setup = s["t_analyze"] + s["t_factor"] + s["t_cg_setup"]
rss = int(open(sys.argv[2]).read().split()[-1]) * 1024
print("%s,%s,%d,%.3f,%.3f,%.1f,%d" % (sys.argv[3], sys.argv[4], s["cells"], setup, s["t_solve"] / cols,
      s["cg_iterations"] / cols, rss))
PY
  done
done
python3 - "$rows" "$N" "$LEVELS" "$(nproc)" >docs/mg-family-cli.md <<'PY'
import datetime, statistics, sys
rows = [l.strip().split(",") for l in open(sys.argv[1])]
n, levels = sys.argv[2], sys.argv[3]
print("# solver=mg against amg on a %s-level block medium, %s^3 cells\n" % (levels, n))
print("Written by `scripts/mg-family-cli.sh` on %s, on a machine of %s cores. The medium is "
      "`scripts/family-medium.py %s %s` read as a scan through its transfer function (one directional "
      "light, one channel); the runs alternate the solvers. Per run: set-up (analyse + factor + the "
      "iterative solver's set-up), the solve per light, iterations, peak resident memory.\n"
      % (datetime.date.today().isoformat(), sys.argv[4], n, levels))
print("| solver | run | cells | set-up (s) | per light (s) | iterations | peak (MB) |")
print("|---|---:|---:|---:|---:|---:|---:|")
for r in rows:
    print("| %s | %s | %s | %s | %s | %s | %.0f |" % (r[0], r[1], r[2], r[3], r[4], r[5], int(r[6]) / 1e6))
med = {}
for s in dict.fromkeys(r[0] for r in rows):
    mine = [r for r in rows if r[0] == s]
    med[s] = [statistics.median(float(r[i]) for r in mine) for i in (3, 4, 5, 6)]
print("\nMedians:\n")
print("| solver | set-up (s) | per light (s) | iterations | peak (MB) |")
print("|---|---:|---:|---:|---:|")
for s, m in med.items():
    print("| %s | %.3f | %.3f | %.1f | %.0f |" % (s, m[0], m[1], m[2], m[3] / 1e6))
if "mg" in med and "amg" in med:
    print("\nmg's time per light is %.2f× amg's." % (med["mg"][1] / med["amg"][1]))
PY
cat docs/mg-family-cli.md
