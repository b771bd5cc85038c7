#!/usr/bin/env bash
# A head with clear regions, from a scan made outside the project: the
# Colin27 T1 head (samples/ch2.nii.gz, samples/ch2_2mm.nii.gz) through
# samples/head-clear.transfer (CSF and skull clear, sinuses air), a pencil
# beam on the scalp.  Per grid (2 mm, 1 mm) and clear= treatment, solver=mg:
# iterations, set-up, solve, the coupling's size and set-up; and the brain's
# fluence against ohm's Monte Carlo tracer (solver=mc, which flies straight
# through clear cells with Fresnel at index steps): the median ratio
# diffusion / transport of the brain's cells in 5 mm shells 10-30 mm from
# where the beam enters.  Writes docs/head-clear.md (docs/transport.md cites
# it).  It reports; it asserts nothing.
#   scripts/head-clear.sh [build/ohm]     GRIDS="2 1" PHOTONS=2e6
#   RADIOSITY_GRIDS="2": where clear=radiosity runs too (its pairs grow with
#   the walls' area within reach: at 1 mm, about 16x the 2 mm's 6.8e6)
#   RADIOSITY_REACH=15: its clear_reach= (mm; default: ohm's, 5 mean chords
#   of the thickest region, 35 mm here)
# About 6 minutes on the project's 2-core machine; run it with nothing else
# busy.
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=$(realpath "${1:-build/ohm}")
GRIDS=${GRIDS:-"2 1"} PHOTONS=${PHOTONS:-2e6} RADIOSITY_GRIDS=${RADIOSITY_GRIDS:-"2"}
RADIOSITY_REACH=${RADIOSITY_REACH:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rows="$tmp/rows.txt"
# the beam: straight down onto the top of the head, 20 mm in front of the
# origin (the scalp is at z = 70-75 mm there)
light=(-light type=pencil pos=0,20,120 dir=0,0,-1 intensity=1)

# the same head with its clear classes made brain: what the solve costs
# where diffusion holds everywhere
awk '/^[0-9]/ && $1 < 45 { print $1, 0.02, 1.0, 1.37; next } { print }' samples/head-clear.transfer >"$tmp/grey.transfer"

run() { # grid clear solver [label transfer]: one solve, its statistics and its cells
  local h=$1 clear=$2 solver=$3 label=${4:-$2} transfer=${5:-samples/head-clear.transfer}
  local file=samples/ch2.nii.gz photons=() reach=()
  [ "$h" = 2 ] && file=samples/ch2_2mm.nii.gz
  [ "$solver" = mc ] && photons=(photons="$PHOTONS") # the diffusion solves at their defaults
  [ "$clear" = radiosity ] && [ -n "$RADIOSITY_REACH" ] && reach=(clear_reach="$RADIOSITY_REACH")
  echo "head-clear: ${h} mm, $label, solver=$solver" >&2
  /usr/bin/time -f "%M" -o "$tmp/rss" "$OHM" -read file="$file" -voxelize threshold=12 voxel="$h" \
    -material transfer="$transfer" "${light[@]}" \
    -solve solver="$solver" clear="$clear" "${photons[@]}" "${reach[@]}" -stats file="$tmp/s.json" \
    -export csv="$tmp/$h-$label-$solver.csv" >"$tmp/out" 2>"$tmp/err" || { tail -3 "$tmp/err" >&2; exit 1; }
  grep -h "clear regions' coupling:" "$tmp/err" | grep -v "%" | tail -1 >"$tmp/coupling" || true
  /usr/bin/python3 - "$tmp/s.json" "$tmp/rss" "$h" "$label" "$solver" "$tmp/coupling" >>"$rows" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
rss = int(open(sys.argv[2]).read().split()[-1]) * 1024
coupling = open(sys.argv[6]).read().strip().replace("ohm: clear regions' coupling: ", "")
print("|".join([sys.argv[3], sys.argv[4], sys.argv[5], str(s["cells"]), str(s.get("clear_cells", "")),
                "%.0f" % (s["cg_iterations"] / max(1, s["solves"])), "%.2f" % (s["t_cg_setup"]),
                "%.2f" % s["t_solve"], "%.2f" % (rss / 1e9), coupling or "—"]))
PY
}

for h in $GRIDS; do
  run "$h" off mc
  for clear in off effective; do run "$h" "$clear" mg; done
  run "$h" off mg "clear classes as brain" "$tmp/grey.transfer"
  case " $RADIOSITY_GRIDS " in *" $h "*) run "$h" radiosity mg ;; esac
