#!/usr/bin/env bash
# cli_install.sh — libohm as a product (include/ohm.h): `cmake --install`
# into a clean prefix puts the header, the library (with its SONAME), the
# command, ohm.pc and the CMake package in place; examples/ builds against
# that prefix by pkg-config and by find_package(ohm); the installed command
# runs from the prefix alone; and the example's power balance and the
# command's for the same scene agree to 1e-12 (both are clients of one API).
set -euo pipefail
source "$(dirname "$0")/lib.sh" "$1"
BUILD=$(dirname "$(realpath "$OHM")")
P="$T/prefix"
cmake --install "$BUILD" --prefix "$P" >/dev/null
LIBDIR=$(dirname "$(find "$P" -name libohm.so -print -quit)")
check "header installed" test -f "$P/include/ohm.h" -a -f "$P/include/ohm/common.h"
check "library with SONAME" bash -c "objdump -p '$LIBDIR/libohm.so' | grep -q 'SONAME *libohm.so.1'"
check "pkg-config file" test -f "$LIBDIR/pkgconfig/ohm.pc"
check "CMake package" test -f "$LIBDIR/cmake/ohm/ohmConfig.cmake"
# (and the four BLAS/LAPACK routines ohm puts in front of CHOLMOD's calls,
# for progress and cancellation inside a factorization: factor_watch.h)
check "only the API exported" bash -c "! nm -D --defined-only '$LIBDIR/libohm.so' | awk '\$2 == \"T\" {print \$3}' | grep -v -E '^(ohm_|dsyrk_\$|dgemm_\$|dtrsm_\$|dpotrf_\$)'"

# the sanitizer pass: programs linking a sanitized libohm need the runtime first
CFLAGS_EXTRA=""
if [ "$SANITIZED" = 1 ]; then CFLAGS_EXTRA="-fsanitize=address,undefined"; fi
export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
for ex in voxelize_and_solve relight; do
  check "$ex builds by pkg-config" cc -std=c11 -Wall -Wextra -pedantic -Werror $CFLAGS_EXTRA examples/$ex.c \
    $(pkg-config --cflags --libs ohm) -lm -Wl,-rpath,"$LIBDIR" -o "$T/$ex"
done
check "examples build by find_package(ohm)" bash -c \
  "cmake -S examples -B '$T/ex-build' -DCMAKE_PREFIX_PATH='$P' -DCMAKE_C_FLAGS='$CFLAGS_EXTRA' >/dev/null && cmake --build '$T/ex-build' >/dev/null"

# the installed command, from the prefix alone (its RPATH finds the library)
check "installed ohm runs" bash -c "env -u LD_LIBRARY_PATH '$P/bin/ohm' --version | grep -q '^ohm 1\\.'"
# images come from the module beside the library, loaded on first use
check "image module installed beside libohm" test -f "$LIBDIR/libohm_oiio.so"
check "installed ohm renders a PNG" env -u LD_LIBRARY_PATH "$P/bin/ohm" -q -read file=samples/cow.obj -voxelize dim=16 \
  -material preset=marble -light dir=0,-1,0 -solve -render file="$T/installed.png"
check "the PNG is one" bash -c "head -c 8 '$T/installed.png' | od -An -tx1 | grep -q '89 50 4e 47'"
check "and ohm starts without loading OpenImageIO" bash -c \
  "! env -u LD_LIBRARY_PATH LD_DEBUG=files '$P/bin/ohm' --version 2>&1 | grep -q 'OpenImageIO'"
# without the module, images fail with one clear line; everything else works
cp -a "$P" "$T/broken"
rm "$(dirname "$(find "$T/broken" -name libohm.so -print -quit)")/libohm_oiio.so"
expect_exit 1 "render without the image module" -- env -u LD_LIBRARY_PATH "$T/broken/bin/ohm" -q \
  -read file=samples/cow.obj -voxelize dim=16 -material preset=marble -light dir=0,-1,0 -solve \
  -render file="$T/none.png" -stats file="$T/none.json"
