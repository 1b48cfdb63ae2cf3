#!/usr/bin/env bash
# Before and after, side by side (issue 15 §3; docs/performance.md): builds an older commit of
# pliant in a directory of its own, builds the current tree's `pliant`, runs `pliant bench --csv`
# of both alternately on this machine (old, new, old, new, ...) and writes the CSVs and a Markdown
# table of the matched records (medians, ranges, speed-up = old time / new time), made by
# perf/compare_bench.py.
#
#   scripts/bench-against.sh [--commit c1dbd21] [--runs 3] [--quick] [--out DIR]
#                            [--build DIR] [--baseline-dir DIR] [--max-wait S] [--jobs N]
#
#   --commit REV       the "old" code (default c1dbd21, the reference of issue 15)
#   --runs N           runs of each version (default 3); they alternate, old first
#   --quick            `pliant bench --quick` (1k and 10k tets, 100k for the memory orders: no
#                      100k or 1M whole steps), 10-20 s a run on a quiet machine; the full set,
#                      the default, takes 1.5-4 minutes a run
#   --out DIR          where the CSVs, logs and comparison.md go
#                      (default out/bench-against-<commit>-<UTC date>/, ignored by git)
#   --build DIR        the current tree's build directory (default build/); configured Release
#                      with ccache if it does not exist yet; it must be a Release build
#   --baseline-dir DIR the old commit's export and build (default build-baseline-<commit>/,
#                      ignored by git); reused if there: the export is kept, the build is
#                      incremental (a no-op once built)
#   --max-wait S       passed to both benches: seconds each stage (and each case measured while
#                      others were busy) waits for a quiet machine; pliant's default is 30 s,
#                      0 measures at once (a check that the tool works on a busy machine)
#   --jobs N           build parallelism (default 2)
#
# The old build gets the current build's compiler, build type, CMAKE_CXX_FLAGS, PLIANT_NATIVE,
# PLIANT_WITH_CGAL and compiler launcher, so that the two differ by their source only; it builds
# the `pliant` target only, without tests. Each bench reads its own commit's scenes/ (a scene file
# that differs between the two is named in the table: its records then compare different scenes).
# The figures are only as good as the machine is quiet: run it on an idle host, and read the
# `others busy` columns and the load averages that the table states.
set -euo pipefail

commit=c1dbd21
runs=3
quick=0
out=""
build=""
baseline=""
max_wait=""
jobs=2

die() { echo "bench-against: $*" >&2; exit 2; }
need_value() { [[ $# -ge 2 && -n "$2" ]] || die "$1 needs a value"; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --commit) need_value "$@"; commit=$2; shift 2 ;;
    --runs) need_value "$@"; runs=$2; shift 2 ;;
    --quick) quick=1; shift ;;
    --out) need_value "$@"; out=$2; shift 2 ;;
    --build) need_value "$@"; build=$2; shift 2 ;;
    --baseline-dir) need_value "$@"; baseline=$2; shift 2 ;;
    --max-wait) need_value "$@"; max_wait=$2; shift 2 ;;
    --jobs) need_value "$@"; jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || die "--runs must be a positive integer, got '$runs'"
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || die "--jobs must be a positive integer, got '$jobs'"
[[ -z "$max_wait" || "$max_wait" =~ ^[0-9]+([.][0-9]+)?$ ]] || die "--max-wait must be a number of seconds, got '$max_wait'"
command -v python3 >/dev/null || die "python3 is needed for the comparison table (perf/compare_bench.py)"

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
full=$(git rev-parse --verify --quiet "${commit}^{commit}") || die "--commit $commit: not a commit of $root"
short=$(git rev-parse --short=7 "$full")
head=$(git rev-parse --short=7 HEAD)
if [[ -n $(git status --porcelain --untracked-files=no) ]]; then head="$head+uncommitted"; fi
build=$(realpath -m "${build:-$root/build}")
baseline=$(realpath -m "${baseline:-$root/build-baseline-$short}")
stamp=$(date -u +%Y%m%d-%H%M%S)
out=$(realpath -m "${out:-$root/out/bench-against-$short-$stamp}")
mkdir -p "$out"
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(dirname "$root")}
log() { echo "bench-against: $*" >&2; }

cache_value() {  # cache_value BUILD_DIR VAR: the value of VAR in BUILD_DIR/CMakeCache.txt, or empty
  sed -n "s/^$2:[A-Z]*=//p" "$1/CMakeCache.txt" | head -n 1
}

# ---- the current tree ----
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  log "configuring the current tree in $build (Release, ccache)"
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >"$out/configure-new.log" \
    || die "configuring $build failed: $out/configure-new.log"
fi
[[ "$(cache_value "$build" CMAKE_HOME_DIRECTORY)" == "$root" ]] \
  || die "--build $build was configured for $(cache_value "$build" CMAKE_HOME_DIRECTORY), not $root"
build_type=$(cache_value "$build" CMAKE_BUILD_TYPE)
[[ "$build_type" == Release ]] || die "$build is a '$build_type' build: compare Release builds (give --build DIR)"
log "building the current tree's pliant ($head) in $build"
cmake --build "$build" -j"$jobs" --target pliant >"$out/build-new.log" 2>&1 \
  || die "building pliant in $build failed: $out/build-new.log"
