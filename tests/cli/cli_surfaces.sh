#!/usr/bin/env bash
# Surfaces and `pliant info`: a surface that does not bound a volume gets a diagnosis (how many
# non-manifold edges, holes, crossing faces, and where) from `pliant info` and in the error of
# `pliant mesh`/`run`; --repair meshes what CGAL can repair; info takes --scale and, for a
# surface, --cell-size. Without CGAL, surface commands say so (exit 2).
# Usage: cli_surfaces.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, png_size, scene
meshes="$src/data/meshes"

# Volume meshes: --scale turns the file's units into metres; --cell-size is for surfaces.
check info_scale 0 "bounding box .* m \(0\.22[0-9]* x 0\.17[0-9]* x 0\.15[0-9]* m\)" -- "$pliant" info "$meshes/liver.msh" --scale 0.035
check info_volume_cell_size 2 "--cell-size is for surface files" -- "$pliant" info "$meshes/liver.msh" --cell-size 0.01
check info_bad_scale 2 "--scale must be a finite number > 0" -- "$pliant" info "$meshes/liver.msh" --scale 0

# A cube of 250 mm written in mm, closed; and the same without its top face (one hole).
v=("0 0 0" "250 0 0" "250 250 0" "0 250 0" "0 0 250" "250 0 250" "250 250 250" "0 250 250")
f=("0 2 1" "0 3 2" "0 1 5" "0 5 4" "1 2 6" "1 6 5" "2 3 7" "2 7 6" "3 0 4" "3 4 7" "4 5 6" "4 6 7")
{ echo "OFF"; echo "8 12 0"; for p in "${v[@]}"; do echo "$p"; done; for t in "${f[@]}"; do echo "3 $t"; done; } > "$work/cube_mm.off"
{ echo "OFF"; echo "8 10 0"; for p in "${v[@]}"; do echo "$p"; done; for t in "${f[@]:0:10}"; do echo "3 $t"; done; } > "$work/open_mm.off"

if ! has_cgal; then
  check info_surface_without_cgal 2 "without CGAL" -- "$pliant" info "$work/cube_mm.off"
  echo "$passed passed, $failed failed"; [ "$failed" -eq 0 ]; exit
fi

check info_surface 0 "watertight: yes .*volume 0\.015625 m\^3" -- "$pliant" info "$work/cube_mm.off" --scale 0.001
grep -q "bounding box \[0, 0, 0\] .. \[0.25, 0.25, 0.25\] m" "$work/info_surface.out" && ok "surface box in m after --scale" || fail "surface box in m after --scale"
check info_cell_size 0 "cell size 0\.025 m: about 4300 tets" -- "$pliant" info "$work/cube_mm.off" --scale 0.001 --cell-size 0.025
grep -qE "^  meshed:" "$work/info_cell_size.out" && grep -q "stable dt" "$work/info_cell_size.out" && ok "info meshes at --cell-size" || fail "info meshes at --cell-size"
check info_open 0 "open: 4 border edges .*1 hole .* of 4 edges around \(125, 125, 250\)" -- "$pliant" info "$work/open_mm.off"
check info_open_repair 0 "filled 1 hole" -- "$pliant" info "$work/open_mm.off" --repair
grep -q "watertight: yes" "$work/info_open_repair.out" && ok "repaired surface is watertight" || fail "repaired surface is watertight"
check mesh_open 2 "1 hole .*|--repair" -- "$pliant" mesh "$work/open_mm.off" --cell-size 25 -o "$work/open.vtu"
grep -q "tries CGAL's repair" "$work/mesh_open.out" && ok "the error suggests --repair" || fail "the error suggests --repair"
check mesh_open_repair 0 "open\.vtu: [0-9]+ nodes, [0-9]+ tets, volume 1\.5[0-9]*e\+07 m\^3" -- "$pliant" mesh "$work/open_mm.off" --cell-size 25 --repair -o "$work/open.vtu"
# The same from a scene (a 25 cm open box in metres): "repair": true, and pliant run --repair.
{ echo "OFF"; echo "8 10 0"; for p in "${v[@]}"; do set -- $p; echo "$(($1/10))e-2 $(($2/10))e-2 $(($3/10))e-2"; done
  for t in "${f[@]:0:10}"; do echo "3 $t"; done; } > "$work/open_m.off"
scene open_scene "{\"duration\": 0.001, \"bodies\": [{\"name\": \"box\", \"mesh\": {\"surface\": \"open_m.off\", \"cell_size\": 0.025}}]}"
check run_open 2 "1 hole" -- "$pliant" run "$work/open_scene.json" --out "$work/o1"
check run_open_repair 0 "results in" -- "$pliant" run "$work/open_scene.json" --out "$work/o2" --repair
scene open_scene2 "{\"duration\": 0.001, \"bodies\": [{\"name\": \"box\", \"mesh\": {\"surface\": \"open_m.off\", \"cell_size\": 0.025, \"repair\": true}}]}"
check run_open_repair_key 0 "results in" -- "$pliant" run "$work/open_scene2.json" --out "$work/o3"

# The shipped dragon.obj: diagnosed, and refused even after the repair, with what is left.
check info_dragon 0 "97 non-manifold edges .*e\.g\. at \(" -- "$pliant" info "$meshes/dragon.obj"
grep -q "watertight: no" "$work/info_dragon.out" && grep -qE "[0-9]+ pairs of faces intersect within" "$work/info_dragon.out" \
  && ok "dragon: open and self-intersecting" || fail "dragon: open and self-intersecting"
check mesh_dragon 2 "what is wrong with it" -- "$pliant" mesh "$meshes/dragon.obj" --cell-size 0.5 -o "$work/dragon.vtu"
check mesh_dragon_repair 2 "did not make it bound a volume; still:" -- "$pliant" mesh "$meshes/dragon.obj" --cell-size 0.5 --repair -o "$work/dragon.vtu"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
