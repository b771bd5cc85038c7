#!/usr/bin/python3
"""Regenerate the bad-input corpus and MANIFEST.tsv (run from the repo root:
/usr/bin/python3 tests/data/corpus/generate.py). Each manifest row: file, how
to run it, expected exit code, a regex (grep -E) the one 'ohm: error:' line
must match, and a note. A note starting with [no-name] means ohm's error line
does not name this file (a known gap: the test then skips that check); exit 0
rows are inputs ohm accepts (VALID-RUNS: fine; KNOWN GAP: should be refused).
Inputs that need the file system (FIFO, directory, non-UTF-8 name, 5 MB
pipeline, .vdb grids) are made at run time by tests/cli_corpus.sh."""
import gzip, os, struct, zlib

D = os.path.dirname(os.path.abspath(__file__))
rows = []
ANY = r"(:[0-9]+)?: "

def esc(name):
    return name.replace(".", r"\.")

def add(name, data, how, code, pat=None, note="", whole=False):
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(D, name), "wb") as f:
        f.write(data)
    if pat is None or pat == ": ":
        pat = ANY
    rows.append((name, how, str(code), pat if whole else esc(name) + pat, note))

# ---- the valid small meshes that get truncated --------------------------
V = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
F = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
     (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]

def obj_text(v=V, f=F):
    return "".join("v %g %g %g\n" % p for p in v) + "".join("f %d %d %d\n" % (a+1, b+1, c+1) for a, b, c in f)

def off_text(v=V, f=F, head=None):
    h = head if head is not None else "OFF\n%d %d 0\n" % (len(v), len(f))
    return h + "".join("%g %g %g\n" % p for p in v) + "".join("3 %d %d %d\n" % t for t in f)

def ply_ascii(v=V, f=F, nv=None, nf=None):
    return ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (nv or len(v), nf or len(f))
            + "".join("%g %g %g\n" % p for p in v) + "".join("3 %d %d %d\n" % t for t in f))

def ply_bin_hdr(nv, nf):
    return ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n" % (nv, nf)).encode()

def ply_bin(v=V, f=F, nv=None, nf=None):
    return (ply_bin_hdr(nv if nv is not None else len(v), nf if nf is not None else len(f))
            + b"".join(struct.pack("<3f", *p) for p in v) + b"".join(struct.pack("<B3i", 3, *t) for t in f))

def tri_pts(t):
    return [V[i] for i in t]

def stl_ascii(f=F):
    s = "solid cube\n"
    for t in f:
        s += " facet normal 0 0 0\n  outer loop\n"
        for p in tri_pts(t):
            s += "   vertex %g %g %g\n" % p
        s += "  endloop\n endfacet\n"
    return s + "endsolid cube\n"

def stl_bin(tris, count=None, header=b"\0" * 80):
    d = header + struct.pack("<I", len(tris) if count is None else count)
    for t in tris:
        d += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *p) for p in t) + b"\0\0"
    return d

CUBE_TRIS = [tri_pts(t) for t in F]
LINE = r":[0-9]+:"

# ---- empty files of each format -----------------------------------------
for ext in ("obj", "ply", "stl", "off", "obj.gz"):
    add("empty." + ext, b"", "mesh", 1, ": .*empty")
add("empty-gzip.off.gz", gzip.compress(b"", mtime=0), "mesh", 1, ": .*empty",
    "a valid gzip stream holding nothing")
add("blank-lines.obj", "\n\n   \n# only a comment\n", "mesh", 1, ": ", "no vertices or faces")

# ---- truncations ----------------------------------------------------------
o = obj_text()
# cut inside lines so the last line is malformed (OBJ has no counts, so a cut
# at a line end is just a smaller valid mesh)
i = o.index("v 1 0 0") + len("v 1 0")
add("trunc-1.obj", o[:i], "mesh", 1, ":5:", "cut inside the 5th vertex line: 2 coordinates")
i = o.index("v 1 1 1") + 3
add("trunc-2.obj", o[:i], "mesh", 1, ":8:", "cut inside the last vertex line")
i = o.index("f 1 2 4") + len("f 1 2")
add("trunc-3.obj", o[:i], "mesh", 1, ":9:", "cut inside the first face: 2 vertices")
i = o.index("f 2 6 8") + len("f 2 6 ")
add("trunc-4.obj", o[:i], "mesh", 1, ":19:", "cut inside the 11th face")
i = o.index("f 2 8 4") + 1
add("trunc-5.obj", o[:i], "mesh", 1, ":20:", "cut after the last 'f'")

t = off_text()
for k, frac in enumerate((0.02, 0.1, 0.3, 0.5, 0.75, 0.97), 1):
    add("trunc-%d.off" % k, t[:int(len(t) * frac)], "mesh", 1, LINE, "first %d%% of a cube" % int(frac*100))

t = ply_ascii()
for k, frac in enumerate((0.05, 0.2, 0.5, 0.7, 0.85, 0.98), 1):
    add("trunc-ascii-%d.ply" % k, t[:int(len(t) * frac)], "mesh", 1, LINE, "first %d%% of a cube" % int(frac*100))

