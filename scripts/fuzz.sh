#!/usr/bin/env bash
# Fuzz one mesh reader with libFuzzer (clang from Debian).
#   scripts/fuzz.sh obj|off|ply|stl [SECONDS=60]
# Seeds come from samples/ and tests/data/bad/; findings land in out/fuzz/FORMAT/.
set -euo pipefail
cd "$(dirname "$0")/.."
fmt=${1:?usage: scripts/fuzz.sh obj|off|ply|stl [seconds]}; secs=${2:-60}
case $fmt in obj|off|ply|stl) ;; *) echo "fuzz: unknown format '$fmt'" >&2; exit 2;; esac
command -v clang >/dev/null || { echo "fuzz: needs clang (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
work=out/fuzz/$fmt; mkdir -p "$work/corpus" "$work/artifacts"
sed 's/@PROJECT_VERSION@/fuzz/' src/version.h.in > "$work/ohm_version.h"
clang -std=c11 -D_POSIX_C_SOURCE=200809L -g -O1 -fsanitize=fuzzer,address,undefined \
  -DFORMAT=ohm_mesh_parse_$fmt -Isrc -I"$work" tests/fuzz/fuzz_mesh.c src/mesh_io.c src/mesh.c src/ohm_error.c \
  -lz -lm -o "$work/fuzz_$fmt"
seeds=$(mktemp -d); trap 'rm -rf "$seeds"' EXIT
for f in samples/*."$fmt" tests/data/bad/*."$fmt"; do [ -f "$f" ] && cp "$f" "$seeds/"; done
for f in samples/*."$fmt".gz; do [ -f "$f" ] && (gzip -dc "$f" | head -c 65536 > "$seeds/$(basename "$f" .gz)") || true; done
"$work/fuzz_$fmt" -max_total_time="$secs" -max_len=65536 -rss_limit_mb=2048 -malloc_limit_mb=64 \
  -dict=tests/fuzz/dict/mesh.dict -artifact_prefix="$work/artifacts/" "$work/corpus" "$seeds"
