#!/usr/bin/env bash
# Command-line behaviour of `pliant`: exit codes (0 ok, 1 internal, 2 invalid input, 3 diverged), the
# files a run writes, and error messages that name the field or file. Usage: cli_test.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, png_size, scene

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
# More threads than cores: clamped to the cores, and said (it was accepted and reported as 100000).
check run_threads_clamped 0 "note: threads: 100000 threads asked, $(nproc) used" -- "$pliant" run "$work/good.json" --out "$work/othr" --threads 100000
if [ "$(sed -n 's/^  "threads": \([0-9]*\),$/\1/p' "$work/othr/summary.json")" = "$(nproc)" ]; then
  echo "ok   clamped threads in summary"; passed=$((passed+1)); else echo "FAIL clamped threads in summary"; failed=$((failed+1)); fi
# A duration whose step count cannot be counted (it ran 0 steps and said ok): refused, exit 2.
check run_duration_huge 2 "duration 1e\+30 s .*steps" -- "$pliant" run "$work/good.json" --out "$work/o" --duration 1e30
scene huge "{\"duration\": 1e30, \"bodies\": [{\"name\": \"b\", $box, $fixed}]}"
check scene_duration_huge 2 "duration 1e\+30 s .*steps" -- "$pliant" run "$work/huge.json" --out "$work/o"
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
# Load fixes are reported, not silent: cube_inverted.msh has 2 triangles and an inverted tet.
scene fixes "{\"duration\": 0.001, \"gravity\": [0,0,0], \"bodies\": [{\"name\": \"c\", \"mesh\": {\"file\": \"$src/tests/data/mesh/cube_inverted.msh\", \"scale\": 0.1}}]}"
check run_load_notes 0 "body 'c': mesh loaded with 2 non-tetrahedral cell\(s\) skipped, [1-9][0-9]* inverted tet\(s\) re-oriented" -- "$pliant" run "$work/fixes.json" --out "$work/ofix"
if grep -q '"notes"' "$work/ofix/summary.json" 2>/dev/null; then echo "ok   load notes in summary"; passed=$((passed+1)); else echo "FAIL load notes in summary"; failed=$((failed+1)); fi

# The adaptive step: a soft stvk beam collapsing under its own weight is sub-stepped and says so;
# the summary carries the counts. With "adapt": false the summary shows no sub-stepping.
soft='"mesh": {"box": {"min": [0,0,0], "max": [0.1,0.025,0.025], "cells": [6,2,2]}}, "model": "stvk", "material": {"young": 100, "poisson": 0.3, "density": 1000}'
scene collapse "{\"duration\": 0.5, \"bodies\": [{\"name\": \"s\", $soft, $fixed}]}"
check run_adaptive 0 "adaptive step: the deformation stiffened the elements up to" -- "$pliant" run "$work/collapse.json" --out "$work/ocol"
# json_num FILE KEY: a top-level number of summary.json (no python on a fresh machine).
json_num() { sed -n "s/^  \"$2\": \([-0-9.e+]*\),\{0,1\}$/\1/p" "$1" | head -n 1; }
if awk -v a="$(json_num "$work/ocol/summary.json" adapted_steps)" -v m="$(json_num "$work/ocol/summary.json" max_substeps)" \
       -v r="$(json_num "$work/ocol/summary.json" max_stiffness_ratio)" 'BEGIN { exit !(a > 0 && m > 1 && r > 2) }'; then
  echo "ok   adaptive counts in summary"; passed=$((passed+1)); else echo "FAIL adaptive counts in summary"; failed=$((failed+1)); fi

# Determinism across processes and thread counts: the same scene gives the same state hash.
hash_of() { sed -n 's/^  "state_hash": "\([0-9a-f]*\)",\{0,1\}$/\1/p' "$1"; }
"$pliant" run "$work/good.json" --out "$work/h1" --threads 1 --quiet && "$pliant" run "$work/good.json" --out "$work/h2" --threads 2 --quiet \
  && "$pliant" run "$work/good.json" --out "$work/h3" --threads 2 --quiet
if [ "$(hash_of "$work/h1/summary.json")" = "$(hash_of "$work/h2/summary.json")" ] && [ "$(hash_of "$work/h2/summary.json")" = "$(hash_of "$work/h3/summary.json")" ]; then
  echo "ok   same hash over runs and threads"; passed=$((passed+1)); else echo "FAIL hashes differ"; failed=$((failed+1)); fi
# --threads and --duration take effect (whole steps up to the duration: at most one step past it).
if awk -v t="$(json_num "$work/out2/summary.json" threads)" -v d="$(json_num "$work/out2/summary.json" simulated_time)" \
       'BEGIN { exit !(t == 1 && d >= 0.002 - 1e-12 && d < 0.0025) }'; then
  echo "ok   overrides in summary"; passed=$((passed+1)); else echo "FAIL overrides in summary"; failed=$((failed+1)); fi

# An output folder that cannot be made: exit 2, naming it.
check out_unwritable 2 "/proc/pliant-no" -- "$pliant" run "$work/good.json" --out /proc/pliant-no/x
check bad_option 2 "" -- "$pliant" run "$work/good.json" --bogus
check no_command 2 "" -- "$pliant"
check help 0 "run" -- "$pliant" --help
check bad_precision 2 "precision" -- "$pliant" run "$work/good.json" --precision half --out "$work/o"

