#!/usr/bin/env bash
# The sweeps behind scenes/adaptive_bar_on_table.json (docs/adaptivity.md, "The bar on a table"):
# the scene's refine_near (auto, 0, 2 and 3 cm) with the push at x = 1.2 m, then refine_near 0 with
# the push at x = 0.4, 0.8, 1.1 and 1.2 m (the probe `near` 10 cm from it towards x = 0, `far` 20 cm
# towards x = 1.6), and at 0.8 and 1.2 m with the coarser levels calibrated. Each variant is the shipped scene edited here, measured by the trade of
# perf/adaptivity_report (full mode: every uniform level, the static split, adaptive with the
# engine's defaults and scaled thresholds, errors against a mesh twice as fine).
#   bash variants.sh [BUILD_DIR] > variants.txt      (from the repository's root; about 3 minutes)
set -euo pipefail
build=${1:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
variant() {  # refine_near push_x [calibrate]
  python3 - "$1" "$2" "$tmp/adaptive_bar_on_table.json" "${3:-}" <<'PY'
import json, sys
s = json.load(open('scenes/adaptive_bar_on_table.json'))
near, x = sys.argv[1], float(sys.argv[2])
if sys.argv[4] == 'calibrate':
    s['bodies'][0]['multiresolution']['calibrate'] = True
s['bodies'][0]['multiresolution']['adapt']['refine_near'] = near if near == 'auto' else float(near)
s['bodies'][0]['prescribed'][0]['region']['sphere']['center'][0] = x
s['probes'][0]['point'][0] = round(x - 0.1, 6)
s['probes'][1]['point'][0] = round(x + 0.2, 6)
json.dump(s, open(sys.argv[3], 'w'))
PY
  echo "## refine_near $1, push at x = $2 m${3:+, coarser levels calibrated}"
  "$build/perf/adaptivity_report" --only trade --case bar_on_table --scenes "$tmp" | grep -E '^\||^Goal|^So does'
  echo
}
for near in auto 0 0.02 0.03; do variant $near 1.2; done
for x in 0.4 0.8 1.1; do variant 0 $x; done
for x in 0.8 1.2; do variant 0 $x calibrate; done
