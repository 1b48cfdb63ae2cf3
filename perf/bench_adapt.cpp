// The cost of adaptivity (docs/multiresolution.md, "Adaptivity"): wall time to apply one change
// (every node of a level split, or merged back) of an adaptive two-level body, on the organ
// (implicit shape, 3 863 fine tets; needs CGAL) and on a bar of about 100k fine tets (Kuhn box).
// Manual time: only the re-activation and the state transfer are timed (World::adapt_stats), not
// the steps between. Every node of the level changes there: the work is the body's by design.
// BM_Local*: one coarse node split and merged back on the same bodies (the activation and the
// level arrays only, no steps), applied in place (apply_changes, what adapt_body does) and, in the
// same run, as adapt_body did before: the full apply_activation from a snapshot plus its body-wide
// loops (the states and masses copied, the momentum summed twice, every unstepped tet's corner
// forces cleared). Run: build/perf/bench_adapt.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>

#include "../engine/src/core/simulation.hpp"
#include "../engine/src/multires/activation.hpp"
#include "../engine/src/multires/adaptivity.hpp"
#include "../engine/src/multires/apply_changes.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/scheduler/executor.hpp"
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
  std::int64_t nodes = 0, touched = 0;
  for (auto _ : state) {
    const World::AdaptStats before = w.adapt_stats(0);
    w.force_level(0, level);
    while (w.adapt_stats(0).changes == before.changes) w.step();
    const World::AdaptStats after = w.adapt_stats(0);
    state.SetIterationTime(after.apply_seconds - before.apply_seconds);
    nodes += (after.splits - before.splits) + (after.merges - before.merges);
    touched += after.touched_nodes - before.touched_nodes;
    level = 1 - level;
  }
  state.counters["fine_tets"] = double(w.tet_count(0, 1));
  state.counters["nodes_per_change"] = double(nodes) / double(state.iterations());
  state.counters["nodes_touched"] = double(touched) / double(state.iterations());  // by the apply (PatchStats)
}

// adapt_body's part 3 before apply_changes: the whole snapshot applied, and the loops over every
// node and tet that came with it (the carry-over itself only did work on the changed nodes).
void full_apply(detail::SimBody<double>& body, const Hierarchy& h, const detail::ActivationState& as) {
  const std::size_t n = h.levels();
  std::vector<std::vector<std::uint8_t>> old_state(n);
  std::vector<std::vector<double>> old_mass(n);
  double p[3] = {0, 0, 0};
  for (std::size_t l = 0; l < n; ++l) {
    const Level<double>& L = body.levels[l];
    old_state[l].assign(L.state.begin(), L.state.end());
    old_mass[l].assign(L.mass.begin(), L.mass.end());
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] == kNodeFree)
        for (int k = 0; k < 3; ++k) p[k] += L.mass[i] * L.v[k][i];
  }
  std::vector<const TetMesh*> meshes;
  for (const TetMesh& m : h.meshes) meshes.push_back(&m);
  detail::apply_activation(body, as.snapshot(), h, meshes, 0.0);
  for (std::size_t l = 0; l < n; ++l) {
    Level<double>& L = body.levels[l];
    const std::vector<std::uint8_t>& on = as.stepped_mask(int(l));
    for (std::size_t e = 0; e < L.tet_count; ++e)
      if (!on[e])
        for (auto& c : L.corner_force) c[e] = 0;
  }
  double q[3] = {0, 0, 0}, m = 0;
  for (auto& L : body.levels)
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] == kNodeFree) {
        m += L.mass[i];
        for (int k = 0; k < 3; ++k) q[k] += L.mass[i] * L.v[k][i];
      }
  for (auto& L : body.levels)
    for (std::size_t i = 0; i < L.node_count; ++i)
      if (L.state[i] == kNodeFree)
        for (int k = 0; k < 3; ++k) L.v[k][i] += (p[k] - q[k]) / m;
  benchmark::DoNotOptimize(old_state.data());
}

