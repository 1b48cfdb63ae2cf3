// The canary of scripts/sanitize.sh tsan: a deliberate race through pliant's Executor (every chunk
// adds to one double), which TSan must still report with tests/tsan-suppressions.txt and the
// fork/join annotations of scheduler/src/executor.cpp; the disjoint writes and the read after the
// join must not be reported. Proves the suppressions do not hide a race in a loop body.
#include <cstdio>
#include <vector>
#include "pliant/scheduler/executor.hpp"
int main() {
  pliant::Executor ex(2);
  std::vector<double> out(100000, 0.0);
  double shared = 0;
  for (int rep = 0; rep < 20; ++rep)
    ex.parallel_for(out.size(), 1000, [&](pliant::Range r) {
      for (std::size_t i = r.begin; i < r.end; ++i) out[i] += 1.0;   // disjoint: fine
      shared += 1.0;                                                  // every chunk: a race
    });
  double sum = 0;
  for (double v : out) sum += v;   // after the join: fine
  std::printf("%g %g\n", sum, shared);
}
