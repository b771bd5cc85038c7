#!/usr/bin/env bash
# -export: a coloured binary PLY (read back by a reader written here, not
# ohm's) and POV-Ray density files with a scene that POV-Ray renders.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

# marble sphere lit from above (+y): RGB, both outputs
expect_exit 0 "export sphere" -- "$OHM" -read file=samples/larger_sphere.off size=30 -voxelize dim=20 \
  -material preset=marble -light type=directional dir=0,-1,0 -solve \
  -export ply="$T/sphere.ply" df3="$T/sphere" -stats file="$T/sphere.json"

# (1) the PLY, with a minimal reader of our own
cat >"$T/ply.py" <<'PY'
import struct, sys
def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[0] == "ply" and header[1] == "format binary_little_endian 1.0", header[:2]
    elems, comments = [], []
    for line in header[2:]:
        w = line.split()
        if w[0] == "comment": comments.append(line)
        elif w[0] == "element": elems.append((w[1], int(w[2]), []))
        elif w[0] == "property": elems[-1][2].append(w[1:])
    fmt = {"float": "f", "uchar": "B", "int": "i"}
    pos, out = end, {}
    for name, count, props in elems:
        if name == "vertex":
            assert all(p[0] != "list" for p in props)
            st = struct.Struct("<" + "".join(fmt[p[0]] for p in props))
            rows = [st.unpack_from(data, pos + i * st.size) for i in range(count)]
            pos += count * st.size
            out["vertex"] = ([p[1] for p in props], rows)
        else:
            assert props == [["list", "uchar", "int", "vertex_indices"]], props
            faces = []
            for _ in range(count):
                n = data[pos]; faces.append(struct.unpack_from("<%di" % n, data, pos + 1)); pos += 1 + 4 * n
            out["face"] = faces
    assert pos == len(data), (pos, len(data))
    return out, comments
PY
check "ply: vertices, properties, colours, lit side brighter" $PY - "$T/sphere.ply" samples/larger_sphere.off "$T/ply.py" <<'PY'
import sys
exec(open(sys.argv[3]).read())
ply, comments = read_ply(sys.argv[1])
nv, nf = map(int, open(sys.argv[2]).read().split("\n")[1].split()[:2])
names, rows = ply["vertex"]
assert len(rows) == nv and len(ply["face"]) == nf, (len(rows), nv, len(ply["face"]), nf)
for p in ("x", "y", "z", "exitance_r", "exitance_g", "exitance_b", "red", "green", "blue"):
    assert p in names, (p, names)
assert any(c.startswith("comment ohm exposure ") for c in comments), comments
ix = {n: i for i, n in enumerate(names)}
cols = {(r[ix["red"]], r[ix["green"]], r[ix["blue"]]) for r in rows}
assert len(cols) > 10, len(cols)
ys = [r[ix["y"]] for r in rows]; mid = (min(ys) + max(ys)) / 2
lum = lambda r: r[ix["red"]] + r[ix["green"]] + r[ix["blue"]]
top = [lum(r) for r in rows if r[ix["y"]] > mid]; bot = [lum(r) for r in rows if r[ix["y"]] < mid]
et = [r[ix["exitance_g"]] for r in rows if r[ix["y"]] > mid]; eb = [r[ix["exitance_g"]] for r in rows if r[ix["y"]] < mid]
assert sum(top) / len(top) > 1.5 * sum(bot) / len(bot), (sum(top) / len(top), sum(bot) / len(bot))
assert sum(et) / len(et) > 2 * sum(eb) / len(eb) and min(et + eb) >= 0
PY

# (2) the density files: padded sizes, file size, zero padding, max 65535
check "df3: header, size, padding" $PY - "$T" <<'PY'
import json, struct, sys
d = sys.argv[1]; s = json.load(open(d + "/sphere.json"))
dims = (s["grid_x"] + 2, s["grid_y"] + 2, s["grid_z"] + 2)
top = 0
for c in "rgb":
    data = open("%s/sphere_%s.df3" % (d, c), "rb").read()
    nx, ny, nz = struct.unpack(">3H", data[:6])
    assert (nx, ny, nz) == dims, ((nx, ny, nz), dims)
    assert len(data) == 6 + 2 * nx * ny * nz, len(data)
    v = struct.unpack(">%dH" % (nx * ny * nz), data[6:])
    at = lambda i, j, k: v[i + nx * (j + ny * k)]
    for j in range(ny):
        for i in range(nx):
            assert at(i, j, 0) == 0 and at(i, j, nz - 1) == 0
    for k in range(nz):
        for i in range(nx):
            assert at(i, 0, k) == 0 and at(i, ny - 1, k) == 0
        for j in range(ny):
            assert at(0, j, k) == 0 and at(nx - 1, j, k) == 0
    assert sum(1 for x in v if x) > 100
    top = max(top, max(v))
