#!/usr/bin/env bash
# The plan `pliant run` prints before stepping, `--dry-run`, the unit-mistake warnings and the
# progress lines when stderr is not a terminal (here it is a file). Usage: cli_plan.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail, png_size, scene
line_of() { grep -n -m1 -E -- "$2" "$1" | cut -d: -f1; }  # line_of FILE PATTERN: first matching line number

fixed='"fixed": [{"box": {"min": [-1,-1,-1], "max": [0.00001,1e4,1e4]}}]'
# A 200 x 50 x 50 mm block written in mm without a scale: 200 m. It runs, but the plan warns first.
scene mm "{\"duration\": 0.05, \"threads\": 1, \"bodies\": [{\"name\": \"block\", \"mesh\": {\"box\": {\"min\": [0,0,0], \"max\": [200,50,50], \"cells\": [8,2,2], \"tets_per_cell\": 6}}, $fixed}]}"
check mm_run 0 "warning: body 'block' is 200 m across .*\"scale\": 0\.001" -- "$pliant" run "$work/mm.json" --out "$work/mm"
w=$(line_of "$work/mm_run.out" "warning: body 'block'"); p=$(line_of "$work/mm_run.out" "^plan: 1 body, 81 nodes, 192 tets"); r=$(line_of "$work/mm_run.out" "steps of .* to t = ")
if [ -n "$w" ] && [ -n "$p" ] && [ -n "$r" ] && [ "$w" -lt "$r" ] && [ "$p" -lt "$r" ]; then ok "plan and warning before the run (lines $p, $w < $r)"
else fail "plan and warning before the run (plan '$p', warning '$w', report '$r')"; fi
grep -q "dt .* s: the stable bound (Courant 0.5 x 2/omega_max" "$work/mm_run.out" && ok "the plan says why dt" || fail "the plan says why dt"

# --dry-run: the plan with an estimate from timed steps, exit 0, nothing written.
check dry_run 0 "estimate: .* of stepping \(timed over [0-9]+ steps?" -- "$pliant" run "$work/mm.json" --out "$work/dry" --dry-run
grep -q "dry run: nothing was written" "$work/dry_run.out" && ok "dry run says so" || fail "dry run says so"
grep -q "warning: body 'block' is 200 m" "$work/dry_run.out" && ok "dry run warns" || fail "dry run warns"
[ ! -e "$work/dry" ] && ok "dry run writes nothing" || fail "dry run created $work/dry"
scene probes "{\"duration\": 0.02, \"bodies\": [{\"name\": \"b\", \"mesh\": {\"box\": {\"max\": [0.2,0.05,0.05], \"cells\": [8,2,2], \"tets_per_cell\": 6}}, $fixed}], \"probes\": [{\"name\": \"tip\", \"body\": \"b\", \"point\": [0.2,0.025,0.025]}], \"output\": {\"vtu_every\": 0.01}}"
check dry_run_files 0 "writes: summary\.json, probes\.csv, series\.pvd \+ vtu/ \(3 frames x 1 body\), sheet\.png" -- \
  "$pliant" run "$work/probes.json" --out "$work/dry2" --dry-run --sheet
[ ! -e "$work/dry2" ] && ok "dry run with pictures writes nothing" || fail "dry run with pictures created $work/dry2"
# A run of more than 10 million steps is warned about (the dry run times a few of them only).
scene long "{\"duration\": 1e4, \"bodies\": [{\"name\": \"b\", \"mesh\": {\"box\": {\"max\": [0.2,0.05,0.05], \"cells\": [8,2,2], \"tets_per_cell\": 6}}, $fixed}]}"
check too_many_steps 0 "warning: [0-9.]+ million steps .*more than 10 million" -- "$pliant" run "$work/long.json" --out "$work/long" --dry-run
check quiet_dry_run_warns 0 "more than 10 million" -- "$pliant" run "$work/long.json" --out "$work/long" --dry-run --quiet
if ! grep -q "^plan:" "$work/quiet_dry_run_warns.out"; then ok "quiet: no plan, the warning only"; else fail "quiet printed the plan"; fi