b = ply_bin()
hl = len(ply_bin_hdr(8, 12))
for k, cut in enumerate((hl // 2, hl, hl + 7, hl + 96, hl + 96 + 13 * 6 + 5, len(b) - 1), 1):
    add("trunc-bin-%d.ply" % k, b[:cut], "mesh", 1, ANY, "binary cube cut at byte %d of %d" % (cut, len(b)))

t = stl_ascii()
for k, frac in enumerate((0.03, 0.3, 0.6, 0.95), 1):
    add("trunc-ascii-%d.stl" % k, t[:int(len(t) * frac)], "mesh", 1, LINE, "first %d%% of an ASCII cube" % int(frac*100))

b = stl_bin(CUBE_TRIS)
for k, cut in enumerate((40, 83, 84 + 25, 84 + 50 * 6, len(b) - 1), 1):
    add("trunc-bin-%d.stl" % k, b[:cut], "mesh", 1, ": ", "binary cube cut at byte %d of %d" % (cut, len(b)))

g = gzip.compress(off_text().encode(), mtime=0)
add("trunc-gz-1.off.gz", g[:len(g) // 2], "mesh", 1, ": ", "gzip stream cut in half")
add("trunc-gz-2.off.gz", g[:12], "mesh", 1, ": ", "gzip stream cut after 12 bytes")

# ---- wrong magic ------------------------------------------------------------
add("magic.ply", ply_ascii().replace("ply\n", "plx\n", 1), "mesh", 1, ":1: .*PLY")
add("magic-format.ply", ply_ascii().replace("format ascii", "format ebcdic", 1), "mesh", 1, LINE)
add("magic.off", off_text(head="FOO\n8 12 0\n"), "mesh", 1, ":1: .*OFF")
add("magic.obj.gz", b"\x1f\x8cthis is not gzip at all", "mesh", 1, ": ")
add("png-bytes.obj", b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\0\x01\0\0\0\x01\x08\x02\0\0\0", "mesh", 1, ": ",
    "a PNG signature under an .obj name")
add("garbage.stl", bytes((i * 37 + 11) % 256 for i in range(300)), "mesh", 1, ": ", "300 junk bytes")

# ---- huge declared counts --------------------------------------------------
add("huge-faces.ply", ply_ascii(nf=10**12), "mesh", 1, ":7: .*1000000000000", "PLY claiming 10^12 faces")
add("huge-faces-bin.ply", ply_bin(nf=10**12), "mesh", 1, ": ", "binary PLY claiming 10^12 faces")
add("huge-verts.off", off_text(head="OFF\n1000000000000 12 0\n"), "mesh", 1, LINE, "OFF claiming 10^12 vertices")
add("huge-tris.stl", stl_bin(CUBE_TRIS, count=4000000000), "mesh", 1, ": ", "binary STL declaring 4e9 triangles")
add("huge-count-overflow.off", off_text(head="OFF\n99999999999999999999999 12 0\n"), "mesh", 1, LINE,
    "count beyond 64 bits")
add("negative-count.ply", ply_ascii().replace("element vertex 8", "element vertex -8"), "mesh", 1, ":3: .*-8")

# ---- negative / overflowing indices -----------------------------------------
add("index-neg-rel.obj", obj_text() + "f -1 -2 -99\n", "mesh", 1, ":21:", "relative index before the first vertex")
add("index-huge.obj", obj_text() + "f 1 2 99999999999999999999\n", "mesh", 1, ":21:")
add("index-int-max.obj", obj_text() + "f 1 2 2147483648\n", "mesh", 1, ":21:")
add("index-neg.off", off_text(f=F[:-1] + [(1, 7, -1)]), "mesh", 1, ":22: .*-1")
add("index-2p32.off", off_text(f=F[:-1] + [(1, 7, 4294967296)]), "mesh", 1, ":22: .*4294967296")
add("index-neg-bin.ply", ply_bin(f=F[:-1] + [(1, 7, -1)]), "mesh", 1, ": ")
add("index-big-bin.ply", ply_bin(f=F[:-1] + [(1, 7, 2**31 - 1)]), "mesh", 1, ": ")
add("index-neg-ascii.ply", ply_ascii(f=F[:-1] + [(1, 7, -5)]), "mesh", 1, ":29: .*-5")
add("face-size-huge.off", off_text().replace("3 1 7 3\n", "2000000000 1 7 3\n"), "mesh", 1, ":22: .*2000000000",
    "face declaring 2e9 corners")

# ---- NaN / Inf / 1e308 -------------------------------------------------------
add("nan.obj", obj_text().replace("v 1 1 1", "v 1 nan 1"), "mesh", 1, ":8:")
add("inf.obj", obj_text().replace("v 0 1 0", "v 0 inf 0"), "mesh", 1, ":3:")
add("big-1e308.obj", obj_text().replace("v 1 0 0", "v 1e308 0 0"), "mesh", 1, r"big-1e308\.obj|no finite volume",
    "coordinates near 1e308: the voxel has no finite volume, refused", whole=True)
add("big-1e309.off", off_text().replace("1 1 1\n", "1 1e309 1\n"), "mesh", 1, ":10:")
add("neg-inf.ply", ply_ascii().replace("0 0 1\n", "0 0 -inf\n", 1), "mesh", 1, LINE)
add("nan-bin.stl", stl_bin([CUBE_TRIS[0], [(0, 0, 0), (float("nan"), 0, 0), (0, 1, 0)]] + CUBE_TRIS[2:]),
    "mesh", 1, ": ", "binary STL with a NaN x")
add("inf-bin.ply", ply_bin(v=V[:-1] + [(1, float("inf"), 1)]), "mesh", 1, ": ")
add("nan-ascii.stl", stl_ascii().replace("vertex 0 0 1", "vertex 0 NaN 1", 1), "mesh", 1, LINE)

# ---- degenerate / zero-area / tiny --------------------------------------------
add("degenerate-all.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 1\nf 2 3 2\n", "mesh", 1,
    ": voxelize: the mesh is flat", "only zero-area faces on a line: read warns '3 degenerate triangles', voxelize refuses a mesh with no thickness")
add("point.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n", "mesh", 1, "voxelize: mesh has zero extent",
    "[no-name] three identical vertices: voxelize refuses it, but its error does not name the file", whole=True)
add("flat.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n", "mesh", 1,
    ": voxelize: the mesh is flat \\(zero thickness along z",
    "a flat square (zero volume): refused (was a known gap: 1 interior cell by rounding)")
add("single-triangle.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "mesh", 1, ": voxelize: the mesh is flat",
    "one triangle encloses nothing: refused")
add("no-faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "mesh", 1, ": ", "vertices only")
add("one-vertex-face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1\n", "mesh", 1, ":4:")

# ---- pipelines -----------------------------------------------------------------
P = "ohm-pipeline 1\n"
add("unknown-action.ohm", P + "read file=samples/cow.obj\nvoxelise dim=8\n", "pipeline", 2, ":3: .*voxelise")
add("self-run.ohm", P + "run file=self.ohm\n", "pipeline", 2, ":2: .*unknown action",
    "'run' is a command, not an action: a usage error, nothing runs")
add("bad-value.ohm", P + "read file=samples/cow.obj\nvoxelize dim=banana\n", "pipeline", 2, ":3: .*dim")
add("out-of-range.ohm", P + "read file=samples/cow.obj\nvoxelize dim=-5\n", "pipeline", 2, ":3: .*dim")
add("unknown-option.ohm", P + "read file=samples/cow.obj\nvoxelize dimm=8\n", "pipeline", 2, ":3: .*dimm")
add("missing-file.ohm", P + "read file=tests/data/corpus/nothere.obj\nvoxelize dim=8\n", "pipeline", 1,
    r"nothere\.obj: cannot open", "[no-name] the error names the missing mesh, not the pipeline file", whole=True)
add("no-header.ohm", "read file=samples/cow.obj\n", "pipeline", 2, ":1:")
add("bad-version.ohm", "ohm-pipeline 9\nread file=samples/cow.obj\n", "pipeline", 2, ":1:")
add("open-quote.ohm", P + 'read file="samples/cow.obj\n', "pipeline", 2, ":2:")
add("binary-junk.ohm", bytes((i * 73 + 5) % 256 for i in range(512)), "pipeline", 2, ":1: .*NUL")
add("nul-byte.ohm", P + "read file=samples/cow.obj\0\nvoxelize dim=8\n", "pipeline", 2, ":2:")
add("empty.ohm", b"", "pipeline", 2, ": ")
add("header-only.ohm", P, "pipeline", 2, ": ", "no actions")

# ---- transfer functions ---------------------------------------------------------
T = "ohm-transfer 1\n"
add("empty.transfer", b"", "transfer", 1, ":1: .*empty")
add("no-header.transfer", "0 0.1 1\n", "transfer", 1, ":1: .*header")
add("version.transfer", "ohm-transfer 2\n0 0.1 1\n", "transfer", 1, ":1: .*version")
add("header-word.transfer", "ohm-transfer 1 colour=rgb\n0 0.1 1\n", "transfer", 1, ":1: .*colour")
add("mode.transfer", "ohm-transfer 1 mode=magic\n0 0.1 1\n", "transfer", 1, ":1: .*magic")
add("eta.transfer", "ohm-transfer 1 eta=7\n0 0.1 1\n", "transfer", 1, ":1: .*eta")
add("columns.transfer", T + "0 0.1 0.1 0.1 1 1 1\n100 0.1 1\n", "transfer", 1, ":3: .*columns")
add("not-number.transfer", T + "0 0.1x 1\n", "transfer", 1, ":2: .*0\\.1x")
add("nan.transfer", T + "0 nan 1\n", "transfer", 1, ":2: .*nan")
add("inf.transfer", T + "0 0.1 inf\n", "transfer", 1, ":2: .*inf")
add("neg-sigma-a.transfer", T + "0 -0.1 1\n", "transfer", 1, ":2: .*sigma_a")
add("zero-sigma-s.transfer", T + "0 0.1 0\n", "transfer", 1, ":2: .*sigma_s")
add("zero-resistance.transfer", "ohm-transfer 1 mode=resistance\n0 0 1000\n", "transfer", 1, ":2: ")
add("rgb-resistance.transfer", "ohm-transfer 1 mode=resistance\n0 1 1 1 1 1 1\n", "transfer", 1, ":2: ")
add("not-increasing.transfer", T + "0 0.1 1\n100 0.1 1\n100 0.2 1\n", "transfer", 1, ":4: .*increasing")
add("no-points.transfer", T + "# nothing here\n", "transfer", 1, ":2: .*no control points")
add("long-line.transfer", T + "0 0.1 1" + " " * 5000 + "\n", "transfer", 1, ":2: ")
add("binary-junk.transfer", bytes((i * 91 + 3) % 256 for i in range(400)), "transfer", 1, ":1: .*NUL")
# finite numbers whose products overflow (an infinite sigma_a grid at -write, or a null
# power with -stats and exit 0, before the ranges of transfer.h)
add("huge-sigma-a.transfer", T + "0 1e300 1\n100 0.1 1\n", "transfer", 1, r":2: .*sigma_a\) must be in \[0, 1e\+06\]")
add("tiny-sigma-s.transfer", T + "0 0.1 1\n100 0.1 1e-300\n", "transfer", 1, r":3: .*sigma_s'\) must be in")
add("huge-resistance.transfer", "ohm-transfer 1 mode=resistance\n0 1e200 1000\n", "transfer", 1,
    ":2: .*must be in")

# ---- raw volumes ---------------------------------------------------------------------
add("empty.raw", b"", "raw:4,4,4:u8", 1, ": .*64 bytes")
add("short.raw", b"\1" * 63, "raw:4,4,4:u8", 1, ": .*63")
add("long.raw", b"\1" * 65, "raw:4,4,4:u8", 1, ": .*65")
add("short-u16.raw", b"\1" * 127, "raw:4,4,4:u16", 1, ": .*127")
add("short-f32.raw", b"\0" * 255, "raw:4,4,4:f32", 1, ": .*255")
add("nan-f32.raw", struct.pack("<64f", *([float("nan")] * 64)), "raw:4,4,4:f32", 1, ": ")
add("trunc.raw.gz", gzip.compress(b"\1" * 64, mtime=0)[:20], "raw:4,4,4:u8", 1, ": ")
add("huge-dims.raw", b"\1" * 64, "raw:65535,65535,65535:u8", 1, ": ")

# ---- NIfTI ----------------------------------------------------------------------------
def nifti(dims=(4, 4, 4), datatype=2, bitpix=8, magic=b"n+1\0", voxoff=352.0, data=None, sizeof=348):
    h = bytearray(348)
    struct.pack_into("<i", h, 0, sizeof)
    struct.pack_into("<8h", h, 40, len(dims), *(list(dims) + [1] * (7 - len(dims))))
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, voxoff)
    struct.pack_into("<f", h, 112, 1.0)
    h[344:348] = magic
    n = 1
    for d in dims:
        n *= max(d, 0)
    if data is None:
        data = bytes([(i * 7) % 200 for i in range(min(n, 4096) * bitpix // 8)])
    return bytes(h) + b"\0" * 4 + data

def nifti2(dims, data):
    h = bytearray(540)
    struct.pack_into("<i", h, 0, 540)
    h[4:12] = b"n+2\0\r\n\x1a\n"
    struct.pack_into("<hh", h, 12, 2, 8)
    struct.pack_into("<8q", h, 16, len(dims), *(list(dims) + [1] * (7 - len(dims))))
    struct.pack_into("<8d", h, 104, 1, 1, 1, 1, 1, 1, 1, 1)
    struct.pack_into("<q", h, 168, 544)
    struct.pack_into("<d", h, 176, 1.0)
    return bytes(h) + b"\0" * 4 + data

good = nifti()
add("empty.nii", b"", "nifti", 1, ": ")
add("trunc-header.nii", good[:200], "nifti", 1, ": ")
add("trunc-data.nii", good[:352 + 30], "nifti", 1, ": ")
add("magic.nii", nifti(magic=b"xyz\0"), "nifti", 1, ": NIfTI-1 magic is 'xyz', expected 'n\\+1'",
    "magic 'xyz' with sizeof_hdr 348: refused before libnifti2 (which would read it as Analyze 7.5)")
add("sizeof.nii", nifti(sizeof=1234), "nifti", 1, ": ")
add("huge-dims.nii", nifti(dims=(32767, 32767, 32767), data=b"\0" * 64), "nifti", 1, ": ",
    "NIfTI-1 declaring 32767^3 voxels (its dims are int16)")
add("huge-dims-2.nii", nifti2((65535, 65535, 65535), b"\0" * 64), "nifti", 1, ": ",
    "NIfTI-2 declaring 65535^3 voxels")
add("huge-dims-2-int64.nii", nifti2((2**40, 2**40, 2**40), b"\0" * 64), "nifti", 1, ": ",
    "NIfTI-2 dims whose product overflows 64 bits")
add("negative-dim.nii", nifti(dims=(4, -4, 4), data=b"\0" * 64), "nifti", 1, ": NIfTI-1 dim\\[2\\] is -4",
    "dim[2] = -4: refused before libnifti2 (which reads it as 1)")
add("zero-dim.nii", nifti(dims=(4, 0, 4), data=b""), "nifti", 1, ": ")
add("datatype.nii", nifti(datatype=1234, bitpix=8), "nifti", 1, ": ", "unknown datatype code")
add("trunc.nii.gz", gzip.compress(good, mtime=0)[:60], "nifti", 1, ": ")

# ---- .vdb (the error names the file as '/path/x.vdb' or path/x.vdb: ) ---------
add("empty.vdb", b"", "vdb", 1, r"empty\.vdb", whole=True)
add("junk.vdb", b"\x20\x42\x44\x56" + bytes(200), "vdb", 1, r"junk\.vdb: file format version 0", whole=True,
    note="VDB magic then zeros: refused by the .vdb checker (file format version 0)")
add("text.vdb", "this is not a vdb\n", "vdb", 1, r"text\.vdb", whole=True)

# ---- .vdb files that lie about sizes: the checker (src/input/scan_check.c) refuses
# them before OpenVDB 10 would trust them.  Each is the fuzz seed
# tests/fuzz/seeds/vdb/density-fog-4x4x4.vdb (one 4^3 float grid, blosc) with
# one field changed; vdb_fields() finds the fields the way OpenVDB reads them.
R = os.path.normpath(os.path.join(D, "..", "..", ".."))
SEED = open(os.path.join(R, "tests/fuzz/seeds/vdb/density-fog-4x4x4.vdb"), "rb").read()

def vdb_fields(b):
    u32 = lambda o: struct.unpack_from("<I", b, o)[0]
    f, p = {}, 8 + 4 + 8 + 1 + 36
    def string(p):
        return p + 4 + u32(p)
    def metamap(p, key):
        f[key + "count"] = p
        n, p = u32(p), p + 4
        for _ in range(n):
            name = b[p + 4:p + 4 + u32(p)].decode()
            p = string(p)
            typ = b[p + 4:p + 4 + u32(p)].decode()
            p = string(p)
            f[key + name] = (p, typ)          # the value's size field
            p += 4 + u32(p)
        return p
    p = metamap(p, "file:")
    p += 4                                       # grid count
    f["name"] = p
    p = string(string(string(p)))                # name, type, instance parent
    f["offsets"] = p
    p = struct.unpack_from("<q", b, p)[0]       # the grid offset
    f["compression"] = p
    p = metamap(p + 4, "grid:")
    p = string(p) + 144                          # a ScaleTranslateMap
    f["root"] = p                                # int32 buffers, float bg, uint32 tiles, children
    p += 16 + 12 + 2 * 4096
    flag = b[p]
    p += 1 + (8 if flag == 5 else 4 if flag in (2, 4) else 0) + (4096 if flag in (3, 4, 5) else 0)
    f["chunk"] = p                               # the first int64 blosc chunk size
    return f

VF = vdb_fields(SEED)

def vdb_patch(fmt, off, *vals):
    b = bytearray(SEED)
    struct.pack_into(fmt, b, off, *vals)
    return bytes(b)

def addv(name, data, pat, note):
    add(name, data, "vdb", 1, ": .*" + pat, note)

addv("vdb-version.vdb", vdb_patch("<I", 8, 300), "file format version 300", "file format version newer than OpenVDB 10's 224")
addv("vdb-uuid.vdb", SEED[:21] + b"Z" + SEED[22:], "UUID", "a non-hex character in the 36-character UUID")
addv("vdb-name-length.vdb", vdb_patch("<I", VF["name"], 0xFFFFFFFF),
     "grid descriptor 0 name length 4294967295 at byte [0-9]+ exceeds", "grid name length 2^32-1 (OpenVDB: a 4 GB string)")
addv("vdb-end-offset.vdb", vdb_patch("<q", VF["offsets"] + 16, 1 << 40), "grid 'density' offsets .* outside the 10199-byte file",
     "grid end offset 2^40")
addv("vdb-file-meta-count.vdb", vdb_patch("<I", VF["file:count"], 0xFFFFFFF0), "the file declares 4294967280 metadata entries",
     "file metadata count near 2^32")
addv("vdb-meta-value.vdb", vdb_patch("<I", VF["grid:class"][0], 0xFFFFFFF0),
     "metadata 'class' value length 4294967280 .* exceeds", "a string metadata value of 4 GB")
addv("vdb-meta-fixed.vdb", vdb_patch("<I", VF["grid:file_mem_bytes"][0], 0),
     "metadata 'file_mem_bytes' value of type int64 is 0 bytes, expected 8",
     "an int64 metadata value stored as 0 bytes (OpenVDB reads 8 whatever the size says, and would drift)")
addv("vdb-delayed-count.vdb", vdb_patch("<I", VF["grid:file_delayed_load"][0] + 4, 0x40000000),
     "file_delayed_load' value declares 1073741824 leaves", "delayed-load metadata declaring 2^30 leaves (OpenVDB: a 1 GB+8 GB vector)")
addv("vdb-compression.vdb", vdb_patch("<I", VF["compression"], 0x80), "compression flags are 0x80", "unknown compression flags")
addv("vdb-tile-count.vdb", vdb_patch("<I", VF["root"] + 8, 0xFFFFFFFF), "root node declares 4294967295 tiles",
     "root node with 2^32-1 tiles (OpenVDB: minutes of reading past the end)")
addv("vdb-child-count.vdb", vdb_patch("<I", VF["root"] + 12, 1000), "root node declares 0 tiles and 1000 children",
     "root node with 1000 children in a 10 KB file")
addv("vdb-blosc-size.vdb", vdb_patch("<q", VF["chunk"], 0x7FFFFFFFFFFFFFF0), "blosc chunk size 9223372036854775792",
     "a blosc chunk of 2^63 bytes (OpenVDB: allocates it)")
addv("vdb-blosc-raw.vdb", vdb_patch("<q", VF["chunk"], -100000), "a raw blosc chunk of 100000 bytes",
     "a raw chunk bigger than the values it holds")
addv("vdb-truncated.vdb", SEED[:6000], "offsets .* outside the 6000-byte file", "the seed cut at 6000 bytes")
add("vdb-no-grids.vdb", SEED[:VF["name"] - 4] + struct.pack("<i", 0), "vdb", 1, ": the file holds no grids",
    "a valid header and file metadata, grid count 0 (a data error: exit 1)")

# ---- fuzz findings (regressions): tests/fuzz/crashes/HARNESS/; docs/fuzzing.md
def crash(harness, name):
    return open(os.path.join(R, "tests/fuzz/crashes", harness, name), "rb").read()

add("fuzz-oom-header.nii", crash("nifti", "oom-2f3e7c5d7be373ec0ce0340280df16b67c4b73eb")[1:], "nifti", 1,
    ": truncated: .*more than the 608-byte file can hold",
    "fuzz finding (regression): NIfTI-2 header declaring 2.7 GB of float64 in a 608-byte file; refused before allocating")
add("fuzz-nifti2-magic-1.nii", crash("nifti", "crash-b4fd2bb5e1a537ee15d41cde93accd0f0c5da843")[1:], "nifti", 1,
    ": NIfTI-2 magic is", "fuzz finding (regression): NIfTI-2 header with a corrupt magic and datatype; libnifti2 3.0.1 smashed its stack")
add("fuzz-nifti2-magic-2.nii", crash("nifti", "crash-7ce77c730ff2be0d8350e4db5cf147c65ced0ce5")[1:], "nifti", 1,
    ": NIfTI-2 magic is", "fuzz finding (regression): as fuzz-nifti2-magic-1.nii")
add("fuzz-blosc-alloc.vdb", crash("vdb", "crash-6cd7215baa6af398ab3820441eee739392353649"), "vdb", 1,
    ": grid 0 \\('density'\\) internal node \\(level 2\\) at byte [0-9]+ has 2 children",
    "fuzz finding (regression): OpenVDB allocated 0x7fff83b1dfd8 bytes in bloscFromStream")
add("fuzz-topology-leak.vdb", crash("vdb", "leak-713c7d4457e872b634cd40eb22e591d8f32520c4"), "vdb", 1,
    ": grid 0 \\('density'\\) internal node \\(level 2\\) values: blosc header",
    "fuzz finding (regression): OpenVDB leaked a node in RootNode::readTopology")
add("fuzz-string-4gb.vdb", crash("vdb", "oom-605fb319761edcef2cabd8c832b6e2599a95cded"), "vdb", 1,
    ": grid descriptor 0 instance parent length 4294967276",
    "fuzz finding (regression): OpenVDB allocated a 4 GB string in GridDescriptor::read")
add("fuzz-delayed-load.vdb", crash("vdb", "oom-cd679bc90624b8562fbe3dd7839fdd4890eb935b"), "vdb", 1,
    ": grid 'density' offsets .* outside the 1295-byte file",
    "fuzz finding (regression): OpenVDB allocated 1.1 GB in DelayedLoadMetadata::readValue")
add("fuzz-tile-loop.vdb", crash("vdb", "timeout-68bebc77545db8999dce46f1f3728cc0f1525b5f"), "vdb", 1,
    ": grid 'density' offsets .* outside the 8088-byte file",
    "fuzz finding (regression): OpenVDB spent >10 s in RootNode::readTopology")

add("fuzz-nifti-inf-bounds.nii", crash("nifti", "crash-38d49ba9b605211527b38be21df670f3469db0fd")[1:], "nifti", 1,
    ": the voxel-to-world transform is singular or overflows",
    "fuzz finding (regression, 2026-11-22): sform entries ~1e296 put the voxels at infinite coordinates; was accepted by the reader")
add("fuzz-vdb-empty-root.vdb", crash("vdb", "crash-cfd0cd52a74ee83cfe5bcab828acb1d9c0b2a3ae"), "vdb", 1,
    ": .*topology ends at byte 664",
    "fuzz finding (regression, 2026-11-22): an empty root node made the checker qsort a NULL array (UB)")

# ---- scan formats (docs/scans.md): INRIMAGE-4, NRRD, MetaImage -----------------------
def inr(fields, data, end=True):
    """An INR file: KEY=VALUE lines padded with newlines to a 256-byte header."""
    head = "#INRIMAGE-4#{\n" + "".join("%s=%s\n" % kv for kv in fields)
    head = head.ljust(252, "\n") + "##}\n" if end else head.ljust(256, "\n")
    return head.encode() + data

INR_FIELDS = [("XDIM", 4), ("YDIM", 3), ("ZDIM", 2), ("VDIM", 1), ("TYPE", "signed fixed"), ("PIXSIZE", "16 bits"),
              ("SCALE", "2**0"), ("CPU", "decm"), ("VX", 1), ("VY", 1), ("VZ", 1)]
VOXELS = bytes(range(48))  # 4 x 3 x 2 16-bit voxels
S16 = "ohm: scan formats"
add("unknown-type.inr", inr([(k, "complex" if k == "TYPE" else v) for k, v in INR_FIELDS], VOXELS), "scan", 1,
    ANY + ".*TYPE=complex", S16)
add("truncated.inr", inr(INR_FIELDS, VOXELS[:30]), "scan", 1, ANY + ".*truncated", S16)
add("no-end.inr", inr(INR_FIELDS, VOXELS, end=False), "scan", 1, ANY + ".*does not end", S16)
NRRD = "NRRD0004\ntype: short\ndimension: 3\nsizes: %s\nendian: little\nencoding: %s\n"
add("missing-data.nhdr", NRRD % ("4 3 2", "raw") + "data file: nowhere.raw\n", "scan", 1, ANY + ".*couldn't open", S16)
add("bad-magic.nrrd", "NRRD000-pi\ntype: short\n", "scan", 1, ANY + ".*not a NRRD file", S16)
add("bomb.nrrd", (NRRD % ("1000 1000 1000", "gzip") + "\n").encode() + gzip.compress(bytes(32), mtime=0), "scan", 1,
    ANY + ".*truncated", S16 + ": 2 GB declared, 32 bytes of gzip")
META = "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = %s\nElementDataFile = %s\n"
add("truncated.mha", (META % ("MET_SHORT", "LOCAL")).encode() + VOXELS[:20], "scan", 1, ANY + ".*truncated", S16)
add("list.mhd", META % ("MET_SHORT", "LIST") + "slice1.raw\n", "scan", 1, ANY + ".*list of slice files", S16)
add("bad-type.mha", (META % ("MET_LONG_LONG", "LOCAL")).encode() + VOXELS, "scan", 1, ANY + ".*MET_LONG_LONG", S16)

# ---- honest bombs (docs/bad-input.md): each header declares what its stream holds,
# 57.6e6 zero bytes (reading them would take 288 MB, over the readers'
# 256 MiB floor) from ~56 KB of deflate, a bomb's 1030 voxels per byte (over
# max_expansion's 500): each
# is refused by the readers' shared budget before anything is allocated
# (cli_corpus.sh also holds each run's peak memory to a few hundred MB).
BOMB = (480, 400, 300)
BOMB_ZEROS = bytes(BOMB[0] * BOMB[1] * BOMB[2])
BOMB_NOTE = "bomb: an honest header over 57.6 MB of zeros"
def gz(data):
    return gzip.compress(data, 9, mtime=0)
add("bomb-honest.nii.gz", gz(nifti(BOMB, data=BOMB_ZEROS)), "scan", 1, ANY + ".*decompression bomb", BOMB_NOTE)
add("bomb-honest.raw.gz", gz(BOMB_ZEROS), "raw:%d,%d,%d:u8" % BOMB, 1, ANY + ".*decompression bomb", BOMB_NOTE)
add("bomb-honest.inr.gz", gz(inr([("XDIM", BOMB[0]), ("YDIM", BOMB[1]), ("ZDIM", BOMB[2]), ("VDIM", 1),
                                  ("TYPE", "unsigned fixed"), ("PIXSIZE", "8 bits"), ("CPU", "decm")], BOMB_ZEROS)),
    "scan", 1, ANY + ".*decompression bomb", BOMB_NOTE)
add("bomb-honest.nrrd", ("NRRD0004\ntype: uchar\ndimension: 3\nsizes: %d %d %d\nencoding: gzip\n\n" % BOMB).encode()
    + gz(BOMB_ZEROS), "scan", 1, ANY + ".*decompression bomb", BOMB_NOTE)
add("bomb-honest.mha", ("ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementType = MET_UCHAR\n"
                        "CompressedData = True\nElementDataFile = LOCAL\n" % BOMB).encode()
    + zlib.compress(BOMB_ZEROS, 9), "scan", 1, ANY + ".*decompression bomb", BOMB_NOTE)

# ---- DICOM (docs/scans.md): one bad slice per folder (a folder is read as a series,
# and one broken file fails the whole folder, so each case needs its own).
# Written through tests/write_dicom.py's pydicom code; series (gaps,
# duplicates, two series, a DICOMDIR) are made at run time by
# tests/cli_corpus.sh.
def add_slice_folder(folder, data, code, pat, note, names_file=True):
    import shutil
    shutil.rmtree(os.path.join(D, folder), ignore_errors=True)
    os.makedirs(os.path.join(D, folder))
    with open(os.path.join(D, folder, "IM0001.dcm"), "wb") as f:
        f.write(data)
    where = esc(folder) + ("/IM0001" + esc(".dcm") if names_file else "")
    rows.append((folder, "scan", str(code), where + ": " + pat, note))

def dicom(name, change, pattern, code=1, cut=0, names_file=True):
    import argparse, io, sys
    sys.path.insert(0, os.path.join(D, "..", ".."))
    import numpy as np
    import write_dicom
    args = argparse.Namespace(description="ohm corpus", patient="ohm^corpus", thickness=1.0, slope=1.0,
                              intercept=0.0, stored="u16", rescale_type="US", uid_seed="ohm corpus " + name)
    ds = write_dicom.slice_dataset(args, 0, np.arange(12).reshape(3, 4), [1, 0, 0, 0, 1, 0], [0.5, 0.5],
                                   [0.0, 0.0, 0.0], write_dicom.uid(args, "study"), write_dicom.uid(args, "series"), 1)
    change(ds)
    out = io.BytesIO()
    ds.save_as(out, write_like_original=False)
    data = out.getvalue()
    add_slice_folder(name, data[:len(data) - cut] if cut else data, code, pattern, "ohm: DICOM",
                     names_file)

def frames(ds):
    ds.NumberOfFrames = 2

def rgb(ds):
    ds.SamplesPerPixel, ds.PhotometricInterpretation, ds.PlanarConfiguration = 3, "RGB", 0
    ds.PixelData = bytes(3 * 2 * 12)

def junk_pixels(ds):
    ds.PixelData = bytes(5)

dicom("dicom-truncated", lambda ds: None, ".*truncated or corrupt", cut=7)
dicom("dicom-short-pixels", junk_pixels, ".*truncated pixel data")
dicom("dicom-no-position", lambda ds: delattr(ds, "ImagePositionPatient"), ".*no ImagePositionPatient")
dicom("dicom-skew", lambda ds: setattr(ds, "ImageOrientationPatient", ["1", "0", "0", "1", "0", "0"]),
      ".*perpendicular unit vectors")
dicom("dicom-frames", frames, ".*2 frames in one file")
dicom("dicom-no-spacing", lambda ds: setattr(ds, "PixelSpacing", ["0", "0.5"]), ".*positive PixelSpacing")
dicom("dicom-rgb", rgb, ".*3 samples per pixel \\(0028,0002\\)")
dicom("dicom-zero-slope", lambda ds: setattr(ds, "RescaleSlope", "0"), ".*RescaleSlope .*non-zero slope")
dicom("dicom-huge", lambda ds: (setattr(ds, "Rows", 65535), setattr(ds, "Columns", 65535)),
      ".*more than the limit", names_file=False)
add_slice_folder("dicom-junk", bytes(128) + b"DICM" + bytes(range(256)) * 4, 1, ".*not a DICOM Part 10 file",
                 "ohm: DICOM: the mark and then noise")

# DICOM fuzz findings (scripts/fuzz.sh dicom, 2026-12-03): GDCM 3.0.21 allocates
# declared lengths and asserts (aborts) on bad VRs; the pre-pass refuses them
for name, crash_file, pattern, what in (
        ("fuzz-dicom-oom-meta", "oom-589eedd7b2b5d98c7d014af004bd0ca15b89eddb", "has VR '03', not one of DICOM's",
         "an unknown VR in the meta group: GDCM read a 1.3 GB length"),
        ("fuzz-dicom-oom-vr", "oom-ed9e0be83d97bc4dd7e571f2e5196869fb90f8ca", "has VR '81', not one of DICOM's",
         "an unknown VR: GDCM read a 943 MB length"),
        ("fuzz-dicom-oom-swapped", "oom-f689ac3bf678842d16ed10bdd6f0da537a52a463", "no TransferSyntaxUID",
         "no meta group: GDCM guessed big endian and read a 3.5 GB length"),
        ("fuzz-dicom-meta-length", "crash-4cf87d5a8dbda3808632aad6f05c801fcba0d69d", "length \\(0002,0000\\) runs to byte",
         "the meta group runs past the file: GDCM asserted reading the next tag"),
        ("fuzz-dicom-samples", "crash-71844e66744b0650541ce3314de5e936909e13c5", "5 samples per pixel",
         "GDCM asserted in PixelFormat::SetSamplesPerPixel"),
        ("fuzz-dicom-vr-planar", "crash-94df232651e151a4b50331a817ecd55604f2168f", "\\(0028,0006\\) .*has VR 'CS'",
         "GDCM asserted in Attribute::SetFromDataElement (PlanarConfiguration)"),
        ("fuzz-dicom-vr-sign", "crash-0a2fdc1f409c220da15aebb2bd98d6461682be87", "\\(0028,0103\\) .*has VR 'UL'",
         "GDCM asserted in Attribute::SetFromDataSet (PixelRepresentation)")):
    add_slice_folder(name, crash("dicom", crash_file), 1, ".*" + pattern, "fuzz finding (regression): " + what)

# ---- slice folders (docs/scans.md): four slices, the last cut to half its bytes.
# The decoders read what is there and, for TIFF, returned success with the
# rest of the slice left undecoded; a partial slice must fail the read and
# be named.  Written by hand (struct, zlib): 16 x 12 8-bit grey, pixels that
# deflate cannot shrink much, so half a PNG ends inside its image data.
SLICE_W, SLICE_H = 16, 12

def slice_pixels(z):
    return bytes((x * 37 + y * 101 + z * 53) * 7 % 251 for y in range(SLICE_H) for x in range(SLICE_W))

def tiff_slice(px):
    """Baseline TIFF, little-endian: one uncompressed strip after the IFD."""
    entries = [(256, 3, 1, SLICE_W), (257, 3, 1, SLICE_H), (258, 3, 1, 8), (259, 3, 1, 1), (262, 3, 1, 1),
               (273, 4, 1, 0), (277, 3, 1, 1), (278, 3, 1, SLICE_H), (279, 4, 1, len(px))]
    data_at = 8 + 2 + 12 * len(entries) + 4
    ifd = struct.pack("<H", len(entries))
    for tag, typ, count, value in entries:
        value = data_at if tag == 273 else value
        ifd += struct.pack("<HHI", tag, typ, count) + (struct.pack("<HH", value, 0) if typ == 3 else struct.pack("<I", value))
    return b"II*\x00" + struct.pack("<I", 8) + ifd + struct.pack("<I", 0) + px

def png_slice(px):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff)
    rows = b"".join(b"\x00" + px[y * SLICE_W:(y + 1) * SLICE_W] for y in range(SLICE_H))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", SLICE_W, SLICE_H, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))

def truncated_stack(folder, ext, encode):
    import shutil
    shutil.rmtree(os.path.join(D, folder), ignore_errors=True)
    os.makedirs(os.path.join(D, folder))
    for z in range(4):
        data = encode(slice_pixels(z))
        with open(os.path.join(D, folder, "s%02d%s" % (z, ext)), "wb") as f:
            f.write(data[:len(data) // 2] if z == 3 else data)
    rows.append((folder, "scan", "1", esc(folder + "/s03" + ext) + ": cannot read pixels",
                 "a slice cut to half its bytes"))

truncated_stack("stack-truncated-tif", ".tif", tiff_slice)
truncated_stack("stack-truncated-png", ".png", png_slice)

with open(os.path.join(D, "MANIFEST.tsv"), "w") as f:
    f.write("# file\thow\texit\tregex (grep -E) for the ohm: error: line\tnote\n")
    for r in rows:
        f.write("\t".join(r) + "\n")
print(len(rows), "files")
