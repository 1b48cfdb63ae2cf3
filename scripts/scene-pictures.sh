#!/usr/bin/env bash
# Regenerates the pictures of scenes/README.md: runs every shipped scene to its end with a contact
# sheet (docs/images/scenes/NAME.png) and prints each run's wall time. Takes a few minutes on 2
# cores (the raptor and the armadillo most). Usage: scripts/scene-pictures.sh [BUILD_DIR]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
mkdir -p "$root/docs/images/scenes"
for scene in "$root"/scenes/*.json; do
  name=$(basename "$scene" .json)
  field=displacement
  [ "$name" = multires_organ ] && field=level  # its point: which level steps where
  "$build/apps/pliant" run "$scene" --out "$out/$name" --sheet --size 960x540 --field "$field" --quiet
  cp "$out/$name/sheet.png" "$root/docs/images/scenes/$name.png"
  wall=$(sed -n 's/^  "wall_time_s": \([0-9.]*\),$/\1/p' "$out/$name/summary.json")
  steps=$(sed -n 's/^  "steps": \([0-9]*\),$/\1/p' "$out/$name/summary.json")
  echo "$name: $steps steps, ${wall} s of stepping -> docs/images/scenes/$name.png"
done
