#!/usr/bin/env bash
# ohm's serial stages beside solver=mg (docs/serial-stages.md): on the block
# medium of N^3 cells (scripts/block-medium.py; default N = 464, 1.0e8
# cells), the chain is run as its prefixes — read; + voxelize; + material;
# + light and solve; + write .vdb — and each prints the whole-process peak
# RSS (/usr/bin/time) and its stages' times (-stats).  Printed as a Markdown
# table of bytes and ns per interior cell (docs/serial-stages.md holds a
# measured one): a stage's bytes are what its prefix's peak adds to the
# prefix before it.  It reports; it asserts nothing.
#
#   scripts/stages-mg.sh [BUILD_DIR] [N]
#
# Needs ~10 GB of memory and ~3 minutes at N = 464; run it with nothing else
# busy (the times are wall clock).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
N=${2:-464}
OHM="$BUILD/ohm"
[ -x "$OHM" ] || { echo "stages-mg: no $OHM (build ohm first)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scripts/block-medium.py "$N" "$tmp/blocks.raw" "$tmp/blocks.transfer"

read_=(-read file="$tmp/blocks.raw" dims="$N,$N,$N" type=u8 spacing=1)
voxelize=(-voxelize dim="$N" threshold=5)
material=(-material transfer="$tmp/blocks.transfer")
solve=(-light type=directional dir=0,-1,0 intensity=1 -solve solver=mg)
write=(-write file="$tmp/blocks.vdb")

# prefix LABEL -- ohm arguments: its peak RSS (bytes) into $tmp/LABEL.rss,
# its stats into $tmp/LABEL.json
prefix() {
  local label=$1
  shift 2
  /usr/bin/time -f "%M" -o "$tmp/$label.rss" "$OHM" --quiet "$@" -stats file="$tmp/$label.json" >/dev/null
}
prefix read -- "${read_[@]}"
prefix voxelize -- "${read_[@]}" "${voxelize[@]}"
prefix material -- "${read_[@]}" "${voxelize[@]}" "${material[@]}"
prefix solve -- "${read_[@]}" "${voxelize[@]}" "${material[@]}" "${solve[@]}"
prefix write -- "${read_[@]}" "${voxelize[@]}" "${material[@]}" "${solve[@]}" "${write[@]}"

echo "## The serial stages beside solver=mg: blocks $N^3 ($BUILD, $(git rev-parse --short HEAD), $(date -u +%F))"
echo
echo "load average before the table: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
/usr/bin/python3 - "$tmp" <<'PY'
import json
import sys

tmp = sys.argv[1]
stats = {p: json.load(open(f"{tmp}/{p}.json")) for p in ("read", "voxelize", "material", "solve", "write")}
rss = {p: int(open(f"{tmp}/{p}.rss").read().split()[-1]) * 1024 for p in stats}
full = stats["write"]
n = full["cells"]
t = lambda k: full.get(k, 0.0) or 0.0
# each prefix's stages, with the time keys -stats gives them
rows = [
    ("read", "read the raw volume", ["t_read"]),
    ("voxelize", "voxelize (threshold)", ["t_voxelize"]),
    ("material", "material (transfer function)", []),
    ("solve", "network, assembly, mg set-up, sources, solve", ["t_network", "t_assemble", "t_cg_setup", "t_source", "t_solve"]),
    ("write", "write .vdb", ["t_write"]),
]
print(f"{n} interior cells; {full['cg_iterations']} iterations; solver_bytes {full['solver_bytes'] / n:.1f} B/cell "
      f"(mg's hierarchy and the stencil it reads)")
print()
print("| prefix ends with | ns per cell | of which | peak RSS (B/cell) | added by the stage (B/cell) |")
print("|---|---:|---|---:|---:|")
before = 0
for p, what, keys in rows:
    ns = sum(t(k) for k in keys) / n * 1e9
    parts = ", ".join(f"{k[2:]} {t(k) / n * 1e9:.0f}" for k in keys) if len(keys) > 1 else ""
    print(f"| {what} | {ns:.0f} | {parts} | {rss[p] / n:.1f} | {(rss[p] - before) / n:+.1f} |")
    before = rss[p]
print()
print(f"whole run: {rss['write'] / 2**20:.0f} MiB peak ({rss['write'] / 1e9:.2f} GB), per light per channel "
      f"{t('t_solve'):.1f} s")
PY
