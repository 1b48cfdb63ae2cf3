#!/usr/bin/env bash
# Command-line behaviour of `pliant`: exit codes (0 ok, 2 invalid input, 3 diverged), the
# files a run writes, and error messages that name the field or file. Usage: cli_test.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
passed=0; failed=0
check() {  # check NAME EXPECTED_EXIT GREP_PATTERN(stderr+stdout, or "") -- command...
  local name=$1 want=$2 pattern=$3; shift 4
  "$@" >"$work/$name.out" 2>&1; local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL $name: exit $got, expected $want"; sed 's/^/    /' "$work/$name.out" | tail -5; failed=$((failed+1)); return
  fi
  if [ -n "$pattern" ] && ! grep -qE -- "$pattern" "$work/$name.out"; then
    echo "FAIL $name: output lacks /$pattern/"; sed 's/^/    /' "$work/$name.out" | tail -5; failed=$((failed+1)); return
  fi
  echo "ok   $name"; passed=$((passed+1))
}
scene() { printf '%s\n' "$2" > "$work/$1.json"; }

box='"mesh": {"box": {"min": [0,0,0], "max": [0.2,0.05,0.05], "cells": [8,2,2]}}'
fixed='"fixed": [{"box": {"min": [-1,-1,-1], "max": [0.0001,1,1]}}]'

scene good "{\"duration\": 0.01, \"bodies\": [{\"name\": \"b\", $box, $fixed}], \"probes\": [{\"name\": \"tip\", \"body\": \"b\", \"point\": [0.2,0.025,0.025]}], \"output\": {\"vtu_every\": 0.005}}"
check run_ok 0 "results in" -- "$pliant" run "$work/good.json" --out "$work/out"
for f in summary.json probes.csv series.pvd; do
  if [ -s "$work/out/$f" ]; then echo "ok   writes $f"; passed=$((passed+1)); else echo "FAIL writes $f"; failed=$((failed+1)); fi
done
# probes.csv: the header run_scene.cpp writes, then one row per probe and step (5 columns).
if [ "$(head -n 1 "$work/out/probes.csv" 2>/dev/null)" = "time,probe,x,y,z" ] \
   && [ "$(sed -n 2p "$work/out/probes.csv" | awk -F, '$2 == "tip" {print NF}')" = "5" ]; then
  echo "ok   probes.csv header"; passed=$((passed+1))
else echo "FAIL probes.csv header: $(head -n 2 "$work/out/probes.csv" 2>/dev/null | tr '\n' '|')"; failed=$((failed+1)); fi
for key in steps simulated_time wall_time_s nodes tets model precision threads dt stable_dt max_displacement kinetic_energy elastic_energy state_hash; do
  if grep -q "\"$key\"" "$work/out/summary.json" 2>/dev/null; then passed=$((passed+1)); else echo "FAIL summary lacks $key"; failed=$((failed+1)); fi
done
check run_overrides 0 "float" -- "$pliant" run "$work/good.json" --out "$work/out2" --threads 1 --precision float --duration 0.002
check run_quiet_silent 0 "" -- "$pliant" run "$work/good.json" --out "$work/out3" --quiet
if [ ! -s "$work/run_quiet_silent.out" ]; then echo "ok   quiet prints nothing"; passed=$((passed+1)); else echo "FAIL quiet printed"; failed=$((failed+1)); fi