done

/usr/bin/python3 - "$tmp" "$rows" "$GRIDS" "$PHOTONS" >docs/head-clear.md <<'PY'
import datetime, gzip, os, struct, sys
import numpy as np
tmp, rows, grids, photons = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4]
# the 1 mm scan, to class each solved cell by the voxel at its centre
raw = gzip.open("samples/ch2.nii.gz").read()
dims = struct.unpack("<8h", raw[40:56])[1:4]
vox = np.frombuffer(raw[352:], dtype=np.uint8)[: dims[0] * dims[1] * dims[2]].reshape(dims[2], dims[1], dims[0])
first = np.array([-90.0, -125.0, -71.0])  # the first voxel's centre (RAS, mm), as ohm reports it

def cells(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1)
    xyz, phi = a[:, 3:6], a[:, 6]
    ijk = np.clip(np.rint(xyz - first).astype(int), 0, np.array(dims) - 1)
    return xyz, phi, vox[ijk[:, 2], ijk[:, 1], ijk[:, 0]]

print("# A head with clear regions: the Colin27 T1 head, solver=mg against transport\n")
print("Written by `scripts/head-clear.sh` on %s, on a machine of %d cores. The scan is "
      "`samples/ch2.nii.gz` (or its 2 mm copy) through `samples/head-clear.transfer`: CSF and skull "
      "clear (σa 0.0004, σs′ 0.001 /mm), sinuses air (10⁻⁵ /mm, n 1.0), brain σa 0.02 σs′ 1.0, scalp "
      "0.019 / 0.86, n 1.37. A 1 W pencil beam enters the scalp straight down at x 0, y 20 mm. "
      "Transport is ohm's Monte Carlo tracer (`solver=mc`, %s photons).\n"
      % (datetime.date.today(), os.cpu_count(), photons))
print("| grid (mm) | clear= (or the medium) | solver | cells | clear cells | iterations | mg set-up (s) | solve (s) | peak (GB) | the coupling |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
for line in open(rows):
    print("| " + " | ".join(line.strip().split("|")) + " |")
print("\nThe brain's fluence against transport: the median of diffusion / transport over the brain's "
      "cells (scan values 45–120) in shells of distance from where the beam enters, and how many "
      "cells each shell has:\n")
print("| grid (mm) | clear= | 10–15 mm | 15–20 | 20–25 | 25–30 | all of 10–30 |")
print("|---|---|---:|---:|---:|---:|---:|")
shells = [(10, 15), (15, 20), (20, 25), (25, 30), (10, 30)]
for h in grids:
    mc = os.path.join(tmp, "%s-off-mc.csv" % h)
    xyz, ref, cls = cells(mc)
    brain = (cls >= 45) & (cls <= 120)
    top = xyz[(np.abs(xyz[:, 0]) < 1.5 * float(h)) & (np.abs(xyz[:, 1] - 20) < 1.5 * float(h))]
    entry = np.array([0.0, 20.0, top[:, 2].max() if len(top) else 70.0])
    r = np.linalg.norm(xyz - entry, axis=1)
    for clear in ("off", "effective", "radiosity"):
        path = os.path.join(tmp, "%s-%s-mg.csv" % (h, clear))
        if not os.path.exists(path):
            continue
        _, phi, _ = cells(path)
        out = []
        for lo, hi in shells:
            m = brain & (r >= lo) & (r < hi) & (ref > 0)
            out.append("%.3f (%d)" % (np.median(phi[m] / ref[m]), m.sum()) if m.sum() else "—")
        print("| %s | %s | %s |" % (h, clear, " | ".join(out)))
PY
echo "head-clear: wrote docs/head-clear.md" >&2
