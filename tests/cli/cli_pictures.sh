#!/usr/bin/env bash
# Pictures from the command line: `pliant run --png-every/--sheet/--size/--mp4/--field/--camera`
# and `pliant render SCENE|FILE.vtu`, on a small box scene (no CGAL): numbered frames of the
# requested size, a contact sheet, renders of a scene and of a run's .vtu frames (coloured by
# their stored displacement and von Mises fields, with their time), clear errors (exit 2) for
# bad names, and the same state hash with and without pictures.
# Usage: cli_pictures.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, png_size, scene
expect_png() {  # expect_png NAME FILE WxH
  local got; got=$(png_size "$2")
  if [ "$got" = "$3" ]; then ok "$1"; else fail "$1: $2 is '${got:-not a PNG}', expected $3"; fi
}
state_hash() { sed -n 's/.*"state_hash": *"\([0-9a-f]*\)".*/\1/p' "$1" 2>/dev/null; }

# A 0.2 m bar clamped at x = 0, sagging under gravity; a probe at its tip; VTU every 5 ms.
cat > "$work/box.json" <<'EOF'
{"duration": 0.01, "threads": 1,
 "bodies": [{"name": "b", "mesh": {"box": {"min": [0,0,0], "max": [0.2,0.05,0.05], "cells": [8,2,2]}},
             "material": {"young": 1e5},
             "fixed": [{"box": {"min": [-1,-1,-1], "max": [0.0001,1,1]}}]}],
 "probes": [{"name": "tip", "body": "b", "point": [0.2,0.025,0.025]}],
 "output": {"vtu_every": 0.005}}
EOF
box="$work/box.json"

# Numbered frames: t = 0, 2.5, 5, 7.5, 10 ms -> 5 frames of the requested size, and no sixth.
check png_every 0 "picture: .*frames/frame_00000\.png \.\. frame_00004\.png" -- \
  "$pliant" run "$box" --out "$work/frames" --png-every 0.0025 --size 320x240
n=$(ls "$work/frames/frames" 2>/dev/null | grep -cE '^frame_[0-9]{5}\.png$')
if [ "$n" = 5 ]; then ok "png_every writes 5 frames"; else fail "png_every writes 5 frames (found $n)"; fi
for i in 0 1 2 3 4; do expect_png "frame $i is 320x240" "$work/frames/frames/frame_0000$i.png" 320x240; done
[ ! -e "$work/frames/sheet.png" ] && ok "no sheet unless asked" || fail "a sheet was written without --sheet"
# The default size is 1280x720.
check png_default_size 0 "" -- "$pliant" run "$box" --out "$work/frames_default" --png-every 0.01 --quiet
expect_png "default frame size 1280x720" "$work/frames_default/frames/frame_00000.png" 1280x720

# The contact sheet, alone (no numbered frames) and with frames, coloured by von Mises stress.
check sheet 0 "picture: .*sheet\.png" -- "$pliant" run "$box" --out "$work/sheet" --sheet --size 320x240
s=$(png_size "$work/sheet/sheet.png")
if [ -n "$s" ] && [ "${s%x*}" -gt 320 ] && [ "${s#*x}" -gt 100 ]; then ok "sheet.png is a PNG ($s)"; else fail "sheet.png ($s)"; fi
[ ! -d "$work/sheet/frames" ] && ok "sheet alone writes no frames" || fail "sheet alone wrote frames/"
check sheet_von_mises 0 "" -- "$pliant" run "$box" --out "$work/sheet_vm" --sheet --png-every 0.005 --size 160x120 \
  --field von_mises --camera side --quiet
[ -s "$work/sheet_vm/sheet.png" ] && expect_png "von Mises frames 160x120" "$work/sheet_vm/frames/frame_00002.png" 160x120 \
  || fail "von Mises sheet"

# Pictures do not change the simulation: same state hash with and without them.
check no_pictures 0 "" -- "$pliant" run "$box" --out "$work/plain" --quiet
h0=$(state_hash "$work/plain/summary.json"); h1=$(state_hash "$work/frames/summary.json"); h2=$(state_hash "$work/sheet_vm/summary.json")
if [ -n "$h0" ] && [ "$h0" = "$h1" ] && [ "$h0" = "$h2" ]; then ok "same state hash with and without pictures ($h0)"
else fail "state hash: plain '$h0', --png-every '$h1', --sheet --field von_mises '$h2'"; fi

