#!/usr/bin/env bash
# ThreadSanitizer run of the tool's threaded tests (docs/tool.md): the haptic link against a
# running simulation, and the tool's determinism across thread counts. Builds build-tsan/ with
# clang 14 (-fsanitize=thread, no CGAL, no benchmarks), then runs the two test programs with the
# suppressions of tests/tsan-suppressions.txt (uninstrumented Embree internals only).
# Usage: scripts/tsan-tool.sh   (about 5 minutes of building on 2 cores, 2 of running)
set -euo pipefail
cd "$(dirname "$0")/.."
CC=clang-14 CXX=clang++-14 cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLIANT_WITH_CGAL=OFF \
  -DPLIANT_BUILD_PERF=OFF -DPLIANT_NATIVE=OFF -DCMAKE_CXX_FLAGS=-fsanitize=thread -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread >/dev/null
cmake --build build-tsan --target test_haptic_link test_tool_response
export TSAN_OPTIONS="suppressions=$PWD/tests/tsan-suppressions.txt halt_on_error=1"
./build-tsan/tests/test_haptic_link
./build-tsan/tests/test_tool_response --gtest_filter='*SameBits*:*PressHold*'
echo "tsan-tool: clean"
