#!/usr/bin/env bash
# Fuzz every reader of user input for SECONDS each (issue 10 §3; docs/reliability.md).
#
#   scripts/fuzz.sh SECONDS [HARNESS...]     e.g. scripts/fuzz.sh 300, scripts/fuzz.sh 60 vtu scene
#
# Builds the libFuzzer harnesses of tests/fuzz/ (clang++-14, -DPLIANT_FUZZ=ON: ASan + UBSan +
# coverage in every library; CGAL, pictures, tests and benchmarks off) in build-fuzz/, seeds each
# corpus from tests/data/mesh, the small meshes of data/meshes and scenes/ (tests/fuzz/make_seeds.py),
# then runs the harnesses one after the other under `nice -n 10`. Harnesses: gmsh (v1, v2, v4),
# vtk (legacy, and XML misnamed .vtk), vtu (ascii, base64, zlib), tetgen (.node/.ele), obj (skins),
# scene (parse_scene), overrides (--sweep and overrides, then parse_scene).
#
# Out: build-fuzz/fuzz/<harness>.log (libFuzzer's output with -print_final_stats), the grown
# corpus in build-fuzz/fuzz/corpus/<harness>/, and anything found in build-fuzz/fuzz/crashes/
# (crash-*, leak-*, timeout-*, oom-*; replay one with build-fuzz/tests/fuzz/fuzz_<harness> FILE).
# A summary line per harness: executions, executions per second, and findings. Exit status 1 when
# any harness found something. FUZZ_CXX overrides the compiler; FUZZ_TIMEOUT (s, default 10) is
# the time one input may take before it counts as a hang.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:?usage: scripts/fuzz.sh SECONDS [HARNESS...]}
shift
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(gmsh vtk vtu tetgen obj scene overrides)
cxx=${FUZZ_CXX:-clang++-14}
timeout_s=${FUZZ_TIMEOUT:-10}
build=build-fuzz
out=$build/fuzz

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
nice -n 10 cmake -S . -B $build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER="$cxx" \
  "${launcher[@]}" -DPLIANT_FUZZ=ON -DPLIANT_WITH_CGAL=OFF -DPLIANT_WITH_RASTER=OFF \
  -DPLIANT_BUILD_TESTS=OFF -DPLIANT_BUILD_PERF=OFF -DPLIANT_INSTALL=OFF >/dev/null
nice -n 10 cmake --build $build -j2 --target "${harnesses[@]/#/fuzz_}"

rm -rf $out/seeds
python3 tests/fuzz/make_seeds.py . $out/seeds
mkdir -p $out/crashes
found=0
for h in "${harnesses[@]}"; do
  mkdir -p $out/corpus/$h
  # The grown corpus (first directory) keeps what earlier runs found; the seeds are read only.
  set +e
  nice -n 10 $build/tests/fuzz/fuzz_$h $out/corpus/$h $out/seeds/$h \
    -max_total_time="$seconds" -timeout="$timeout_s" -rss_limit_mb=2048 -malloc_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix=$out/crashes/$h- >$out/$h.log 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' $out/$h.log | tail -1)
  speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' $out/$h.log | tail -1)
  cov=$(grep -o 'cov: [0-9]*' $out/$h.log | tail -1 || true)
  artifacts=$(grep -c 'Test unit written to' $out/$h.log || true)
  printf '%-10s %12s executions %8s/s  %s  exit %d  findings %s\n' "$h" "${execs:-?}" "${speed:-?}" "$cov" "$rc" "$artifacts"
  if [ "$rc" -ne 0 ] || [ "$artifacts" != 0 ]; then
    found=1
    grep -m3 -E 'ERROR|runtime error|terminate|SUMMARY' $out/$h.log || true
  fi
done
exit $found