# pliant render: a scene (rest state) and a run's stored frames.
check render_scene 0 "wrote .*scene\.png \(320x240" -- "$pliant" render "$box" -o "$work/scene.png" --size 320x240
expect_png "render scene 320x240" "$work/scene.png" 320x240
check render_scene_default 0 "" -- "$pliant" render "$box" -o "$work/scene_default.png" --quiet
expect_png "render default size" "$work/scene_default.png" 1280x720
vtu="$work/frames/vtu/b_00002.vtu"  # t = 0.01 s
[ -s "$vtu" ] && ok "run wrote $(basename "$vtu")" || fail "run wrote no $vtu"
# A run's .vtu is coloured by its stored displacement by default, and its time (from series.pvd) is shown.
check render_vtu 0 "wrote .*frame\.png \(400x300, displacement, t = 0\.01[0-9]* s\)" -- \
  "$pliant" render "$vtu" -o "$work/frame.png" --size 400x300
expect_png "render vtu 400x300" "$work/frame.png" 400x300
check render_vtu_displacement 0 "displacement, t = 0\.00[56][0-9]* s" -- \
  "$pliant" render "$work/frames/vtu/b_00001.vtu" -o "$work/frame_d.png" --field displacement --size 200x150
check render_vtu_von_mises 0 "von_mises, t = 0\.01[0-9]* s" -- \
  "$pliant" render "$vtu" -o "$work/frame_vm.png" --field von_mises --size 200x150 --camera top
expect_png "render vtu von Mises" "$work/frame_vm.png" 200x150
check render_vtu_none 0 "\(200x150, none" -- "$pliant" render "$vtu" -o "$work/frame_n.png" --field none --size 200x150
# Default output name: the input's name with .png, in the current folder.
check render_default_name 0 "" -- bash -c "cd '$work' && '$pliant' render '$vtu' --size 64x48 --quiet"
expect_png "render default name" "$work/b_00002.png" 64x48
# A bare mesh (no fields, no series): displacement needs --rest; von Mises cannot be had.
mkdir -p "$work/bare"
check mesh_copy 0 "" -- "$pliant" mesh "$vtu" -o "$work/bare/copy.vtu"
check render_bare 0 "\(200x150, none\)" -- "$pliant" render "$work/bare/copy.vtu" -o "$work/bare.png" --size 200x150
check render_bare_displacement 2 "--field displacement needs .*--rest" -- \
  "$pliant" render "$work/bare/copy.vtu" -o "$work/bare_d.png" --field displacement
check render_bare_von_mises 2 "--field von_mises needs .*von_mises" -- \
  "$pliant" render "$work/bare/copy.vtu" -o "$work/bare_vm.png" --field von_mises
check render_bare_rest 0 "\(200x150, displacement\)" -- "$pliant" render "$work/bare/copy.vtu" \
  --rest "$work/frames/vtu/b_00000.vtu" -o "$work/bare_rest.png" --size 200x150
expect_png "render with --rest" "$work/bare_rest.png" 200x150
check render_missing 2 "absent\.vtu" -- "$pliant" render "$work/absent.vtu" -o "$work/x.png"

# Bad names and values: exit 2, the message names the option and the value.
check run_bad_camera 2 "--camera: unknown camera \"iso\".*scene, auto, front, side, top" -- \
  "$pliant" run "$box" --out "$work/bad" --png-every 0.005 --camera iso
check run_bad_field 2 "--field: unknown field \"stress\".*displacement, von_mises, level, none" -- \
  "$pliant" run "$box" --out "$work/bad" --png-every 0.005 --field stress
check render_bad_camera 2 "--camera: unknown camera \"iso\"" -- "$pliant" render "$box" -o "$work/x.png" --camera iso
check render_bad_field 2 "--field: unknown field \"stress\"" -- "$pliant" render "$vtu" -o "$work/x.png" --field stress
check run_bad_size 2 "--size: expected WIDTHxHEIGHT" -- "$pliant" run "$box" --out "$work/bad" --png-every 0.005 --size 320
check render_bad_size 2 "--size: width 8 is outside" -- "$pliant" render "$box" -o "$work/x.png" --size 8x8
check run_bad_png_every 2 "--png-every must be > 0" -- "$pliant" run "$box" --out "$work/bad" --png-every -1
[ ! -e "$work/x.png" ] && ok "no picture after an error" || fail "a picture was written after an error"

# --mp4: a video with ffmpeg; without it, a clear message before any work (exit 2).
if command -v ffmpeg >/dev/null 2>&1; then
  check mp4 0 "picture: .*movie\.mp4" -- "$pliant" run "$box" --out "$work/movie" --mp4 --size 160x120
  [ -s "$work/movie/movie.mp4" ] && ok "movie.mp4 written" || fail "movie.mp4 missing"
else
  check mp4_without_ffmpeg 2 "--mp4 needs ffmpeg, which is not installed" -- \
    "$pliant" run "$box" --out "$work/movie" --mp4 --size 160x120
  [ ! -e "$work/movie/summary.json" ] && ok "--mp4 without ffmpeg runs nothing" || fail "--mp4 without ffmpeg ran the scene"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
