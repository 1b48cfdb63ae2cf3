#!/usr/bin/env bash
# What the command line and scene files refuse or say that they once took without a word, hung on,
# or overwrote (an audit of 2026-11-29, docs/reliability.md): each case with its exit code and the
# words of its message. Usage: cli_bad_input.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, scene

box='"mesh": {"box": {"min": [0,0,0], "max": [0.2,0.05,0.05], "cells": [8,2,2]}}'
fixed='"fixed": [{"box": {"min": [-1,-1,-1], "max": [0.0001,1,1]}}]'
scene good "{\"duration\": 0.002, \"bodies\": [{\"name\": \"b\", $box, $fixed}]}"
json_num() { sed -n "s/^  \"$2\": \([-0-9.e+]*\),\{0,1\}$/\1/p" "$1" | head -n 1; }

# A frame far below a step hung for ever (the next frame's end was searched one frame at a time);
# below a step, every step is its own frame, and the run says so.
check realtime_tiny_frame 0 "realtime_frame 1e-15 s is shorter than a step" -- timeout 60 "$pliant" run "$work/good.json" \
  --out "$work/rt" --realtime --realtime-frame 1e-15
# --realtime-frame without a real-time run was ignored (--realtime-priority was refused).
check realtime_frame_needs_realtime 2 "--realtime-frame needs a real-time run" -- "$pliant" run "$work/good.json" \
  --out "$work/o" --realtime-frame 0.5
# A duration below one step ran 0 steps and said ok.
check duration_below_a_step 0 "duration 1e-300 s is shorter than one step" -- "$pliant" run "$work/good.json" \
  --out "$work/short" --duration 1e-300
if [ "$(json_num "$work/short/summary.json" steps)" = "1" ]; then ok "one step for a duration below a step"
else fail "one step for a duration below a step: $(json_num "$work/short/summary.json" steps)"; fi
# An --out that is a file failed after the world was built, as a bare filesystem error.
: > "$work/afile"
check out_is_a_file 2 "--out .*afile: exists and is not a folder" -- "$pliant" run "$work/good.json" --out "$work/afile"
# Empty option values read as options not given.
check empty_precision 2 "--precision: an empty value" -- "$pliant" run "$work/good.json" --out "$work/o" --precision ''
check empty_duration 2 "--duration: an empty value" -- "$pliant" run "$work/good.json" --out "$work/o" --duration ''
check empty_schedule 2 "--schedule: an empty value" -- "$pliant" run "$work/good.json" --out "$work/o" --schedule ''
# A tool listing no body touched every body.
scene tool_no_body "{\"duration\": 0.002, \"bodies\": [{\"name\": \"b\", $box, $fixed}], \"tools\": [{\"shape\": {\"sphere\": {\"radius\": 0.01}}, \"path\": {\"keyframes\": [{\"time\": 0, \"position\": [0.1, 0.025, 0.2]}]}, \"bodies\": []}]}"
check tool_lists_no_body 2 "tools\[0\]\.bodies.*at least one body" -- "$pliant" run "$work/tool_no_body.json" --out "$work/o"
# What World refuses names the scene file and its entry, not only the body's field.
scene no_node "{\"bodies\": [{\"name\": \"b\", $box, \"fixed\": [{\"box\": {\"min\": [5,5,5], \"max\": [6,6,6]}}]}]}"
check world_error_names_file 2 "no_node\.json: bodies\[0\]: body 'b': fixed\[0\].*selects no node" -- "$pliant" run "$work/no_node.json" --out "$work/o"

# mesh and render replaced their input by their output when -o named it.
cp "$src/tests/data/mesh/cube.vtu" "$work/cube.vtu"
before=$(md5sum < "$work/cube.vtu")
check mesh_onto_its_input 2 "-o .*cube\.vtu: is the input file" -- "$pliant" mesh "$work/cube.vtu" -o "$work/cube.vtu"
check render_onto_its_input 2 "-o .*cube\.vtu: is the input file" -- "$pliant" render "$work/cube.vtu" -o "$work/cube.vtu"
if [ "$(md5sum < "$work/cube.vtu")" = "$before" ]; then ok "the input mesh is untouched"; else fail "the input mesh was changed"; fi
check mesh_file_and_implicit 2 "give a file .* or --implicit sphere, not both" -- "$pliant" mesh "$work/cube.vtu" --implicit sphere \
  --cell-size 0.1 -o "$work/x.vtu"

# info and mesh took --faces counts that shrink (a "coarser" level finer than the next); the scene
# reader refuses them.
check faces_must_grow 2 "--faces: the counts must grow from coarse to fine: 5 after 10" -- "$pliant" info "$work/cube.vtu" --faces 10,5

# stress: a seed that is not a number was an internal error (exit 1); a missing mesh folder ran
# with 0 meshes; negative counts meant "no limit"; an infinite time ran for ever.
check stress_bad_seed 2 "--scene abc: expected a scene's seed" -- "$pliant" stress --scene abc
check stress_missing_meshes 2 "--meshes .*nowhere: not a folder" -- "$pliant" stress --seconds 1 --meshes "$work/nowhere"
check stress_negative_max_scenes 2 "--max-scenes must be >= 0" -- "$pliant" stress --seconds 1 --max-scenes -5
check stress_negative_repeat 2 "--repeat-every must be >= 0" -- "$pliant" stress --seconds 1 --repeat-every -1
check stress_infinite_seconds 2 "--seconds must be a finite number" -- "$pliant" stress --seconds inf
# stability: a filter that matches no cell passed with "0 unexpected".
check stability_filter_matches_nothing 2 "--filter \"zzz\": no cell" -- "$pliant" stability --subset --filter zzz
check stability_negative_steps 2 "--steps must be > 0" -- "$pliant" stability --subset --steps -5

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
