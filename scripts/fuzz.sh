#!/usr/bin/env bash
# Fuzz ohm's readers with libFuzzer (clang from Debian).
#   scripts/fuzz.sh obj|off|ply|stl|pipeline|transfer|raw|nifti|vdb|nrrd|meta|inr|dicom|args [SECONDS=60]
#   scripts/fuzz.sh all [SECONDS=60]        every harness in turn
# Harnesses live in tests/fuzz/ (docs/fuzzing.md says what each checks).  Seeds
# come from samples/, pipelines/, tests/data/ and tests/fuzz/seeds/; the corpus
# grows in out/fuzz/NAME/corpus, crashes land in out/fuzz/NAME/artifacts/.
# Each run ends with one line: "fuzz NAME: N execs in Ts of Ss, cov C ft F, corpus K, crashes X"
# (T: how long it ran; less than S when it stopped at a finding).
# Exit status: 0 clean, 1 if any harness found a crash (or failed to build).
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: scripts/fuzz.sh obj|off|ply|stl|pipeline|transfer|raw|nifti|vdb|nrrd|meta|inr|dicom|stack|args|all [seconds]"
name=${1:?$usage}; secs=${2:-60}
all_names="obj off ply stl pipeline args transfer raw nifti vdb nrrd meta inr dicom stack"
command -v clang >/dev/null && command -v clang++ >/dev/null ||
  { echo "fuzz: needs clang and clang++ (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }

if [ "$name" = all ]; then
  status=0; mkdir -p out/fuzz
  for n in $all_names; do
    "$0" "$n" "$secs" > "out/fuzz/$n.log" 2>&1 || status=1
    line=$(grep '^fuzz ' "out/fuzz/$n.log" | tail -n 1 || true)
    echo "${line:-fuzz $n: FAILED to build or run, see out/fuzz/$n.log}"
  done
  exit $status
fi
case $name in obj|off|ply|stl|pipeline|args|transfer|raw|nifti|vdb|nrrd|meta|inr|dicom|stack) ;;
  *) echo "fuzz: unknown harness '$name'" >&2; echo "$usage" >&2; exit 2;; esac
mkdir -p out/fuzz

# --- build ---------------------------------------------------------------------
# Sanitizers everywhere; UB is fatal in C (-fno-sanitize-recover) so libFuzzer
# keeps the input.  The C++ wrappers get ASan only: OpenVDB's headers are not
# UBSan-clean and would drown the C findings.  Objects are cached in
# out/fuzz/obj/ and rebuilt when their source (or any header) is newer.
objdir=out/fuzz/obj; mkdir -p "$objdir"
sed 's/@PROJECT_VERSION@/fuzz/' src/base/version.h.in > "$objdir/ohm_version.h.new"
cmp -s "$objdir/ohm_version.h.new" "$objdir/ohm_version.h" 2>/dev/null || mv "$objdir/ohm_version.h.new" "$objdir/ohm_version.h"
rm -f "$objdir/ohm_version.h.new"
SAN="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
CFLAGS="-std=c11 -D_POSIX_C_SOURCE=200809L -g -O1 -fno-omit-frame-pointer $SAN -fsanitize=fuzzer-no-link
  -Isrc -Iinclude -I$objdir -Iwrappers/vdb -Iwrappers/oiio -Iwrappers/gdcm -isystem /usr/include/suitesparse -isystem /usr/include/nifti"
CXXFLAGS="-std=c++17 -g -O1 -fno-omit-frame-pointer -fsanitize=address,fuzzer-no-link
  -Isrc -Iinclude -Iwrappers/vdb -Iwrappers/oiio -Iwrappers/gdcm -isystem /usr/include/Imath -isystem /usr/include/gdcm-3.0"
