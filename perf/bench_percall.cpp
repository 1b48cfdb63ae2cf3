// Per-call times of the corotational element pass and of the whole step (World::step) on the
// benchmark boxes of about 10k and 100k tets, float and double, 1..N threads: the minimum, the
// 10th percentile and the median of the calls, in ns per tet, one CSV line per case:
//   size,precision,threads,pass,min,p10,median,calls
// For comparing builds on a shared machine (docs/performance.md, issue 15): a call that the
// scheduler did not interrupt runs at full speed, so the minimum and low percentiles of many
// short calls move much less with other processes' load than a mean or a median does. Run two
// builds alternately, several times, and compare like with like.
//   bench_percall [seconds per case = 0.8] [max threads = 2] [only = e.g. 10kf, 100kd]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pliant/perf/workload.hpp"

namespace {
using namespace pliant;
using namespace pliant::perf;

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::size_t(p * double(v.size() - 1))];
}

void print(const char* size, Precision p, int threads, const char* pass, const std::vector<double>& s, double tets) {
  const double k = 1e9 / tets;  // s per call -> ns per tet
  std::printf("%s,%s,%d,%s,%.3f,%.3f,%.3f,%zu\n", size, p == Precision::float32 ? "float" : "double", threads, pass,
              percentile(s, 0) * k, percentile(s, 0.1) * k, percentile(s, 0.5) * k, s.size());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 0.8;
  const int max_threads = argc > 2 ? std::atoi(argv[2]) : 2;
  const std::string only = argc > 3 ? argv[3] : "";
  if (!(seconds > 0) || max_threads < 1 ||
      !(only.empty() || only == "10kf" || only == "10kd" || only == "100kf" || only == "100kd")) {
    std::fprintf(stderr, "usage: bench_percall [seconds per case > 0] [max threads >= 1] [only: 10kf|10kd|100kf|100kd]\n");
    return 2;
  }
  for (int si : {1, 2})  // standard_sizes(): 10k, 100k
    for (Precision p : {Precision::float32, Precision::float64})
      for (int threads = 1; threads <= max_threads; ++threads) {
        const BoxSize& sz = standard_sizes()[std::size_t(si)];
        if (!only.empty() && only != std::string(sz.label) + (p == Precision::float32 ? "f" : "d")) continue;
        World w = make_box_world(ForceModel::corotational, p, threads, sz.cells, Order::grid);
        Executor exec(threads);
        TimingOptions o;
        o.min_seconds = seconds;
        o.min_samples = 50;
        o.warmup = 5;
        const PartTimes parts = time_step_parts(w, exec, o);
        const std::vector<double> steps = time_calls([&] { w.step(); }, o);
        const double tets = double(w.tet_count(0));
        print(sz.label, p, threads, "element", parts.element, tets);
        print(sz.label, p, threads, "step", steps, tets);
      }
  return 0;
}
