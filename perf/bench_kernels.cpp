// Speed of the element passes (per model), the gather, the integrator and a whole step, on box
// meshes of about 1k, 10k and 100k tets, in float and double, on 1 and 2 threads.
// Counters: ns per tet (or node) and millions of tets per second. Run:
//   ./build/perf/bench_kernels --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/world.hpp"

namespace {
using namespace pliant;

// cells n x n/4 x n/4 x 6 tets: n = 12 -> 1.3k, 26 -> 10k, 56 -> 110k tets.
World make_world(ForceModel model, Precision precision, int threads, int n) {
  WorldDef wd;
  wd.precision = precision;
  wd.threads = threads;
  World w(wd);
  BodyDef b;
  b.name = "box";
  b.model = model;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {1, 0.25, 0.25};
  b.mesh.cells = {n, n / 4, n / 4};
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-6, 1, 1};
  b.fixed.push_back(clamp);
  w.add_body(b);
  for (int i = 0; i < 20; ++i) w.step();  // deformed state: rotations are not identity
  return w;
}

template <class T>
void element_pass(benchmark::State& state, ForceModel model) {
  const Precision p = sizeof(T) == 4 ? Precision::float32 : Precision::float64;
  World w = make_world(model, p, 1, int(state.range(0)));
  Level<T>& L = w.level<T>(0);
  ElementContext<T> c;
  for (int k = 0; k < 3; ++k) {
    c.X[k] = L.X[k].data();
    c.x[k] = L.x[k].data();
    c.v[k] = L.v[k].data();
  }
  for (int a = 0; a < 4; ++a) c.tet[a] = L.tet[a].data();
  c.volume = L.volume.data();
  for (int q = 0; q < 9; ++q) c.grad[q] = L.grad[q].data();
  if (!L.rotation[0].empty())
    for (int k = 0; k < 4; ++k) c.rotation[k] = L.rotation[k].data();
  c.lambda = L.lambda;
  c.mu = L.mu;
  c.young = L.young;
  for (int q = 0; q < 12; ++q) c.corner_force[q] = L.corner_force[q].data();
  const Range r{0, L.tet_count};
  for (auto _ : state) {
    switch (model) {
      case ForceModel::linear: element_forces_linear(c, r); break;
      case ForceModel::stvk: element_forces_stvk(c, r); break;
      case ForceModel::corotational: element_forces_corotational(c, r); break;
      case ForceModel::springs: element_forces_springs(c, r); break;
    }
    benchmark::DoNotOptimize(L.corner_force[0].data());
    benchmark::ClobberMemory();
  }
  const double tets = double(L.tet_count) * double(state.iterations());
  state.counters["tets"] = double(L.tet_count);
  state.counters["ns_per_tet"] = benchmark::Counter(tets * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["Mtet_per_s"] = benchmark::Counter(tets * 1e-6, benchmark::Counter::kIsRate);
}

template <class T>
void whole_step(benchmark::State& state) {
  const Precision p = sizeof(T) == 4 ? Precision::float32 : Precision::float64;
  World w = make_world(ForceModel::corotational, p, int(state.range(1)), int(state.range(0)));
  for (auto _ : state) w.step();
  const double tets = double(w.tet_count(0)) * double(state.iterations());
  state.counters["tets"] = double(w.tet_count(0));
  state.counters["threads"] = double(state.range(1));
  state.counters["ns_per_tet"] = benchmark::Counter(tets * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["Mtet_per_s"] = benchmark::Counter(tets * 1e-6, benchmark::Counter::kIsRate);
}

void sizes(benchmark::internal::Benchmark* b) { b->Arg(12)->Arg(26)->Arg(56)->UseRealTime(); }
void step_sizes(benchmark::internal::Benchmark* b) {
  for (int n : {12, 26, 56})
    for (int t : {1, 2}) b->Args({n, t});
  b->UseRealTime();
}

void element_pass_f32(benchmark::State& s, ForceModel m) { element_pass<float>(s, m); }
void element_pass_f64(benchmark::State& s, ForceModel m) { element_pass<double>(s, m); }

BENCHMARK_CAPTURE(element_pass_f32, linear, ForceModel::linear)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f64, linear, ForceModel::linear)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f32, stvk, ForceModel::stvk)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f64, stvk, ForceModel::stvk)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f32, corotational, ForceModel::corotational)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f64, corotational, ForceModel::corotational)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f32, springs, ForceModel::springs)->Apply(sizes);
BENCHMARK_CAPTURE(element_pass_f64, springs, ForceModel::springs)->Apply(sizes);
BENCHMARK_TEMPLATE(whole_step, float)->Apply(step_sizes);
BENCHMARK_TEMPLATE(whole_step, double)->Apply(step_sizes);

}  // namespace

BENCHMARK_MAIN();