# Progress when stderr is not a terminal: a line every --progress-every seconds, each on its own
# (no carriage returns), after the estimate; --quiet silences them. 12k tets for about 1.5 s.
scene slow "{\"duration\": 0.3, \"threads\": 1, \"bodies\": [{\"name\": \"b\", \"mesh\": {\"box\": {\"max\": [0.2,0.05,0.05], \"cells\": [32,8,8], \"tets_per_cell\": 6}}, $fixed}]}"
check progress_lines 0 "estimate: " -- "$pliant" run "$work/slow.json" --out "$work/slow" --progress-every 0.2
n=$(grep -cE "^pliant: +[0-9.]+%  t = [0-9.e-]+ / 0\.3 s  step [0-9]+ / [0-9]+  [0-9]+ steps/s  ETA [0-9.]+ (s|min)$" "$work/progress_lines.out")
if [ "$n" -ge 2 ]; then ok "progress lines on a non-terminal ($n)"; else fail "progress lines on a non-terminal: $n"; sed 's/^/    /' "$work/progress_lines.out"; fi
if ! grep -q $'\r' "$work/progress_lines.out"; then ok "no carriage returns in a log"; else fail "carriage returns in a log"; fi
e=$(line_of "$work/progress_lines.out" "estimate: "); g=$(line_of "$work/progress_lines.out" "^pliant: +[0-9.]+%")
[ -n "$e" ] && [ -n "$g" ] && [ "$e" -lt "$g" ] && ok "the estimate comes before the progress lines" || fail "estimate ($e) before progress ($g)"
check progress_quiet 0 "" -- "$pliant" run "$work/slow.json" --out "$work/slow_q" --progress-every 0.2 --quiet
[ ! -s "$work/progress_quiet.out" ] && ok "--quiet silences plan and progress" || fail "--quiet printed: $(head -c 200 "$work/progress_quiet.out")"
check bad_progress_every 2 "--progress-every must be a finite number > 0" -- "$pliant" run "$work/slow.json" --out "$work/x" --progress-every 0
# Real time in frames: the report counts frames of the given length; a negative frame is refused.
check realtime_frames 0 "of 10 frames of 1 ms ended after" -- "$pliant" run "$work/slow.json" --out "$work/rt" --duration 0.01 --realtime --realtime-frame 0.001
check bad_realtime_frame 2 "--realtime-frame must be a finite number >= 0" -- "$pliant" run "$work/slow.json" --out "$work/x" --realtime --realtime-frame -1
check priority_needs_realtime 2 "--realtime-priority needs a real-time run" -- "$pliant" run "$work/slow.json" --out "$work/x" --realtime-priority
check priority_said 0 "real-time priority" -- "$pliant" run "$work/slow.json" --out "$work/rtp" --duration 0.01 --realtime --realtime-priority

# A surface in mm without a scale (CGAL builds): the warning comes before meshing starts, so it
# is seen even when the mesher then refuses the cell size.
if has_cgal; then
  v=("0 0 0" "250 0 0" "250 250 0" "0 250 0" "0 0 250" "250 0 250" "250 250 250" "0 250 250")
  f=("0 2 1" "0 3 2" "4 5 6" "4 6 7" "0 1 5" "0 5 4" "1 2 6" "1 6 5" "2 3 7" "2 7 6" "3 0 4" "3 4 7")
  { for p in "${v[@]}"; do echo "v $p"; done; for t in "${f[@]}"; do set -- $t; echo "f $(($1+1)) $(($2+1)) $(($3+1))"; done; } > "$work/cube_mm.obj"
  scene mm_surface "{\"duration\": 0.01, \"bodies\": [{\"name\": \"part\", \"mesh\": {\"surface\": \"cube_mm.obj\", \"cell_size\": 50}}]}"
  check mm_surface 0 "warning: body 'part' is 250 m across" -- "$pliant" run "$work/mm_surface.json" --out "$work/mms" --dry-run
  w=$(line_of "$work/mm_surface.out" "warning: body 'part'"); m=$(line_of "$work/mm_surface.out" "^meshing body 'part': surface cube_mm\.obj, cell_size 50 m, 250 m x 250 m x 250 m, about [0-9]+ tets")
  [ -n "$w" ] && [ -n "$m" ] && [ "$w" -lt "$m" ] && ok "mm surface: warning before meshing" || fail "mm surface: warning ($w) before meshing ($m)"
  scene mm_surface_small "{\"bodies\": [{\"name\": \"part\", \"mesh\": {\"surface\": \"cube_mm.obj\", \"cell_size\": 0.005}}]}"
  check mm_surface_refused 2 "cell_size" -- "$pliant" run "$work/mm_surface_small.json" --out "$work/mms2"
  w=$(line_of "$work/mm_surface_refused.out" "warning: body 'part': cell_size 5 mm is"); e=$(line_of "$work/mm_surface_refused.out" "^pliant: error:")
  [ -n "$w" ] && [ -n "$e" ] && [ "$w" -lt "$e" ] && ok "mm surface: warnings before the mesher's error" || fail "mm surface: warning ($w) before error ($e)"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
