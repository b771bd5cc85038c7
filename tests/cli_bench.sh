#!/usr/bin/env bash
# `ohm bench` through the real command: the table's shape, counts that grow
# with the grid, the machine's measured rates, and usage errors.  Never a time:
# speed is reported by the benchmark, not asserted by a test.
set -eu
source "$(dirname "$0")/lib.sh" "$1"

expect_exit 0 "bench help" -- "$OHM" bench help
check "help lists the options" grep -q "sizes=LIST" "$T/stdout"

expect_exit 0 "bench two sizes" -- "$OHM" bench mesh=samples/spot.obj sizes=8x8x4,16x16x8 frames=4 \
  csv="$T/b.csv" md="$T/b.md"
check "markdown on stdout is the md= file" cmp -s "$T/stdout" "$T/b.md"
check "markdown: a header row and two grid rows" $PY - "$T/b.md" <<'PY'
import sys
rows = [l for l in open(sys.argv[1]) if l.startswith("| ")]
assert len(rows) == 3, rows
assert "nnz(L)" in rows[0] and "upper bound n(n+1)/2" in rows[0], rows[0]
assert rows[1].startswith("| 8x8x4 |") and rows[2].startswith("| 16x16x8 |"), rows
PY
check "csv: columns, two rows, growing counts, machine rates" $PY - "$T/b.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert len(rows) == 2, len(rows)
need = ("grid", "cells", "t_analyze_s", "t_factorize_s", "t_factor_one_channel_s", "t_factor_all_s", "t_source_s",
        "t_solve_s", "nnz_A", "nnz_L", "upper_bound_fill", "update_per_light_s", "update_per_frame_s",
        "solve_bound_per_light_s", "solve_over_bound", "factor_gflops", "factor_fraction_of_dgemm",
        "bandwidth_gbs", "dgemm_gflops", "frames", "channels", "factors")
for k in need:
    assert k in rows[0], k
assert [r["grid"] for r in rows] == ["8x8x4", "16x16x8"], [r["grid"] for r in rows]
f = lambda r, k: float(r[k])
for r in rows:
    assert int(r["frames"]) == 4 and int(r["channels"]) == 3 and int(r["factors"]) == 3, r
    for k in ("cells", "nnz_A", "nnz_L", "upper_bound_fill", "bandwidth_gbs", "dgemm_gflops"):
        assert f(r, k) > 0, (k, r[k])
    assert f(r, "nnz_L") >= f(r, "nnz_A"), (r["nnz_L"], r["nnz_A"])
    n = f(r, "cells")
    assert f(r, "upper_bound_fill") == n * (n + 1) / 2, (r["upper_bound_fill"], n)
    # the fitted grid: no axis beyond its count plus the margin (2 x 4 cells)
    fit = sorted(int(x) for x in r["grid"].split("x"))
    dims = sorted(int(r[k]) - 8 for k in ("dims_x", "dims_y", "dims_z"))
    assert all(d <= c for d, c in zip(dims, fit)) and any(d == c for d, c in zip(dims, fit)), (dims, fit)
for k in ("cells", "nnz_A", "nnz_L", "upper_bound_fill"):
    assert f(rows[1], k) > f(rows[0], k), (k, rows[0][k], rows[1][k])
# both rows measured against the same machine
assert rows[0]["bandwidth_gbs"] == rows[1]["bandwidth_gbs"]
PY

# usage errors: exit 2, one line naming the word
expect_exit 2 "unknown option" -- "$OHM" bench frame=4
expect_error_line "unknown option" "bench: unknown option 'frame'; did you mean 'frames'"
expect_exit 2 "bad sizes" -- "$OHM" bench sizes=8x8
expect_error_line "bad sizes" "bench: sizes=8x8: expected a list like"
expect_exit 2 "bad frames" -- "$OHM" bench frames=0
expect_error_line "bad frames" "bench: frames=0: expected a whole number from 1 to 100000"
expect_exit 2 "bad material" -- "$OHM" bench material=cheese
expect_error_line "bad material" "bench: material=cheese: expected a preset"
expect_exit 2 "bad max" -- "$OHM" bench max=2
expect_error_line "bad max" "bench: max=2: expected one of 0\\|1"
expect_exit 2 "no value" -- "$OHM" bench csv
expect_error_line "no value" "bench: option 'csv' needs a value"
expect_exit 2 "bad device_sizes" -- "$OHM" bench device=cpu device_sizes=4
expect_error_line "bad device_sizes" "bench: device_sizes=4: expected grid sizes 8..2000"

# device=: the device's tables after Table 2 (studies/device_bench.h), on
# stdout and in md=: the block medium solved there as on the host, cube60
# traced there and on the host, each within 4 se of MCX's 17.69708%
if "$OHM" devices >/dev/null 2>&1; then
  expect_exit 0 "bench device=cpu" -- "$OHM" bench sizes=8x8x4 frames=1 device=cpu device_sizes=16 photons=20000 \
    md="$T/dev.md"
  check "bench device=cpu: the device's tables are in md= as on stdout" grep -q "### On device=cpu: the Monte Carlo" "$T/dev.md"
  check "bench device=cpu: mg on the device as on the host, cube60 on both within 4 se of MCX" $PY - "$T/dev.md" <<'PY'
import sys
rows = [l.split('|') for l in open(sys.argv[1]) if l.startswith('| 16^3') or '% ±' in l]
assert len(rows) == 3, rows
mg, dev, host = rows
assert mg[4].split('(')[1] == mg[8].split('(')[1] and float(mg[10]) <= 1e-6, mg
assert host[1].strip().startswith('host') and not dev[1].strip().startswith('host'), (dev, host)
for r in (dev, host):
    assert abs(float(r[6])) <= 4, r
PY
elif [ "${CI:-}" = true ] || { [ -n "${OHM_REQUIRE_OPENCL:-}" ] && [ "$OHM_REQUIRE_OPENCL" != 0 ]; }; then
  bad "no OpenCL device for bench device=, but CI=true or OHM_REQUIRE_OPENCL is set"
else
  echo "SKIP: bench device=: no OpenCL device"
fi

# a missing mesh is a failure (exit 1), not a usage error
expect_exit 1 "missing mesh" -- "$OHM" bench mesh="$T/none.obj" sizes=8x8x4 frames=1
expect_error_line "missing mesh" "none.obj"

finish