assert top == 65535, top
pov = open(d + "/sphere.pov").read()
assert "df3 scale factor" in pov and "millimetres" in pov and 'density_file df3 "sphere_g.df3"' in pov
PY

# (3) POV-Ray renders the scene; the camera's up is towards the light
if command -v povray >/dev/null; then
  t0=$(date +%s%N)
  if (cd "$T" && timeout 60 povray +Isphere.pov +Osphere.png +W64 +H64 -D +A0.3 Display=off >"$T/pov.log" 2>&1); then
    ok
    echo "povray: rendered 64x64 in $(( ($(date +%s%N) - t0) / 1000000 )) ms"
  else bad "povray failed: $(tail -5 "$T/pov.log")"; fi
  check "render: lit (upper) half brighter" $PY - "$T/sphere.png" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n"
pos, idat = 8, b""
while pos < len(data):
    n, typ = struct.unpack(">I4s", data[pos:pos + 8]); body = data[pos + 8:pos + 8 + n]; pos += 12 + n
    if typ == b"IHDR": w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
    elif typ == b"IDAT": idat += body
assert depth in (8, 16) and ctype in (2, 6), (depth, ctype)
bpp = (3 if ctype == 2 else 4) * depth // 8
raw, stride, prev, rows = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
for y in range(h):
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - bpp] if i >= bpp else 0; b = prev[i]; c = prev[i - bpp] if i >= bpp else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(line); prev = line
step = depth // 8
lum = [sum(r[x * bpp + ch * step] for x in range(w) for ch in range(3)) for r in rows]
upper, lower = sum(lum[:h // 2]), sum(lum[h // 2:])
assert upper > 1.3 * lower > 0, (upper, lower)
PY
elif [ "${CI:-}" = true ]; then
  bad "povray is not installed (CI=true): run scripts/install-deps.sh"
else
  echo "SKIP: povray is not installed; the render checks did not run (scripts/install-deps.sh installs it)" >&2
fi

# grey material: one density file and one float property; exposure= is recorded
expect_exit 0 "export grey" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=12 \
  -material sigma_a=0.01 sigma_s=1 -light dir=0,-1,0 -solve -export ply="$T/cow.ply" exposure=2.5 \
  df3="$T/cow.df3" quantity=exitance
check "grey: BASE.df3 and BASE.pov" test -s "$T/cow.df3" -a -s "$T/cow.pov" -a ! -e "$T/cow_r.df3"
check "grey ply: exitance, exposure 2.5" $PY - "$T/cow.ply" "$T/ply.py" <<'PY'
import sys
exec(open(sys.argv[2]).read())
ply, comments = read_ply(sys.argv[1])
assert "exitance" in ply["vertex"][0] and "exitance_r" not in ply["vertex"][0]
assert any(c.startswith("comment ohm exposure 2.5 ") for c in comments), comments
PY

# orbit: frame= picks a frame; past the last one is an error
expect_exit 0 "export frame 2" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=10 \
  -material sigma_a=0.01 sigma_s=1 -light dir=0,-1,0 orbit=2 -solve -export ply="$T/f2.ply" frame=2
expect_exit 1 "frame out of range" -- "$OHM" -read file=samples/cow.obj size=40 -voxelize dim=10 \
  -material sigma_a=0.01 sigma_s=1 -light dir=0,-1,0 -solve -export ply="$T/f3.ply" frame=3
expect_error_line "frame out of range" "frame=3: the solution has 1 frame"

# errors: nothing solved, no output named, unwritable path
expect_exit 2 "export before solve" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 -export ply="$T/x.ply"
expect_error_line "export before solve" "-export: nothing to export: run -solve first"
expect_exit 2 "export without outputs" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material preset=marble -light dir=0,-1,0 -solve -export
expect_error_line "export without outputs" "give ply=FILE, df3=BASE and/or csv=FILE"
expect_exit 1 "unwritable ply" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material preset=marble -light dir=0,-1,0 -solve -export ply="$T/no/such/dir/x.ply"
expect_error_line "unwritable ply" "$T/no/such/dir/x.ply"
expect_exit 1 "unwritable df3" -- "$OHM" -read file=samples/cow.obj -voxelize dim=8 \
  -material preset=marble -light dir=0,-1,0 -solve -export df3="$T/no/such/dir/x"
expect_error_line "unwritable df3" "$T/no/such/dir/x_r.df3"
check "no stray files" test -z "$(ls -A "$T" | grep -E '^\.|\.ohm-' || true)"

finish
