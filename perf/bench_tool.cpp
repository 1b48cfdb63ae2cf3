// The cost of the tool (docs/tool.md): Embree refit of a body surface, the contact query
// (BVH ball query + exact tests), against surface size (about 5k, 50k, 500k triangles: the top
// of thin slabs of (N, N, 1) cells), and the whole step of a 2k-tet body with and without a tool
// pressing into it. Run: build/perf/bench_tool [--benchmark_filter=...].
#include <benchmark/benchmark.h>

#include <cmath>

#include "../engine/src/collision/tool_contact.hpp"
#include "pliant/scheduler/executor.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

// A slab of N x N x 1 cells of 1 cm, 5 tets per cell: about 4 N^2 boundary triangles.
BodyDef slab(int n) {
  BodyDef b;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.01 * n, 0.01 * n, 0.01};
  b.mesh.cells = {n, n, 1};
  b.mesh.tets_per_cell = 5;
  b.material.young = 1e5;
  return b;
}

int cells_for(std::int64_t triangles) { return int(std::lround(std::sqrt(double(triangles) / 4.0))); }

struct Fixture {
  World world;
  Executor exec;
  detail::EmbreeDevice device;
  detail::LevelContact<double> lc;
  ToolShapeDef shape;
  ToolPose pose;
  explicit Fixture(int n, int threads) : world(make_def(threads)), exec(threads) {
    world.add_body(slab(n));
    lc = detail::make_level_contact(device, world.level<double>(0), 0, 0, exec, ToolPose{});
    shape.radius = 0.012;
    // On the slab's top, in the middle (world frame).
    pose.position = {0.005 * n, 0.005 * n, 0.01 + 0.006};
  }
  static WorldDef make_def(int threads) {
    WorldDef d;
    d.threads = threads;
    return d;
  }
};

void BM_Refit(benchmark::State& state) {
  Fixture f(cells_for(state.range(0)), int(state.range(1)));
  std::string error;
  for (auto _ : state) {
    if (!f.lc.bvh->refit(f.exec, error)) state.SkipWithError(error.c_str());
  }
  state.counters["triangles"] = double(f.lc.triangles.size());
  state.counters["ns_per_triangle"] =
      benchmark::Counter(double(f.lc.triangles.size()), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// The contact query of a step when no vertex left the margin (the common case: a refit every few
// hundred steps): the displacement check over the surface, the ball query and the exact tests.
void BM_CheckAndQuery(benchmark::State& state) {
  Fixture f(cells_for(state.range(0)), int(state.range(1)));
  std::string error;
  const Vec3d origin = f.world.body_origin(0);
  for (auto _ : state) {
    if (!detail::find_tool_contacts(f.lc, f.world.level<double>(0), f.shape, f.pose, f.pose, origin, f.exec, error))
      state.SkipWithError(error.c_str());
    benchmark::DoNotOptimize(f.lc.hits.data());
  }
  state.counters["triangles"] = double(f.lc.triangles.size());
  state.counters["contacts"] = double(f.lc.hits.size());
}

// The step of a 2k-tet body (the default scene's size) with a sphere held 6 mm into it, against
// the same body without a tool; both sag under 20 g, so that the elements' rotations cost the same.
void BM_StepWithTool(benchmark::State& state) {
  WorldDef d;
  d.threads = int(state.range(1));
  d.gravity = {0, 0, -9.81 * 20};  // both bodies deformed alike (rotations away from identity cost Newton steps)
  World w(d);
  BodyDef b = slab(0);
  b.mesh.max = {0.1, 0.1, 0.05};
  b.mesh.cells = {8, 8, 6};  // 384 cells x 6 = 2304 tets
  b.mesh.tets_per_cell = 6;
  RegionDef base;
  base.min = {-1, -1, -1e-9};
  base.max = {1, 1, 1e-9};
  b.fixed.push_back(base);
  w.add_body(b);
  if (state.range(0)) {
    ToolDef t;
    t.shape.radius = 0.01;
    t.keyframes = {{0.0, {0.05, 0.05, 0.061}}, {0.05, {0.05, 0.05, 0.054}}};
    w.add_tool(t);
  }
  for (int i = 0; i < 200; ++i) w.step();  // into contact
  for (auto _ : state) w.step();
  state.counters["tets"] = double(w.tet_count(0));
  if (state.range(0)) {
    const ToolReading r = w.tool_reading(0);
    state.counters["contacts"] = double(r.contacts);
    state.counters["refits_per_query"] = double(r.refits) / double(r.queries);
  }
}

BENCHMARK(BM_Refit)->ArgsProduct({{5000, 50000, 500000}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CheckAndQuery)->ArgsProduct({{5000, 50000, 500000}, {1, 2}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StepWithTool)->ArgsProduct({{0, 1}, {1, 2}})->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace pliant

BENCHMARK_MAIN();
