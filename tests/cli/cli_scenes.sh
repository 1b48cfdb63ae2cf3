#!/usr/bin/env bash
# Every shipped scene (scenes/*.json) runs: a short run of each (--duration 0.002 s) exits 0 and
# writes a sane summary.json (status ok, steps, nodes and tets counted, finite energies, a small
# displacement, a state hash). Scenes that mesh a surface or an implicit shape need CGAL and are
# skipped, with a line saying so, in builds without it. Usage: cli_scenes.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, png_size, scene
json_num() { sed -n "s/^  \"$2\": \([-0-9.e+]*\),\{0,1\}$/\1/p" "$1" | head -n 1; }  # a top-level number of summary.json
cgal=0
has_cgal && cgal=1
duration=0.002
found=0
for s in "$src"/scenes/*.json; do
  name=$(basename "$s" .json); found=$((found+1))
  if [ "$cgal" = 0 ] && grep -qE '"(surface|implicit)"' "$s"; then echo "skip $name: meshes a surface or shape (needs CGAL)"; continue; fi
  check "run_$name" 0 "" -- "$pliant" run "$s" --out "$work/$name" --duration "$duration" --quiet
  sum="$work/$name/summary.json"
  if grep -q '"status": "ok"' "$sum" 2>/dev/null && grep -qE '"state_hash": "[0-9a-f]{16}"' "$sum" && ! grep -qiE 'nan|inf' "$sum" \
     && awk -v st="$(json_num "$sum" steps)" -v n="$(json_num "$sum" nodes)" -v t="$(json_num "$sum" tets)" \
            -v time="$(json_num "$sum" simulated_time)" -v u="$(json_num "$sum" max_displacement)" \
            -v k="$(json_num "$sum" kinetic_energy)" -v e="$(json_num "$sum" elastic_energy)" -v d="$duration" \
            'BEGIN { exit !(st >= 1 && n >= 4 && t >= 1 && time >= d - 1e-12 && time < d + 0.01 && u >= 0 && u < 0.05 && k >= 0 && e >= 0) }'; then
    ok "$name: sane summary ($(json_num "$sum" steps) steps, $(json_num "$sum" tets) tets, max displacement $(json_num "$sum" max_displacement) m)"
  else
    fail "$name: summary"; sed 's/^/    /' "$sum" 2>/dev/null | head -25
  fi
  if grep -q '"probes"' "$s"; then [ -s "$work/$name/probes.csv" ] && ok "$name: probes.csv" || fail "$name: probes.csv"; fi
  if grep -q '"tools"' "$s"; then
    [ "$(head -n 1 "$work/$name/tools.csv" 2>/dev/null)" = "time,tool,x,y,z,fx,fy,fz,contacts,max_penetration" ] \
      && [ "$(wc -l < "$work/$name/tools.csv")" -ge 2 ] && [ -s "$work/$name/tools.png" ] \
      && ok "$name: tools.csv and tools.png" || fail "$name: tools.csv (header, rows) or tools.png"
  fi
done
# The shipped set: the default scene, the cantilever, and the examples of scenes/README.md.
[ "$found" -ge 7 ] && ok "$found scenes found" || fail "only $found scenes in $src/scenes"
for name in default cantilever liver raptor armadillo cube_drop sheet multires_organ; do
  [ -f "$src/scenes/$name.json" ] && grep -q "docs/images/scenes/$name.png" "$src/scenes/README.md" 2>/dev/null \
    && [ -s "$src/docs/images/scenes/$name.png" ] && ok "$name: documented with its picture" || fail "$name: scene, README entry or picture missing"
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
