#!/usr/bin/env bash
# The tolerance audit: every EXPECT_NEAR / EXPECT_LT / EXPECT_LE of the unit tests records the
# largest measured / allowed it saw (tests/support/tolerance_audit.hpp, force-included by
# -DPLIANT_TOLERANCE_AUDIT=ON); this builds the tests so, runs them, and lists the checks whose
# largest ratio is below 0.1, i.e. that allow more than 10x what they measure (a test that cannot
# fail by much). Ratios of plain comparisons (a < b between two measured values) are listed too;
# read them as such.
#
#   bash scripts/tolerance-audit.sh [BUILD_DIR] [CTEST_REGEX]
#
# BUILD_DIR: a separate build folder (default build-audit/). Output: BUILD_DIR/tolerance-audit.tsv
# (file:line, largest ratio, count, expression), sorted by ratio.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-audit}
regex=${2:-.}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLIANT_TOLERANCE_AUDIT=ON -DPLIANT_BUILD_PERF=OFF >/dev/null
cmake --build "$build" -j2
raw=$build/tolerance-audit.raw
rm -f "$raw"
PLIANT_AUDIT_OUT=$raw ctest --test-dir "$build" -j2 -R "$regex" --output-on-failure || true
# The largest ratio per check over every test process.
sort -t$'\t' -k1,1 -k2,2gr "$raw" | awk -F'\t' '!seen[$1]++' | sort -t$'\t' -k2,2g > "$build/tolerance-audit.tsv"
echo "checks allowing more than 10x what they measured (ratio < 0.1):"
awk -F'\t' '$2 < 0.1' "$build/tolerance-audit.tsv" | sed 's|^\.\./||'
echo "($(awk -F'\t' '$2 < 0.1' "$build/tolerance-audit.tsv" | wc -l) of $(wc -l < "$build/tolerance-audit.tsv") checks; full list in $build/tolerance-audit.tsv)"