# info and mesh on a small volume mesh written by pliant itself.
check mesh_convert_needs_input 2 "" -- "$pliant" mesh -o "$work/x.vtu"
"$pliant" run "$work/good.json" --out "$work/out4" -q
check info_vtu 0 "nodes 81  tets 160" -- "$pliant" info "$work/out4/vtu/b_00000.vtu"
check info_stable_dt 0 "stable dt" -- "$pliant" info "$work/out4/vtu/b_00000.vtu" --young 1e5
check info_missing 2 "absent.vtu" -- "$pliant" info "$work/absent.vtu"
# Only regular files are read: a FIFO named .msh made `info` wait forever, a link to /dev/zero was
# read until memory ran out. Each command that reads a file the user names, bounded by timeout
# and a memory limit so that a regression fails instead of hanging.
mkfifo "$work/fifo.msh" "$work/fifo.json" "$work/fifo.vtu"
ln -sf /dev/zero "$work/zero.msh"; ln -sf /dev/zero "$work/zero.json"; ln -sf /dev/zero "$work/zero.stl"
limited() { (ulimit -v 4000000; exec timeout 20 "$@"); }
check info_fifo 2 "fifo\.msh: is a FIFO \(named pipe\), not a regular file" -- limited "$pliant" info "$work/fifo.msh"
check info_dev_zero 2 "zero\.msh: is a character device, not a regular file" -- limited "$pliant" info "$work/zero.msh"
check run_fifo_scene 2 "fifo\.json: is a FIFO" -- limited "$pliant" run "$work/fifo.json" --out "$work/o"
check run_dev_zero_scene 2 "zero\.json: is a character device" -- limited "$pliant" run "$work/zero.json" --out "$work/o"
check render_fifo 2 "fifo\.vtu: is a FIFO" -- limited "$pliant" render "$work/fifo.vtu" -o "$work/x.png"
check render_dev_zero 2 "zero\.json: is a character device" -- limited "$pliant" render "$work/zero.json" -o "$work/x.png"
check study_fifo_scene 2 "fifo\.json: is a FIFO" -- limited "$pliant" study "$work/fifo.json" --sweep 'bodies[0].model="linear"' --out "$work/o"
check mesh_dev_zero 2 "zero\.stl: is a character device|built without CGAL" -- limited "$pliant" mesh "$work/zero.stl" --cell-size 0.1 -o "$work/x.vtu"
scene fifo_mesh "{\"bodies\": [{\"mesh\": {\"file\": \"fifo.msh\"}}]}"
check scene_fifo_mesh 2 "fifo\.msh: is a FIFO" -- limited "$pliant" run "$work/fifo_mesh.json" --out "$work/o"
check mesh_convert 0 "81 nodes, 160 tets" -- "$pliant" mesh "$work/out4/vtu/b_00000.vtu" -o "$work/copy.vtu"
# Meshing a closed surface (STL and PLY, written here: a unit cube of 12 triangles) and an implicit
# shape, when the build has CGAL (has_cgal: the build's option, checked against the mesher).
if has_cgal; then
  v=("0 0 0" "1 0 0" "1 1 0" "0 1 0" "0 0 1" "1 0 1" "1 1 1" "0 1 1")
  f=("0 2 1" "0 3 2" "4 5 6" "4 6 7" "0 1 5" "0 5 4" "1 2 6" "1 6 5" "2 3 7" "2 7 6" "3 0 4" "3 4 7")
  { echo "solid c"; for t in "${f[@]}"; do set -- $t
      echo " facet normal 0 0 0"; echo "  outer loop"
      for i in $1 $2 $3; do echo "   vertex ${v[$i]}"; done
      echo "  endloop"; echo " endfacet"; done; echo "endsolid c"; } > "$work/c.stl"
  { printf 'ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n'
    for p in "${v[@]}"; do echo "$p"; done; for t in "${f[@]}"; do echo "3 $t"; done; } > "$work/c.ply"
  check mesh_stl 0 "volume 1 m\^3" -- "$pliant" mesh "$work/c.stl" --cell-size 0.25 -o "$work/c_stl.vtu"
  check mesh_ply 0 "volume 1 m\^3" -- "$pliant" mesh "$work/c.ply" --cell-size 0.25 -o "$work/c_ply.vtu"
  check mesh_implicit 0 "tets, volume" -- "$pliant" mesh --implicit sphere --cell-size 0.02 -o "$work/sphere.vtu"
  check mesh_bad_cell_size 2 "cell-size" -- "$pliant" mesh "$work/c.stl" --cell-size -1 -o "$work/x.vtu"
  check info_meshed 0 "dihedral" -- "$pliant" info "$work/c_stl.vtu"
else  # a build without CGAL says so, exit 2
  check mesh_without_cgal 2 "built without CGAL" -- "$pliant" mesh --implicit sphere --cell-size 0.05 -o "$work/x.vtu"
fi

# study: the tables and the plots, their paths printed. test_study_plots checks the pixels; here,
# that the files are PNGs of 800x600 (from the IHDR chunk) and not near-empty (a blank 800x600
# plot compresses to about 2 KB; one with axes, labels and points, to more than 8 KB).
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
check study_bad_cost 2 "--cost must be wall, tet-steps or tet-updates" -- "$pliant" study "$bar" --sweep 'bodies[0].model="linear"' --cost joules --out "$work/study3"

# The measuring commands: a stability subset and a short stress run, each with its exit code.
check stability_subset 0 "unexpected" -- "$pliant" stability --subset --steps 200
check stress_short 0 "result: OK" -- "$pliant" stress --seconds 2 --threads 2 --seed 7

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
