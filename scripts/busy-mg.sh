#!/usr/bin/env bash
# solver=mg on a busy machine: the solve's seconds of the bundled cow,
# alternating quiet and with one `nice -n 19` busy loop per core, for one
# or two builds of ohm in the same run (docs/performance.md, "A
# factorization on a busy machine", cites it).  It reports; it asserts
# nothing.
#   scripts/busy-mg.sh build/ohm [other-build/ohm]     DIMS="128 200" RUNS=3
# About 2 minutes for two builds; run it with nothing else busy.
set -euo pipefail
cd "$(dirname "$0")/.."
DIMS=${DIMS:-"128 200"} RUNS=${RUNS:-3}
[ $# -ge 1 ] || { echo "usage: scripts/busy-mg.sh OHM [OTHER_OHM]" >&2; exit 2; }
tmp=$(mktemp -d)
burners=()
stop_burners() {
  for p in "${burners[@]}"; do kill "$p" 2>/dev/null || true; done
  burners=()
}
trap 'stop_burners; rm -rf "$tmp"' EXIT

solve_seconds() { # ohm dim: the solve's seconds (three media, one light)
  "$1" -read file=samples/cow.obj size=60 -voxelize dim="$2" -material preset=skin1 \
    -light type=directional dir=0,-1,0 -solve solver=mg -stats file="$tmp/s.json" >/dev/null 2>&1
  python3 -c 'import json, sys; s = json.load(open(sys.argv[1])); print("%.3f %d" % (s["t_solve"], s["cells"]))' \
    "$tmp/s.json"
}

echo "| build | cells | quiet (s) | busy (s) | busy / quiet |"
echo "|---|---:|---|---|---|"
for dim in $DIMS; do
  for ohm in "$@"; do
    quiet=() busy=() cells=0
    for run in $(seq "$RUNS"); do
      read -r t cells < <(solve_seconds "$ohm" "$dim")
      quiet+=("$t")
      for _ in $(seq "$(nproc)"); do
        nice -n 19 sh -c 'while :; do :; done' &
        burners+=($!)
      done
      sleep 0.5
      read -r t cells < <(solve_seconds "$ohm" "$dim")
      busy+=("$t")
      stop_burners
      sleep 0.5
    done
    python3 - "$ohm" "$cells" "${quiet[*]}" "${busy[*]}" <<'PY'
import statistics, sys
q = [float(x) for x in sys.argv[3].split()]
b = [float(x) for x in sys.argv[4].split()]
print("| %s | %s | %s | %s | %.2f× (medians) |" % (sys.argv[1], sys.argv[2], ", ".join("%.3f" % x for x in q),
      ", ".join("%.3f" % x for x in b), statistics.median(b) / statistics.median(q)))
PY
  done
done
