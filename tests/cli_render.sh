#!/usr/bin/env bash
# -render: preview images (PNG, EXR) of a solution, with and without scattering.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# Spot lit from +x (light travels -x), seen from the front (+z): the lit side
# is on the right of each panel; compare=1 puts the no-scattering view on the
# right half of the image.
SCENE=(-read file=samples/spot.obj size=50 -voxelize dim=32 -material preset=marble
       -light type=directional dir=-1,0,0 intensity=1 -solve)
expect_exit 0 "render spot png+exr" -- "$OHM" "${SCENE[@]}" \
  -render file="$T/spot.png" size=128,64 compare=1 view=0,0,-1 \
  -render file="$T/spot.exr" size=64,48 -stats file="$T/spot.json"
check "render: logged" grep -q "rendered $T/spot.png: 128 x 64" "$T/stderr"

check "png: scattering lights the shadowed side" $PY - "$T/spot.png" <<'PY'
import sys
from PIL import Image
im = Image.open(sys.argv[1])
assert im.size == (128, 64) and im.mode == "RGB", (im.size, im.mode)
px = im.load()
bg = px[0, 0]
assert max(bg) < 80 and max(bg) - min(bg) <= 1, bg          # neutral dark grey
def panel(x0):
    obj = [(x, y) for y in range(64) for x in range(x0, x0 + 64) if px[x, y] != bg]
    assert len(obj) > 500, len(obj)
    xs = sorted(x for x, _ in obj)
    lo, hi = xs[len(xs) // 50], xs[-len(xs) // 50 - 1]
    w = hi - lo
    def mean(a, b):
        v = [sum(px[x, y]) / 3 for x, y in obj if lo + a * w <= x <= lo + b * w]
        return sum(v) / len(v)
    return mean(0.2, 0.5), mean(0.7, 1.0)                     # shadowed (left), lit (right)
s_dark, s_lit = panel(0)
l_dark, l_lit = panel(64)
print("scattering: shadowed %.1f lit %.1f; no scattering: shadowed %.1f lit %.1f" % (s_dark, s_lit, l_dark, l_lit))
assert s_lit > 120, s_lit                                     # not black
assert s_lit > s_dark + 20, (s_lit, s_dark)                   # lit side brighter
assert s_dark > max(l_dark + 15, 3 * l_dark), (s_dark, l_dark) # light bleeds into the shadow
assert 0.6 < s_lit / l_lit < 1.6, (s_lit, l_lit)              # lit side comparable
PY
check "exr: magic and size" $PY - "$T/spot.exr" <<'PY'
import sys
b = open(sys.argv[1], "rb").read()
assert b[:4] == bytes([0x76, 0x2f, 0x31, 0x01]), b[:4]
import struct
i = b.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0")
size, x0, y0, x1, y1 = struct.unpack("<5i", b[i:i + 20])
assert (size, x0, y0, x1, y1) == (16, 0, 0, 63, 47), (size, x0, y0, x1, y1)
i = b.index(b"channels\0chlist\0") + len(b"channels\0chlist\0")
chl = b[i + 4:i + 4 + struct.unpack("<i", b[i:i + 4])[0]]
for name in (b"R", b"G", b"B"):
    j = chl.index(name + b"\0") + 2
    assert struct.unpack("<i", chl[j:j + 4])[0] == 1, name        # pixel type 1 = HALF
PY
if command -v oiiotool >/dev/null; then
  check "exr: oiiotool reads it" bash -c "oiiotool --info '$T/spot.exr' | grep -q '64 x  *48'"
fi
check "stats: t_render" $PY -c "import json,sys; assert json.load(open(sys.argv[1]))['t_render'] >= 0" "$T/spot.json"
check "no temporary files left" bash -c "! ls -a '$T' | grep -q ohm-"

# errors
expect_exit 2 "render without a solution" -- "$OHM" -read file=samples/spot.obj -voxelize dim=16 \
  -render file="$T/x.png"
expect_error_line "no solution: one line" "no solution"
expect_exit 2 "render to .jpg" -- "$OHM" "${SCENE[@]}" -render file="$T/x.jpg"
expect_error_line "unsupported extension" "x\.jpg.*png or \.exr"
expect_exit 2 "render size=" -- "$OHM" "${SCENE[@]}" -render file="$T/x.png" size=10
expect_error_line "bad size" "size=10"
expect_exit 1 "render to a missing directory" -- "$OHM" "${SCENE[@]}" -render file="$T/nodir/x.png"
expect_error_line "unwritable path named" "nodir/x\.png"
check "nothing written on error" test ! -e "$T/x.jpg"

finish