expect_error_line "render without the image module" "none\.png: images need ohm's OpenImageIO module libohm_oiio\.so"
check "and it wrote nothing" test ! -e "$T/none.png" -a ! -e "$T/none.json"
"$T/voxelize_and_solve" samples/cow.obj 24 "$T/ex.vdb" > "$T/example.txt"
check "example wrote its .vdb" test -s "$T/ex.vdb"
"$P/bin/ohm" -q -read file=samples/cow.obj size=50 -voxelize dim=24 -material preset=marble \
  -light type=directional dir=0,-1,-0.5 -solve -stats file="$T/cli.json"
check "example and command agree to 1e-12" $PY - "$T/example.txt" "$T/cli.json" <<'PYEOF'
import json, sys
ex = dict(l.split()[0:2] for l in open(sys.argv[1]) if l.startswith("power_"))
st = json.load(open(sys.argv[2]))
bad = 0
for k in ("power_in", "power_absorbed", "power_out"):
    a, b = float(ex[k]), st[k]
    rel = abs(a - b) / abs(b)
    print("%s: example %.17g, command %.17g, relative %.3g" % (k, a, b, rel))
    bad += not (b > 0 and rel <= 1e-12)
sys.exit(bad)
PYEOF
# the Python package from the prefix alone: it finds the prefix's library
PYDIR=$(find "$P" -type d -name ohm -path '*-packages/ohm' -print -quit)
PYENV=(env -u OHM_LIBRARY PYTHONPATH="$(dirname "$PYDIR")")
if [ "$SANITIZED" = 1 ]; then
  PYENV+=(LD_PRELOAD="$(cc -print-file-name=libasan.so):$(cc -print-file-name=libubsan.so)" ASAN_OPTIONS=detect_leaks=0)
fi
check "python package installed under the prefix" test -f "$PYDIR/__init__.py" -a -f "$PYDIR/_location.py"
check "import ohm from the prefix" bash -c "cd '$T' && $(printf '%q ' "${PYENV[@]}") $PY -c 'import ohm, sys; assert ohm.__file__.startswith(\"$P\"), ohm.__file__; print(ohm.version())' | grep -q '^1\.'"
# spot in marble, two lights, one factorization per channel: each frame's
# per-cell fluence from the API equals the command's (-export csv=) to 1e-12
out=$("$T/relight" samples/spot.obj 2 32 "$T/relight.txt")
check "relight: two frames" test "$(grep -c '^frame' <<<"$out")" = 2
check "relight: no factorization after the first solve" grep -q "frame 2: .*3 factorizations in all" <<<"$out"
for f in 1 2; do
  dir=$(grep "^frame $f:" <<<"$out" | sed 's/^frame [0-9]*: dir=\([^:]*\):.*/\1/')
  "$P/bin/ohm" -q -read file=samples/spot.obj size=50 -voxelize dim=32 -material preset=marble \
    -light type=directional dir="$dir" -solve solver=direct -export csv="$T/cli_$f.csv"
done
check "relit fluence = the command's, cell by cell, to 1e-12" $PY - "$T/relight.txt" "$T/cli_1.csv" "$T/cli_2.csv" <<'PYEOF'
import csv, sys
api = {}
for line in open(sys.argv[1]):
    w = line.split()
    api[(int(w[0]), int(w[1]), int(w[2]), int(w[3]))] = [float(x) for x in w[4:]]
worst, cells = 0.0, 0
for frame, path in enumerate(sys.argv[2:], 1):
    rows = list(csv.DictReader(open(path)))
    scale = max(abs(float(r["fluence_r"])) for r in rows)
    for r in rows:
        a = api[(frame, int(r["i"]), int(r["j"]), int(r["k"]))]
        for c, ch in enumerate("rgb"):
            worst = max(worst, abs(a[c] - float(r["fluence_" + ch])) / scale)
        cells += 1
print("%d cells in 2 frames, largest difference %.3g of the maximum" % (cells, worst))
sys.exit(0 if cells > 1000 and worst <= 1e-12 and len(api) == cells else 1)
PYEOF
finish