// One coarse node (the nearest to the body's centre) split and merged back, again and again:
// µs per split and per merge, the activation's update() apart from the apply.
void run_local(benchmark::State& state, const BodyDef& def, bool in_place) {
  Executor exec(1);
  std::vector<std::int32_t> unused;
  TetMesh mesh = build_mesh(def.mesh);
  MeshLoadReport report;
  finalize_tet_mesh(mesh, "bench", report);
  const Hierarchy h = link_levels(build_level_meshes(def, std::move(mesh)));
  detail::SimBody<double> body = detail::build_multilevel_body<double>(h, def, 0.5, exec);
  detail::ActivationState as(h, detail::node_targets(h, def.multiresolution.active));
  detail::PatchState ps = detail::make_patch_state(body, h, as);
  const TetMesh& coarse = h.meshes[0];
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < coarse.node_count(); ++i)
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], coarse.point(i)[k]);
      hi[k] = std::max(hi[k], coarse.point(i)[k]);
    }
  std::int32_t node = 0;
  double best = 1e300;
  for (std::size_t i = 0; i < coarse.node_count(); ++i) {
    const Vec3d p = coarse.point(i);
    const double d = std::hypot(p[0] - 0.5 * (lo[0] + hi[0]), p[1] - 0.5 * (lo[1] + hi[1]), p[2] - 0.5 * (lo[2] + hi[2]));
    if (d < best) {
      best = d;
      node = std::int32_t(i);
    }
  }
  double seconds[2] = {0, 0}, update_seconds = 0;
  std::size_t changed = 0, touched = 0, body_nodes = 0;
  for (const auto& L : body.levels) body_nodes += L.node_count;
  for (auto _ : state) {
    double total = 0;
    for (int step = 0; step < 2; ++step) {  // split, merge
      const auto t0 = std::chrono::steady_clock::now();
      as.set_target(0, node, step == 0 ? 1 : 0);
      const detail::ActivationState::Changes ch = as.update();
      const auto t1 = std::chrono::steady_clock::now();
      if (in_place) {
        const detail::ChangeSet cs = detail::apply_changes(body, ps, as, ch, 0.0);
        detail::keep_momentum(body, cs);
        touched += cs.stats.nodes;
      } else {
        full_apply(body, h, as);
      }
      const auto t2 = std::chrono::steady_clock::now();
      for (const auto& c : ch.nodes) changed += c.size();
      seconds[step] += std::chrono::duration<double>(t2 - t0).count();
      update_seconds += std::chrono::duration<double>(t1 - t0).count();
      total += std::chrono::duration<double>(t2 - t0).count();
    }
    state.SetIterationTime(total / 2);
  }
  const double it = double(state.iterations());
  state.counters["split_us"] = 1e6 * seconds[0] / it;
  state.counters["merge_us"] = 1e6 * seconds[1] / it;
  state.counters["update_us"] = 1e6 * update_seconds / (2 * it);  // of which ActivationState::update
  state.counters["nodes_changed"] = double(changed) / (2 * it);
  state.counters["nodes_touched"] = double(touched) / (2 * it);
  state.counters["body_nodes"] = double(body_nodes);
  state.counters["renormalised"] = double(ps.renormalisations) / (2 * it);  // share of the changes (apply_changes.hpp)
}

void BM_AdaptChangeBar100k(benchmark::State& state) { run(state, bar100k()); }
void BM_AdaptChangeOrgan(benchmark::State& state) { run(state, organ()); }
BENCHMARK(BM_AdaptChangeBar100k)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK(BM_AdaptChangeOrgan)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(40);
void BM_LocalFullBar100k(benchmark::State& state) { run_local(state, bar100k(), false); }
void BM_LocalInPlaceBar100k(benchmark::State& state) { run_local(state, bar100k(), true); }
void BM_LocalFullOrgan(benchmark::State& state) { run_local(state, organ(), false); }
void BM_LocalInPlaceOrgan(benchmark::State& state) { run_local(state, organ(), true); }
BENCHMARK(BM_LocalFullBar100k)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(10);
BENCHMARK(BM_LocalInPlaceBar100k)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(200);
BENCHMARK(BM_LocalFullOrgan)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(100);
BENCHMARK(BM_LocalInPlaceOrgan)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(1000);

}  // namespace
}  // namespace pliant

BENCHMARK_MAIN();