newest_header=$(ls -t src/*/*.h wrappers/*/*.h | head -n 1)
objs=()
obj() { # obj SOURCE [extra flags...]: compile once, append to objs
  local src=$1; shift
  local o="$objdir/$(echo "$src $*" | tr '/ =' '___' | tr -cd 'A-Za-z0-9_.-').o"
  if [ ! -f "$o" ] || [ "$src" -nt "$o" ] || [ "$newest_header" -nt "$o" ]; then
    case $src in *.cpp) clang++ $CXXFLAGS "$@" -c "$src" -o "$o" ;; *) clang $CFLAGS "$@" -c "$src" -o "$o" ;; esac
  fi
  objs+=("$o")
}
VDB_LIBS="-lopenvdb -ltbb -lImath-3_1 -lboost_iostreams"
OIIO_LIBS="-lOpenImageIO -lOpenImageIO_Util"
GDCM_LIBS="-lgdcmMSFF -lgdcmDICT -lgdcmDSED -lgdcmCommon"
SCAN_LIBS="$VDB_LIBS $OIIO_LIBS $GDCM_LIBS -lnifti2 -lznz -lteem -lz -lm -lpthread"
scan_objs() { for f in src/input/scan*.c; do obj "$f"; done; obj src/base/ohm_error.c; obj src/base/memory.c; obj wrappers/vdb/ohm_vdb.cpp; obj wrappers/oiio/ohm_oiio.cpp; obj wrappers/oiio/ohm_oiio_load.c; obj wrappers/gdcm/ohm_gdcm.cpp; obj wrappers/gdcm/dicom_check.cpp; }
link=clang; libs="-lz -lm"
case $name in
  obj|off|ply|stl)
    obj tests/fuzz/fuzz_mesh.c -DFORMAT=ohm_mesh_parse_$name
    obj src/input/mesh_io.c; obj src/input/mesh.c; obj src/base/ohm_error.c ;;
  transfer)
    obj tests/fuzz/fuzz_transfer.c; obj src/input/transfer.c; obj src/base/ohm_error.c ;;
  pipeline|args)
    # The option specs live in the action table (actions.c), whose run functions
    # reach every module: link the whole core, as the ohm binary does.
    if [ "$name" = args ]; then obj tests/fuzz/fuzz_pipeline.c -DARGS; else obj tests/fuzz/fuzz_pipeline.c; fi
    for f in src/*/*.c; do [ "$f" = src/cli/main.c ] || obj "$f"; done
    obj wrappers/vdb/ohm_vdb.cpp; obj wrappers/oiio/ohm_oiio.cpp; obj wrappers/oiio/ohm_oiio_load.c; obj wrappers/gdcm/ohm_gdcm.cpp; obj wrappers/gdcm/dicom_check.cpp
    link=clang++
    libs="$SCAN_LIBS -lcholmod -lsuitesparseconfig -lembree3 -lblas" ;;
  raw)   obj tests/fuzz/fuzz_scan.c -DKIND=KIND_RAW;   scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  nifti) obj tests/fuzz/fuzz_scan.c -DKIND=KIND_NIFTI; scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  vdb)   obj tests/fuzz/fuzz_scan.c -DKIND=KIND_VDB;   scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  nrrd)  obj tests/fuzz/fuzz_scan.c -DKIND=KIND_NRRD;  scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  meta)  obj tests/fuzz/fuzz_scan.c -DKIND=KIND_META;  scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  inr)   obj tests/fuzz/fuzz_scan.c -DKIND=KIND_INR;   scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  dicom) obj tests/fuzz/fuzz_scan.c -DKIND=KIND_DICOM; scan_objs; link=clang++; libs=$SCAN_LIBS ;;
  stack) obj tests/fuzz/fuzz_scan.c -DKIND=KIND_STACK; scan_objs; link=clang++; libs=$SCAN_LIBS ;;
esac
work=out/fuzz/$name; mkdir -p "$work/corpus" "$work/artifacts"
$link -g $SAN -fsanitize=fuzzer "${objs[@]}" $libs -o "$work/fuzz_$name"

# --- seeds ---------------------------------------------------------------------
seeds=$(mktemp -d); tmp=$(mktemp -d); trap 'rm -rf "$seeds" "$tmp"' EXIT
cp_seeds() { for f in "$@"; do [ -f "$f" ] && cp "$f" "$seeds/" || true; done; }
max_len=65536; dict=""
case $name in
  obj|off|ply|stl)
    cp_seeds samples/*."$name" tests/data/bad/*."$name"
    for f in samples/*."$name".gz; do [ -f "$f" ] && (gzip -dc "$f" | head -c 65536 > "$seeds/$(basename "$f" .gz)") || true; done
    dict=tests/fuzz/dict/mesh.dict ;;
  pipeline) cp_seeds pipelines/*.ohm tests/data/*.ohm tests/data/*/*.ohm tests/fuzz/seeds/pipeline/*; dict=tests/fuzz/dict/pipeline.dict ;;
  args)
    # each pipeline's action lines as argv: "-read" "file=..." ..., NUL-separated
    for p in pipelines/*.ohm; do
      grep -v '^#\|^ohm-pipeline\|^$' "$p" | tr ' ' '\n' | sed '/^[a-z]*$/s/^/-/' | tr '\n' '\0' \
        > "$seeds/$(basename "$p" .ohm)" || true
    done
    printf -- '-light\0type=directional\0dir=1e308,1e308,1e308\0-material\0sigma_a=1e-320\0sigma_s=0x1p3' \
      > "$seeds/numbers"
    dict=tests/fuzz/dict/pipeline.dict ;;
  transfer) cp_seeds samples/*.transfer tests/data/*.transfer tests/data/*/*.transfer tests/fuzz/seeds/transfer/*
            dict=tests/fuzz/dict/transfer.dict ;;
  raw)
    # 5-byte parameter prefix (see fuzz_scan.c) + the start of the walnut volume.
    cp_seeds tests/fuzz/seeds/raw/*
    if [ -f samples/walnut_64x48x57_uint16.raw.gz ]; then
      (gzip -dc samples/walnut_64x48x57_uint16.raw.gz | head -c 40000 > "$tmp/walnut") || true
      { printf '\007\007\007\001\000'; head -c 1024 "$tmp/walnut"; } > "$seeds/walnut-8x8x8-u16"
      { printf '\017\017\007\011\020'; dd if="$tmp/walnut" bs=1 skip=20000 count=4096 status=none; } > "$seeds/walnut-16x16x8-u16-gz"
      { printf '\003\003\003\006\000'; head -c 256 "$tmp/walnut"; } > "$seeds/walnut-4x4x4-i16-big"
    fi ;;
  nifti) cp_seeds tests/fuzz/seeds/nifti/*; max_len=262144 ;;
  vdb)   cp_seeds tests/fuzz/seeds/vdb/* tests/data/*.vdb tests/data/corpus/*.vdb samples/*.vdb; max_len=262144 ;;
  nrrd|meta|inr) cp_seeds tests/fuzz/seeds/$name/* ;;
  dicom) cp_seeds tests/fuzz/seeds/dicom/* samples/walnut-dicom/IM0001.dcm ;;
  stack) cp_seeds tests/fuzz/seeds/stack/* ;;
esac
[ -n "$dict" ] && [ -f "$dict" ] && dict="-dict=$dict" || dict=""

# --- run -----------------------------------------------------------------------
log="$work/last-run.log"
count_crashes() { ls "$work/artifacts" 2>/dev/null | grep -cE '^(crash|leak|timeout|oom)-' || true; }
before=$(count_crashes)
export TMPDIR=${TMPDIR:-/tmp}
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
# FUZZ_KEEP_GOING=1: fork mode that records a crash and goes on (for a harness
# whose known crash would otherwise end every run at once).  Off by default for
# every harness: since ohm checks NIfTI headers and .vdb structure before
# libnifti2/OpenVDB see them (src/input/scan.c, src/input/scan_check.c), nifti and vdb no
# longer stop on the libraries' known crashes (docs/fuzzing.md).
keep=""; [ "${FUZZ_KEEP_GOING:-0}" = 1 ] && keep="-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1"
set +e
t0=$SECONDS
"$work/fuzz_$name" $keep -max_total_time="$secs" -max_len=$max_len -rss_limit_mb=2048 -malloc_limit_mb=512 \
  -timeout=10 -print_final_stats=1 $dict -artifact_prefix="$work/artifacts/" "$work/corpus" "$seeds" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
ran=$((SECONDS - t0))
set -e
last=$(grep -E '^#[0-9]+' "$log" | grep ' cov: ' | tail -n 1 || true)
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
[ -n "$execs" ] || execs=$(echo "$last" | sed -n 's/^#\([0-9]*\).*/\1/p')
cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p'); ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\).*/\1/p')
crashes=$(( $(count_crashes) - before ))
echo "fuzz $name: ${execs:-?} execs in ${ran}s of ${secs}s, cov ${cov:-?} ft ${ft:-?}, corpus ${corp:-?}, crashes $crashes (exit $rc)"
[ "$rc" -eq 0 ] && [ "$crashes" -eq 0 ]
