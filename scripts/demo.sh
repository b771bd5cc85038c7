#!/usr/bin/env bash
# The README's first command: install what is missing, build ohm, and run the
# main job on a bundled sample mesh.  Outputs land in out/ (printed at the end).
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"

mkdir -p out
./build/ohm run pipelines/spot.ohm

echo
echo "ohm demo: wrote"
for f in out/spot.vdb out/spot.json out/spot.png; do
  [ -f "$f" ] && echo "  $PWD/$f ($(stat -c %s "$f") bytes)"
done
echo "Grids: surface, density, fluence_r/g/b, exitance_r/g/b (world mm)."
echo "out/spot.png is a preview: with scattering (left), without (right)."
echo "Open out/spot.vdb in Blender (File > Import > OpenVDB) or inspect it with"
echo "  /usr/bin/python3 -c 'import pyopenvdb as v; print([g.name for g in v.readAll(\"out/spot.vdb\")[0]])'"