scene poisson "{\"bodies\": [{$box, \"material\": {\"poisson\": 0.7}}]}"
check bad_poisson 2 "bodies\[0\]\.material\.poisson" -- "$pliant" run "$work/poisson.json" --out "$work/o"
check missing_scene 2 "nope.json" -- "$pliant" run "$work/nope.json" --out "$work/o"
printf '{"bodies": [\n' > "$work/broken.json"
check broken_json 2 "broken.json" -- "$pliant" run "$work/broken.json" --out "$work/o"
scene bigdt "{\"time_step\": {\"dt\": 1.0}, \"bodies\": [{$box, $fixed}]}"
check dt_above_bound 2 "above the stable bound" -- "$pliant" run "$work/bigdt.json" --out "$work/o"
scene nofix "{\"bodies\": [{$box, \"fixed\": [{\"box\": {\"min\": [5,5,5], \"max\": [6,6,6]}}]}]}"
check empty_region 2 "selects no node" -- "$pliant" run "$work/nofix.json" --out "$work/o"
scene missing_mesh "{\"bodies\": [{\"mesh\": {\"file\": \"absent.msh\"}}]}"
check missing_mesh_file 2 "absent.msh" -- "$pliant" run "$work/missing_mesh.json" --out "$work/o"
# A mesh file that exists but is malformed (a NaN coordinate at line 12): exit 2, naming file and line.
scene bad_mesh "{\"bodies\": [{\"mesh\": {\"file\": \"$src/tests/data/mesh/bad_nan.msh\"}}]}"
check malformed_mesh_file 2 "bad_nan\.msh:12: node 3 has a non-finite coordinate" -- "$pliant" run "$work/bad_mesh.json" --out "$work/o"
# A load of 1e300 N overflows at once: the run must stop with exit 3 and say where.
scene diverge "{\"duration\": 0.01, \"bodies\": [{\"name\": \"b\", $box, $fixed, \"loads\": [{\"region\": {\"box\": {\"min\": [0.19,-1,-1], \"max\": [1,1,1]}}, \"force\": [0,0,-1e300]}]}]}"
check diverges 3 "body 'b', level 0, step [0-9]+.*node [0-9]+" -- "$pliant" run "$work/diverge.json" --out "$work/odiv"
if grep -q '"status": "diverged"' "$work/odiv/summary.json" 2>/dev/null && ! grep -qi nan "$work/odiv/summary.json"; then
  echo "ok   diverged summary"; passed=$((passed+1)); else echo "FAIL diverged summary"; failed=$((failed+1)); fi
check bad_option 2 "" -- "$pliant" run "$work/good.json" --bogus
check no_command 2 "" -- "$pliant"
check help 0 "run" -- "$pliant" --help
check bad_precision 2 "precision" -- "$pliant" run "$work/good.json" --precision half --out "$work/o"

# info and mesh on a small volume mesh written by pliant itself.
check mesh_convert_needs_input 2 "" -- "$pliant" mesh -o "$work/x.vtu"
"$pliant" run "$work/good.json" --out "$work/out4" -q
check info_vtu 0 "nodes 81  tets 192" -- "$pliant" info "$work/out4/vtu/b_00000.vtu"
check info_stable_dt 0 "stable dt" -- "$pliant" info "$work/out4/vtu/b_00000.vtu" --young 1e5
check info_missing 2 "absent.vtu" -- "$pliant" info "$work/absent.vtu"
check mesh_convert 0 "81 nodes, 192 tets" -- "$pliant" mesh "$work/out4/vtu/b_00000.vtu" -o "$work/copy.vtu"

# study: the tables and the plots, their paths printed. test_study_plots checks the pixels; here,
# that the files are PNGs of 800x600 (from the IHDR chunk) and not near-empty (a blank 800x600
# plot compresses to about 2 KB; one with axes, labels and points, to more than 8 KB).
png_size() { od -An -tu1 -j16 -N8 "$1" 2>/dev/null | awk '{printf "%dx%d", $1*16777216+$2*65536+$3*256+$4, $5*16777216+$6*65536+$7*256+$8}'; }
bar="$src/scenes/validation/slender_bar.json"
check study_plots 0 "results in .*study\.csv.*pareto\.png, .*convergence\.png" -- "$pliant" study "$bar" \
  --sweep 'bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]' --sweep 'bodies[0].model="linear"|"corotational"' --out "$work/study"
for f in pareto convergence; do
  png="$work/study/$f.png"
  if [ "$(head -c 8 "$png" 2>/dev/null | od -An -tx1 | tr -d ' ')" = "89504e470d0a1a0a" ] && [ "$(png_size "$png")" = "800x600" ] \
     && [ "$(stat -c %s "$png")" -gt 8000 ]; then
    echo "ok   study writes $f.png"; passed=$((passed+1))
  else echo "FAIL study writes $f.png (size $(png_size "$png"), $(stat -c %s "$png" 2>/dev/null) bytes)"; failed=$((failed+1)); fi
done
# Models alone: no mesh and no number to converge along, so no convergence plot, and a note says why.
check study_no_convergence 0 "no convergence\.png: no sweep changes the mesh" -- "$pliant" study "$bar" \
  --sweep 'bodies[0].model="linear"|"springs"' --out "$work/study2"
if [ -s "$work/study2/pareto.png" ] && [ ! -e "$work/study2/convergence.png" ]; then
  echo "ok   study without convergence"; passed=$((passed+1)); else echo "FAIL study without convergence"; failed=$((failed+1)); fi
check study_bad_cost 2 "--cost must be wall or tet-steps" -- "$pliant" study "$bar" --sweep 'bodies[0].model="linear"' --cost joules --out "$work/study3"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
