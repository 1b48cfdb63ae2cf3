// Google Benchmark programs for the passes of a step against the machine's limits, in one run:
//   machine/triad/...     STREAM-like triad at working sets from L2 to DRAM, on 1 and 2 threads
//   machine/peak_*/...    peak FMA (and multiply + add) rate
//   element/<model>/...   every force model's element pass
//   gather/, integrate/, gather_integrate/   the node passes (separate and fused)
//   step/corotational/... a whole World::step
//   order/...             1M tets in grid, random and renumbered memory order
// on box meshes of about 1k, 10k, 100k and 1M tets, float and double, 1 and 2 threads.
// Counters: ns_per_tet, Mtet_per_s, bytes_per_tet and GB_per_s (compulsory traffic, see
// docs/performance.md), GFLOP_per_s, footprint_MiB, and roofline = (the lower of triad
// bandwidth at that working set / bytes and peak / flops) / measured speed.
// The machine benchmarks run first and feed the roofline of the later ones. Run e.g.
//   ./perf/bench_kernels --benchmark_counters_tabular=true --benchmark_filter='machine|100k'
// Each kernel iteration runs a whole step (so the state evolves as in a simulation) and times
// only the pass named by the benchmark.
#include <benchmark/benchmark.h>

#include <chrono>
#include <initializer_list>
#include <utility>
#include <map>
#include <memory>
#include <string>

#include "pliant/perf/machine.hpp"
#include "pliant/perf/workload.hpp"

