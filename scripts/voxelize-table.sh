#!/usr/bin/env bash
# Voxelize every bundled sample mesh at dim 32, 64 and 128 and print a Markdown
# table: interior cells, their volume against the mesh's enclosed volume
# (divergence theorem), and the times.  Usage: scripts/voxelize-table.sh [build/ohm]
set -euo pipefail
cd "$(dirname "$0")/.."
OHM=${1:-build/ohm}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
echo "| mesh | dim | grid | voxel (mm) | interior cells | cell volume (mm³) | mesh volume (mm³) | difference | open edges | read (s) | voxelize (s) | write (s) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for m in spot.obj cow.obj bunny00.off.gz knot1.off larger_sphere.off stanford-bunny.obj.gz ChineseDragon-10kv.off.gz head.off teapot.obj; do
  for d in 32 64 128; do
    "$OHM" --quiet -read file="samples/$m" -voxelize dim=$d -write file="$tmp/x.vdb" -stats file="$tmp/s.json" 2>/dev/null
    /usr/bin/python3 - "$m" "$d" "$tmp/s.json" <<'PY'
import json, sys
m, d, s = sys.argv[1], sys.argv[2], json.load(open(sys.argv[3]))
diff = 100 * (s["interior_volume_mm3"] - s["mesh_volume_mm3"]) / s["mesh_volume_mm3"]
note = "" if s["mesh_boundary_edges"] == 0 else " (open mesh: not comparable)"
print(f"| {m} | {d} | {s['grid_x']}×{s['grid_y']}×{s['grid_z']} | {s['voxel_mm']:.4g} | {s['cells']} | "
      f"{s['interior_volume_mm3']:.5g} | {s['mesh_volume_mm3']:.5g} | {diff:+.2f}%{note} | {s['mesh_boundary_edges']} | "
      f"{s['t_read']:.3f} | {s['t_voxelize']:.3f} | {s['t_write']:.3f} |")
PY
  done
done
