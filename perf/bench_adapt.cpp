// The cost of adaptivity (docs/multiresolution.md, "Adaptivity"): wall time to apply one change
// (every node of a level split, or merged back) of an adaptive two-level body, on the organ
// (implicit shape, 3 863 fine tets; needs CGAL) and on a bar of about 100k fine tets (Kuhn box).
// Manual time: only the re-activation and the state transfer are timed (World::adapt_stats), not
// the steps between. Run: build/perf/bench_adapt.
#include <benchmark/benchmark.h>

#include "pliant/world.hpp"

namespace pliant {
namespace {

BodyDef bar100k() {
  BodyDef b;
  b.name = "bar";
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {1.0, 0.1, 0.1};
  b.mesh.cells = {128, 12, 11};  // 16 896 cells x 6 = 101 376 tets
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e6;
  b.multiresolution.levels = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  return b;
}

BodyDef organ() {
  BodyDef b;
  b.name = "organ";
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.01;
  b.material.young = 2e4;
  b.material.poisson = 0.45;
  b.multiresolution.levels = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  return b;
}

void run(benchmark::State& state, const BodyDef& def) {
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  wd.threads = 1;
  World w(wd);
  BodyDef b = def;
  b.multiresolution.active.adapt.refine_above = 1e9;  // only forced changes
  b.multiresolution.active.adapt.coarsen_below = 0;
  w.add_body(b);
  int level = 1;
  std::int64_t nodes = 0;
  for (auto _ : state) {
    const World::AdaptStats before = w.adapt_stats(0);
    w.force_level(0, level);
    while (w.adapt_stats(0).changes == before.changes) w.step();
    const World::AdaptStats after = w.adapt_stats(0);
    state.SetIterationTime(after.apply_seconds - before.apply_seconds);
    nodes += (after.splits - before.splits) + (after.merges - before.merges);
    level = 1 - level;
  }
  state.counters["fine_tets"] = double(w.tet_count(0, 1));
  state.counters["nodes_per_change"] = double(nodes) / double(state.iterations());
}

void BM_AdaptChangeBar100k(benchmark::State& state) { run(state, bar100k()); }
void BM_AdaptChangeOrgan(benchmark::State& state) { run(state, organ()); }
BENCHMARK(BM_AdaptChangeBar100k)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK(BM_AdaptChangeOrgan)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(40);

}  // namespace
}  // namespace pliant

BENCHMARK_MAIN();