namespace {
using namespace pliant;
using namespace pliant::perf;
using Clock = std::chrono::steady_clock;

MachineLimits g_limits;

// Every benchmark reports the same counters (the CSV reporter needs one column set); those
// that do not apply are 0.
void counters(benchmark::State& st, std::initializer_list<std::pair<const char*, double>> values) {
  for (const char* name : {"tets", "threads", "ns_per_tet", "Mtet_per_s", "bytes_per_tet", "GB_per_s", "GFLOP_per_s",
                           "footprint_MiB", "roof_GB_per_s", "roofline"})
    st.counters[name] = 0;
  for (const auto& [name, v] : values) st.counters[name] = v;
}

const MachineLimits& limits() {
  bool have_triad = false, have_peak = false;
  for (const auto& t : g_limits.triad) have_triad |= t.threads > 0;
  for (const auto& p : g_limits.peak) have_peak |= p.fma;
  if (!have_triad || !have_peak) {  // machine benchmarks filtered out: a short ladder now
    LimitOptions o;
    o.footprints_mib = {1, 24, 256};
    o.samples = 3;
    const MachineLimits m = measure_machine_limits(o);
    if (!have_triad) g_limits.triad = m.triad;
    if (!have_peak) g_limits.peak = m.peak;
  }
  return g_limits;
}

void machine_triad(benchmark::State& st, double mib, int threads) {
  double best = 0;
  for (auto _ : st) best = std::max(best, measure_triad(std::size_t(mib * 1024 * 1024), threads, 1, 0.02));
  counters(st, {{"GB_per_s", best}, {"footprint_MiB", mib}, {"threads", threads}});
  g_limits.triad.push_back({mib * 1024 * 1024, threads, best});
}

void machine_peak(benchmark::State& st, bool is_double, bool fma, int threads) {
  PeakPoint best;
  for (auto _ : st) {
    const PeakPoint p = measure_peak(is_double, threads, fma, 0.05);
    if (p.gflop_per_s > best.gflop_per_s) best = p;
  }
  counters(st, {{"GFLOP_per_s", best.gflop_per_s}, {"threads", threads}});
  st.SetLabel(best.isa);
  g_limits.peak.push_back(best);
}

// One world at a time (a 1M-tet double world is about half a gigabyte).
struct WorldKey {
  ForceModel model;
  Precision precision;
  std::string size;
  Order order;
  int threads;
  bool operator==(const WorldKey& o) const {
    return model == o.model && precision == o.precision && size == o.size && order == o.order && threads == o.threads;
  }
};
std::unique_ptr<World> g_world;
std::unique_ptr<WorldKey> g_key;

World& world(const WorldKey& key, const std::array<int, 3>& cells) {
  if (!g_key || !(*g_key == key)) {
    g_world.reset();
    g_world = std::make_unique<World>(make_box_world(key.model, key.precision, key.threads, cells, key.order));
    g_key = std::make_unique<WorldKey>(key);
  }
  return *g_world;
}

Executor& executor(int threads) {
  static std::map<int, std::unique_ptr<Executor>> pool;
  auto& e = pool[threads];
  if (!e) e = std::make_unique<Executor>(threads);
  return *e;
}

void set_counters(benchmark::State& st, const World& w, Pass pass, int threads, double seconds) {
  const double calls = double(st.iterations());
  const double tets = double(w.tet_count(0));
  const double per_call = seconds / calls;
  const PassCost c = pass_cost(w, 0, pass);
  const MachineLimits& m = limits();
  const bool is_double = w.precision() == Precision::float64;
  const double bw = m.bandwidth(c.footprint, threads), peak = m.peak_gflops(is_double, threads);
  const double roof = std::max(c.bytes / (bw * 1e9), c.flops / (peak * 1e9));
  counters(st, {{"tets", tets},
                {"threads", threads},
                {"ns_per_tet", per_call / tets * 1e9},
                {"Mtet_per_s", tets / per_call * 1e-6},
                {"bytes_per_tet", c.bytes / tets},
                {"GB_per_s", c.bytes / per_call * 1e-9},
                {"GFLOP_per_s", c.flops / per_call * 1e-9},
                {"footprint_MiB", c.footprint / (1024.0 * 1024.0)},
                {"roof_GB_per_s", bw},
                {"roofline", roof / per_call}});
}

void pass_bench(benchmark::State& st, WorldKey key, std::array<int, 3> cells, Pass pass, int threads) {
  World& w = world(key, cells);
  StepRunner run(w, executor(threads));
  double total = 0;
  auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
  for (auto _ : st) {
    // A whole step; only `pass` is timed.
    double timed = 0;
    auto t0 = Clock::now();
    run.element();
    auto t1 = Clock::now();
    if (pass == Pass::element) timed = seconds(t0, t1);
    if (pass == Pass::gather_integrate) {
      run.gather_integrate();
      timed = seconds(t1, Clock::now());
    } else {
      run.gather();
      const auto t2 = Clock::now();
      run.integrate();
      const auto t3 = Clock::now();
      if (pass == Pass::gather) timed = seconds(t1, t2);
      if (pass == Pass::integrate) timed = seconds(t2, t3);
    }
    st.SetIterationTime(timed);
    total += timed;
  }
  set_counters(st, w, pass, threads, total);
}

void step_bench(benchmark::State& st, WorldKey key, std::array<int, 3> cells) {
  World& w = world(key, cells);
  double total = 0;
  for (auto _ : st) {
    const auto t0 = Clock::now();
    w.step();
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    st.SetIterationTime(s);
    total += s;
  }
  set_counters(st, w, Pass::step, key.threads, total);
}

void register_all() {
  for (int threads : {1, 2}) {
    for (double mib : {0.5, 1.0, 4.0, 24.0, 96.0, 512.0})
      benchmark::RegisterBenchmark(("machine/triad/" + std::to_string(int(mib * 1024)) + "KiB/threads:" +
                                    std::to_string(threads)).c_str(),
                                   machine_triad, mib, threads)
          ->Iterations(5)
          ->Unit(benchmark::kMillisecond);
    for (bool is_double : {false, true})
      for (bool fma : {true, false})
        benchmark::RegisterBenchmark((std::string("machine/") + (fma ? "peak_fma/" : "peak_mul_add/") +
                                      (is_double ? "double" : "float") + "/threads:" + std::to_string(threads))
                                         .c_str(),
                                     machine_peak, is_double, fma, threads)
            ->Iterations(3)
            ->Unit(benchmark::kMillisecond);
  }
  for (const auto& sz : standard_sizes())
    for (Precision p : {Precision::float32, Precision::float64}) {
      for (ForceModel m : {ForceModel::linear, ForceModel::stvk, ForceModel::springs, ForceModel::corotational}) {
        const WorldKey key{m, p, sz.label, Order::grid, 1};
        std::vector<Pass> passes{Pass::element};
        if (m == ForceModel::corotational)
          passes = {Pass::element, Pass::gather, Pass::integrate, Pass::gather_integrate};
        for (Pass pass : passes)
          for (int threads : {1, 2})
            benchmark::RegisterBenchmark((std::string(to_string(pass)) + "/" + to_string(m) + "/" + to_string(p) + "/" +
                                          sz.label + "/threads:" + std::to_string(threads))
                                             .c_str(),
                                         pass_bench, key, sz.cells, pass, threads)
                ->UseManualTime()
                ->Unit(benchmark::kMicrosecond);
      }
      for (int threads : {1, 2})
        benchmark::RegisterBenchmark((std::string("step/corotational/") + to_string(p) + "/" + sz.label +
                                      "/threads:" + std::to_string(threads))
                                         .c_str(),
                                     step_bench, WorldKey{ForceModel::corotational, p, sz.label, Order::grid, threads},
                                     sz.cells)
            ->UseManualTime()
            ->Unit(benchmark::kMicrosecond);
    }
  const BoxSize& big = standard_sizes().back();
  for (ForceModel m : {ForceModel::linear, ForceModel::corotational})
    for (Order order : {Order::grid, Order::random, Order::renumbered}) {
      const WorldKey key{m, Precision::float32, big.label, order, 1};
      for (Pass pass : {Pass::element, Pass::gather_integrate})
        benchmark::RegisterBenchmark((std::string("order/") + to_string(pass) + "/" + to_string(m) + "/float/" +
                                      big.label + "/" + to_string(order) + "/threads:1")
                                         .c_str(),
                                     pass_bench, key, big.cells, pass, 1)
            ->UseManualTime()
            ->Unit(benchmark::kMicrosecond);
      if (m == ForceModel::corotational)
        benchmark::RegisterBenchmark(
            (std::string("order/step/corotational/float/") + big.label + "/" + to_string(order) + "/threads:1").c_str(),
            step_bench, key, big.cells)
            ->UseManualTime()
            ->Unit(benchmark::kMicrosecond);
    }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("machine", machine_description());
  benchmark::AddCustomContext("build", build_description());
  register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
