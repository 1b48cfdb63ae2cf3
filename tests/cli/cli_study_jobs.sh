#!/usr/bin/env bash
# A study beyond one process (issue 11 §4): `pliant study --jobs FILE` writes one command per run,
# each line runs from any working directory as its own process, `--collect DIR` assembles the same
# study.csv as the in-process study (but for the timing columns), and `--parallel N` does it all on
# this machine. Usage: cli_study_jobs.sh PLIANT SOURCE_DIR WORK_DIR
set -u
pliant=$1; src=$2; work=$3
rm -rf "$work"; mkdir -p "$work"
. "$(dirname "$0")/cli_lib.sh"  # check, ok, fail

bar="$src/scenes/validation/slender_bar.json"
sweeps=(--sweep 'bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]' --sweep 'bodies[0].model="linear"|"corotational"' --cost tet-steps)
# study.csv without the columns a machine's timing decides (setup_s, wall_s, repeats, wall_per_sim_s);
# commas inside quoted fields ("[10,1,1]") become ';' first, so that awk splits at columns only.
untimed() {
  sed -E ':a; s/^(([^"]*"[^"]*")*[^"]*"[^",]*),/\1;/; ta' "$1" | awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) drop[i] = ($i ~ /^(setup_s|wall_s|repeats|wall_per_sim_s)$/) }
           { out = ""; for (i = 1; i <= NF; i++) if (!drop[i]) out = out (out == "" ? "" : ",") $i; print out }'
}

check in_process 0 "4 runs" -- "$pliant" study "$bar" "${sweeps[@]}" --out "$work/direct"

# The job list: one line per run, absolute paths, a comment naming the settings.
check jobs_written 0 "4 runs written to .*jobs\.txt" -- \
  "$pliant" study "$bar" "${sweeps[@]}" --out "$work/study" --jobs "$work/jobs.txt"
if [ "$(wc -l < "$work/jobs.txt")" = 4 ] && grep -q "^'/.*' study --out '$work/study' --run 3  # cells=\[20,1,1\], model=linear$" "$work/jobs.txt"; then
  ok "one line per run"; else fail "one line per run: $(head -n 3 "$work/jobs.txt" | tr '\n' '|')"; fi
[ ! -e "$work/study/runs" ] && ok "jobs do not run" || fail "jobs ran"
for hint in "parallel < $work/jobs.txt" "sbatch --array=1-4 scripts/study-slurm.sh $work/jobs.txt" "pliant study --collect $work/study"; do
  grep -qF -- "$hint" "$work/jobs_written.out" && ok "says: $hint" || fail "says: $hint"
done

# Collecting before the runs: the missing ones are named.
check collect_missing 2 "4 of 4 runs have no run.json \(runs 1, 2, 3, 4\)" -- "$pliant" study --collect "$work/study"

# Each line from another working directory, in reverse order, as GNU parallel or Slurm would.
mkdir -p "$work/elsewhere"
status=0
for k in 4 3 2 1; do (cd "$work/elsewhere" && bash -c "$(sed -n "${k}p" "$work/jobs.txt")") >"$work/job$k.out" 2>&1 || status=1; done
[ "$status" = 0 ] && [ -s "$work/study/runs/0004/run.json" ] && ok "job lines run anywhere" || { fail "job lines run anywhere"; cat "$work"/job*.out | tail -5; }
grep -q "^\[2/4\] cells=\[10,1,1\], model=corotational: bar_speed = " "$work/job2.out" && ok "a job's progress line" || fail "a job's progress line: $(cat "$work/job2.out")"

check collect 0 "4 runs in .* on the Pareto front; results in .*study\.csv.*pareto\.png" -- "$pliant" study --collect "$work/study"
if [ -s "$work/direct/study.csv" ] && [ "$(untimed "$work/study/study.csv")" = "$(untimed "$work/direct/study.csv")" ]; then
  ok "collected study.csv = in-process study.csv"
else fail "collected study.csv differs:"; diff <(untimed "$work/direct/study.csv") <(untimed "$work/study/study.csv") | head -5; fi
[ -s "$work/study/pareto.png" ] && ok "collect draws the plots" || fail "collect draws the plots"

# GNU parallel when the machine has it (scripts/install-deps.sh does not install it).
if command -v parallel >/dev/null 2>&1; then
  check gnu_parallel_jobs 0 "" -- "$pliant" study "$bar" "${sweeps[@]}" --out "$work/gnu" --jobs "$work/gnu.txt"
  (cd / && parallel -j 2 < "$work/gnu.txt") >"$work/gnu.out" 2>&1
  check gnu_parallel_collect 0 "4 runs" -- "$pliant" study --collect "$work/gnu"
  [ "$(untimed "$work/gnu/study.csv")" = "$(untimed "$work/direct/study.csv")" ] && ok "GNU parallel study.csv" || fail "GNU parallel study.csv"
else
  echo "skip GNU parallel: not installed"
fi

# --parallel N: the same, N processes on this machine, then collected.
check parallel 0 "4 runs in .*results in .*study\.csv" -- "$pliant" study "$bar" "${sweeps[@]}" --out "$work/par" --parallel 2
[ "$(untimed "$work/par/study.csv")" = "$(untimed "$work/direct/study.csv")" ] && ok "--parallel study.csv" || fail "--parallel study.csv"
[ "$(wc -l < "$work/par/jobs.txt")" = 4 ] && ok "--parallel keeps its job list" || fail "--parallel keeps its job list"

# Errors: a run out of range, options that belong in study.json, a scene edited after the list.
check run_out_of_range 2 "--run 9: the study in .* has runs 1 to 4" -- "$pliant" study --out "$work/study" --run 9
check run_needs_out 2 "--run K needs --out DIR" -- "$pliant" study --run 1
check collect_no_sweeps 2 "--collect takes no --sweep" -- "$pliant" study --collect "$work/study" --sweep 'a=1'
check no_scene 2 "SCENE is required" -- "$pliant" study --out "$work/x"
check parallel_zero 2 "--parallel must be >= 1" -- "$pliant" study "$bar" "${sweeps[@]}" --out "$work/p0" --parallel 0
cp "$bar" "$work/bar.json"; cp "${bar%.json}.reference.json" "$work/bar.reference.json"
check edit_jobs 0 "" -- "$pliant" study "$work/bar.json" --sweep 'bodies[0].mesh.box.cells=[10,1,1]' --out "$work/edit" --jobs "$work/edit.txt"
echo " " >> "$work/bar.json"
check edited_scene 2 "changed since the job list was written" -- bash -c "$(head -n 1 "$work/edit.txt")"

# A scene without a reference file runs anyway (issue 11 §5): the probes against the finest run,
# with a note, in columns named with their unit; collected from a job list, the note comes with it.
cp "$bar" "$work/noref.json"
check no_reference 0 "note: no reference file .*noref\.reference\.json: measuring the displacement of probe tip" -- \
  "$pliant" study "$work/noref.json" --sweep 'duration=0.05' --sweep 'bodies[0].mesh.box.cells=[10,1,1]|[20,1,1]' --out "$work/noref"
head -n 1 "$work/noref/study.csv" | grep -q ",tip_displacement_m,tip_displacement_reference_m,tip_displacement_error," \
  && ok "no-reference columns" || fail "no-reference columns: $(head -n 1 "$work/noref/study.csv")"
check no_reference_jobs 0 "" -- "$pliant" study "$work/noref.json" --sweep 'duration=0.05' --out "$work/noref_jobs" --parallel 1
grep -q "note: no reference file" "$work/no_reference_jobs.out" && ok "collected study keeps the note" || fail "collected study keeps the note"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