new_bin="$build/apps/pliant"
[[ -x "$new_bin" ]] || die "no $new_bin after the build"

# ---- the old commit ----
src="$baseline/src"
if [[ "$(cat "$src/.pliant-commit" 2>/dev/null)" != "$full" ]]; then
  [[ ! -e "$src" ]] || die "$src is not an export of $full (another commit): remove $baseline or give --baseline-dir"
  log "exporting $short into $src"
  rm -rf "$src.partial" && mkdir -p "$src.partial"  # an interrupted export is never taken for a complete one
  git archive "$full" | tar -x -C "$src.partial"
  echo "$full" >"$src.partial/.pliant-commit"
  mv "$src.partial" "$src"
fi
# pliant_perf (which `pliant bench` needs) was under PLIANT_BUILD_PERF in older trees.
perf_flag=()
if grep -A2 'if(PLIANT_BUILD_PERF)' "$src/CMakeLists.txt" | grep -q 'add_subdirectory(perf)'; then
  perf_flag=(-DPLIANT_BUILD_PERF=ON)
fi
bbuild="$baseline/build"
# Configured on every call, with the current build's settings: a build kept from an earlier call
# then still differs from the current one by its source only (a no-op when nothing changed).
log "configuring $short in $bbuild with the current build's settings"
settings=(-G "$(cache_value "$build" CMAKE_GENERATOR)" -DCMAKE_BUILD_TYPE=Release -DPLIANT_BUILD_TESTS=OFF
          "-DCMAKE_CXX_COMPILER=$(cache_value "$build" CMAKE_CXX_COMPILER)"
          "-DCMAKE_CXX_FLAGS=$(cache_value "$build" CMAKE_CXX_FLAGS)"
          "-DCMAKE_CXX_FLAGS_RELEASE=$(cache_value "$build" CMAKE_CXX_FLAGS_RELEASE)")
for var in PLIANT_NATIVE PLIANT_WITH_CGAL CMAKE_CXX_COMPILER_LAUNCHER; do
  value=$(cache_value "$build" $var)
  [[ -z "$value" ]] || settings+=("-D$var=$value")
done
cmake -S "$src" -B "$bbuild" "${settings[@]}" "${perf_flag[@]}" >"$out/configure-old.log" 2>&1 \
  || die "configuring $short in $bbuild failed: $out/configure-old.log"
log "building $short's pliant in $bbuild"
cmake --build "$bbuild" -j"$jobs" --target pliant >"$out/build-old.log" 2>&1 \
  || die "building $short's pliant failed: $out/build-old.log"
old_bin="$bbuild/apps/pliant"
[[ -x "$old_bin" ]] || die "no $old_bin after the build"

# ---- alternating runs ----
bench_args=()
[[ $quick == 1 ]] && bench_args+=(--quick)
[[ -n "$max_wait" ]] && bench_args+=(--max-wait "$max_wait")
printf 'run\tversion\tcommit\tstart_utc\tend_utc\tloadavg_before\tloadavg_after\n' >"$out/runs.tsv"
loadavg() { cut -d' ' -f1-3 /proc/loadavg; }
for ((i = 1; i <= runs; ++i)); do
  for version in old new; do
    if [[ $version == old ]]; then bin=$old_bin; scenes="$src/scenes"; rev=$short
    else bin=$new_bin; scenes="$root/scenes"; rev=$head; fi
    csv="$out/$version-run$i.csv"
    log "run $i/$runs, $version ($rev): $bin bench ${bench_args[*]}"
    before=$(loadavg); start=$(date -u +%H:%M:%S)
    "$bin" bench --csv "$csv" --scenes "$scenes" "${bench_args[@]}" >"$out/$version-run$i.txt" 2>"$out/$version-run$i.log" \
      || die "run $i of $version failed: $out/$version-run$i.log"
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$i" "$version" "$rev" "$start" "$(date -u +%H:%M:%S)" "$before" "$(loadavg)" \
      >>"$out/runs.tsv"
  done
done

# ---- the table ----
scene_flags=()
for scene in default cantilever; do
  if ! git diff --quiet "$full" -- "scenes/$scene.json"; then  # that commit against the working tree
    scene_flags+=(--scene-differs "$scene")
  fi
done
cpu=$(lscpu | sed -n 's/^Model name: *//p' | head -n 1)
set_name=$([[ $quick == 1 ]] && echo "quick set (--quick)" || echo "full set")
old_csvs=(); new_csvs=()  # in run order: the comparison pairs old run i with new run i
for ((i = 1; i <= runs; ++i)); do old_csvs+=("$out/old-run$i.csv"); new_csvs+=("$out/new-run$i.csv"); done
python3 "$root/perf/compare_bench.py" \
  --old "${old_csvs[@]}" --new "${new_csvs[@]}" \
  --old-label "$short" --new-label "$head" \
  --machine "${cpu:-unknown} ($(nproc) logical CPUs available)" \
  --date "$(date -u '+%Y-%m-%d %H:%M UTC')" \
  --set "$set_name, $runs run(s) of each, alternating (old first)" \
  --runs-log "$out/runs.tsv" "${scene_flags[@]}" >"$out/comparison.md"
log "wrote $out/comparison.md"
cat "$out/comparison.md"
