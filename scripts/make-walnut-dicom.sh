#!/usr/bin/env bash
# make-walnut-dicom.sh — write samples/walnut-dicom/, the bundled DICOM
# series: the walnut CT (samples/walnut_64x48x57_uint16.raw.gz, 0.625 mm
# voxels) as 57 CT slices through tests/write_dicom.py (pydicom).
#
# Geometry: axial slices (ImageOrientationPatient 1\0\0\0\1\0), the first
# voxel's centre at (-20, -15, -17.5) mm LPS, i.e. (20, 15, -17.5) mm RAS,
# so the walnut sits about the scanner's centre.  Values: the stored pixels
# are the raw file's own numbers, with RescaleSlope 0.125 and
# RescaleIntercept -1024 (RescaleType US: the walnut's scale is not
# Hounsfield's; the rescale is there so the sample exercises it), so a
# reader's values are raw / 8 - 1024, from -1024 to 1085.375.
# samples/walnut-dicom.transfer is samples/walnut.transfer on that scale.
#
#   bash scripts/make-walnut-dicom.sh   # (re)writes samples/walnut-dicom/
set -euo pipefail
cd "$(dirname "$0")/.."
py=/usr/bin/python3
out=samples/walnut-dicom
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
gzip -dc samples/walnut_64x48x57_uint16.raw.gz > "$tmp/walnut.raw"
"$py" - "$tmp/walnut.raw" "$tmp/values.raw" <<'PY'
import sys
import numpy as np
raw = np.fromfile(sys.argv[1], dtype="<u2").astype(np.float32)
(raw / 8 - 1024).astype("<f4").tofile(sys.argv[2])
PY
rm -rf "$out"
"$py" tests/write_dicom.py "$out" --raw "$tmp/values.raw" --type f32 --dims 64,48,57 \
    --matrix=-0.625,0,0,20,0,-0.625,0,15,0,0,0.625,-17.5 --slope 0.125 --intercept -1024 --rescale-type US \
    --stored u16 --thickness 0.625 --names ordered --description "walnut CT (Voreen), 0.625 mm" \
    --patient "walnut^ohm sample" --uid-seed "ohm walnut-dicom sample"
echo "wrote $out: $(ls "$out" | wc -l) files, $(du -sk "$out" | cut -f1) KB"
