// Applying a change of an adaptive body in place (engine/src/multires/apply_changes.*): after
// every one of a sequence of random splits and merges, the patched level arrays equal what the full
// apply_activation gives from the activation's snapshot (on a copy of the body): stepped runs,
// states, ghost and receiver CSRs, impulse sizes, loads and prescribed nodes compared exactly,
// masses and inverse masses as the largest relative difference (rounding for nested levels; the
// slivers' share for non-nested ones, whose mass policy differs: apply_changes.hpp), the total
// against rho V; the patch's own masses and region counts against those made afresh. Along the way:
// the changes update() lists are exactly the tets whose state changed, the incremental activation
// equals one made from scratch with the same targets, and momentum is kept (every node moving) on
// the organ, which nothing holds (a held body gets no correction: keep_momentum).
// And the work of one change is local: the same on a bar twice as long.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <cstdio>
#include <array>
#include <random>
#include <string>
#include <vector>

#include "../../engine/src/core/simulation.hpp"
#include "../../engine/src/multires/activation.hpp"
#include "../../engine/src/multires/adaptivity.hpp"
#include "../../engine/src/multires/apply_changes.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/scheduler/executor.hpp"
#include "pliant/world.hpp"
#include "../support/adaptive_body.hpp"

namespace pliant::detail {
namespace {

// An adaptive box bar with a clamp at x = 0, a prescribed end at x = max, and a load on a slab in
// the middle: every kind of region, over nodes that change role.
BodyDef bar(std::array<int, 3> cells, int levels, double ratio) {
  BodyDef b;
  b.name = "bar";
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.1 * cells[0] / cells[1], 0.1, 0.1 * cells[2] / cells[1]};
  b.mesh.cells = cells;
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.density = 1000;
  b.multiresolution.levels = levels;
  b.multiresolution.ratio = ratio;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-9, 1, 1};
  b.fixed.push_back(clamp);
  PrescribedMotionDef end;
  end.region.min = {b.mesh.max[0] - 1e-9, -1, -1};
  end.region.max = {10, 10, 10};
  end.keyframes = {{0.0, {0, 0, 0}}, {1.0, {0, 0.01, 0}}};
  b.prescribed.push_back(end);
  NodalLoadDef load;
  load.region.min = {0.4 * b.mesh.max[0], -1, -1};
  load.region.max = {0.6 * b.mesh.max[0], 10, 10};
  load.total_force = {0, -2, 1};
  b.loads.push_back(load);
  return b;
}

using Adaptive = AdaptiveBody<double>;

template <class A, class B>
bool same(const A& a, const B& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin());
}

// Compares the patched body with the full apply's; returns the largest relative mass difference.
double compare(const SimBody<double>& got, const SimBody<double>& want, const std::string& where) {
  double worst = 0;
  for (std::size_t l = 0; l < got.levels.size(); ++l) {
    SCOPED_TRACE(where + ", level " + std::to_string(l));
    const Level<double>& G = got.levels[l];
    const Level<double>& W = want.levels[l];
    EXPECT_EQ(G.stepped_runs.size(), W.stepped_runs.size());
    for (std::size_t r = 0; r < std::min(G.stepped_runs.size(), W.stepped_runs.size()); ++r) {
      EXPECT_EQ(G.stepped_runs[r].begin, W.stepped_runs[r].begin) << r;
      EXPECT_EQ(G.stepped_runs[r].end, W.stepped_runs[r].end) << r;
    }
    EXPECT_EQ(G.stepped_count, W.stepped_count);
    EXPECT_TRUE(same(G.state, W.state));
    EXPECT_TRUE(same(G.ghosts, W.ghosts));
    EXPECT_TRUE(same(G.ghost_offsets, W.ghost_offsets));
    EXPECT_TRUE(same(G.ghost_source_level, W.ghost_source_level));
    EXPECT_TRUE(same(G.ghost_source_node, W.ghost_source_node));
    EXPECT_TRUE(same(G.ghost_weight, W.ghost_weight));  // the same bits: both copy the activation's
    EXPECT_TRUE(same(G.receivers, W.receivers));
    EXPECT_TRUE(same(G.receive_offsets, W.receive_offsets));
    EXPECT_TRUE(same(G.receive_ghost_level, W.receive_ghost_level));
    EXPECT_TRUE(same(G.receive_ghost_node, W.receive_ghost_node));
    EXPECT_TRUE(same(G.receive_weight, W.receive_weight));
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(G.impulse[k].size(), W.impulse[k].size());
      EXPECT_TRUE(same(G.external[k], W.external[k])) << k;  // same sums in the same order
    }
    for (std::size_t m = 0; m < got.motions.size(); ++m) EXPECT_TRUE(same(got.motions[m].nodes[l], want.motions[m].nodes[l]));
    for (std::size_t i = 0; i < G.node_count; ++i) {
      EXPECT_EQ(G.mass[i] == 0, W.mass[i] == 0) << i;
      EXPECT_EQ(G.inv_mass[i] == 0, W.inv_mass[i] == 0) << i;
      if (W.mass[i] > 0) worst = std::max(worst, std::abs(G.mass[i] / W.mass[i] - 1));
      if (W.inv_mass[i] > 0) worst = std::max(worst, std::abs(G.inv_mass[i] / W.inv_mass[i] - 1));
    }
  }
  return worst;
}

double total_mass(const SimBody<double>& b) {
  double m = 0;
  for (const auto& L : b.levels)
    for (std::size_t i = 0; i < L.node_count; ++i) m += L.mass[i];
  return m;
}

// Random targets on random nodes of every level (splits, merges, and nodes split two levels at
// once), applied in place, against the full apply after every change.
double worst_momentum = 0;  // relative, over the random changes of the last random_changes()

double random_changes(const BodyDef& def, int changes, double& worst_total, double& worst_sliver,
                      std::int64_t* renormalisations = nullptr) {
  Adaptive a(def);
  worst_momentum = 0;
  const double expected = total_mass(a.body);  // rho x V since the build
  std::mt19937 rng(1234);
  const int n = int(a.h.levels());
  double worst = 0;
  // Every node moving (inactive ones too: those that become free bring a velocity the correction
  // must take up, as carried-over ones do), so that the momentum kept checks the touched set.
  std::uniform_real_distribution<double> velocity(-1, 1);
  for (auto& L : a.body.levels)
    for (int k = 0; k < 3; ++k)
      for (std::size_t i = 0; i < L.node_count; ++i) L.v[k][i] = 0.3 + velocity(rng);
  auto momentum = [&] {
    std::array<double, 3> p{0, 0, 0};
    for (const auto& L : a.body.levels)
      for (std::size_t i = 0; i < L.node_count; ++i)
        if (L.state[i] == kNodeFree)
          for (int k = 0; k < 3; ++k) p[std::size_t(k)] += L.mass[i] * L.v[k][i];
    return p;
  };
  const std::array<double, 3> p0 = momentum();
  const bool held = !def.fixed.empty() || !def.prescribed.empty();
  worst_total = std::abs(expected / total_mass(a.full(0)) - 1);
  for (int c = 0; c < changes; ++c) {
    const double t = 0.01 * c;
    a.set_random_targets(rng, 12);
    std::vector<std::vector<std::uint8_t>> before(std::size_t(n), std::vector<std::uint8_t>{});
    for (int l = 0; l < n; ++l) before[std::size_t(l)] = a.as->stepped_mask(l);
    const ActivationState::Changes ch = a.as->update();
    // The changes drive the apply: they must be exactly the tets whose stepped state changed.
    for (int l = 0; l < n; ++l) {
      std::vector<std::int32_t> on, off, listed_on = ch.tets_on[std::size_t(l)], listed_off = ch.tets_off[std::size_t(l)];
      for (std::size_t e = 0; e < before[std::size_t(l)].size(); ++e)
        if (before[std::size_t(l)][e] != a.as->stepped_mask(l)[e]) (a.as->stepped_mask(l)[e] ? on : off).push_back(std::int32_t(e));
      std::sort(listed_on.begin(), listed_on.end());
      std::sort(listed_off.begin(), listed_off.end());
      EXPECT_EQ(listed_on, on) << "change " << c << ", level " << l;
      EXPECT_EQ(listed_off, off) << "change " << c << ", level " << l;
    }
    if (c % 10 == 9) {  // the incremental activation against one made from scratch with the same targets
      std::vector<std::vector<int>> targets(std::size_t(n), std::vector<int>{});
      for (int l = 0; l < n; ++l)
        for (std::size_t i = 0; i < a.h.meshes[std::size_t(l)].node_count(); ++i)
          targets[std::size_t(l)].push_back(a.as->target(l, std::int32_t(i)));
      const ActivationState fresh(a.h, targets);
      for (int l = 0; l < n; ++l) {
        EXPECT_EQ(fresh.stepped_mask(l), a.as->stepped_mask(l)) << "change " << c << ", level " << l;
        std::size_t roles = 0;
        for (std::size_t i = 0; i < a.h.meshes[std::size_t(l)].node_count(); ++i)
          roles += fresh.role(l, std::int32_t(i)) != a.as->role(l, std::int32_t(i));
        EXPECT_EQ(roles, 0u) << "change " << c << ", level " << l;
      }
    }
    keep_momentum(a.body, apply_changes(a.body, a.ps, *a.as, ch, t));
    const std::array<double, 3> p = momentum();
    for (int k = 0; k < 3 && !held; ++k)  // held: no correction (momentum goes to the fixed nodes)
      worst_momentum = std::max(worst_momentum, std::abs(p[std::size_t(k)] - p0[std::size_t(k)]) / std::abs(p0[0]));
    worst = std::max(worst, compare(a.body, a.full(t), "change " + std::to_string(c)));
    // A node no level integrates (a ghost, or inactive) weighs nothing: what lets an undo leave a
    // level that steps no tet before or after a change unsaved (adaptivity.cpp, save_state).
    std::size_t weighing = 0;
    for (const auto& L : a.body.levels)
      for (std::size_t i = 0; i < L.node_count; ++i)
        weighing += (L.state[i] == kNodeGhost || L.state[i] == kNodeInactive) && (L.mass[i] != 0 || L.inv_mass[i] != 0);
    EXPECT_EQ(weighing, 0u) << "change " << c;
    // A level that steps no tet has no free node (what lets the energies and the motion of a change
    // skip it: Simulation::body_energy, body_motion).
    for (std::size_t l = 0; l < a.body.levels.size(); ++l) {
      const auto& L = a.body.levels[l];
      if (L.stepped_count != 0) continue;
      EXPECT_EQ(std::count(L.state.begin(), L.state.begin() + std::ptrdiff_t(L.node_count), kNodeFree), 0)
          << "change " << c << ", level " << l << " steps no tet";
    }
    worst_total = std::max(worst_total, std::abs(total_mass(a.body) / expected - 1));
    // Own masses and region counts kept by the patch against those made from the full apply.
    SimBody<double> full = a.full(t);
    const PatchState fresh = make_patch_state(full, a.h, *a.as);
    for (std::size_t l = 0; l < std::size_t(n); ++l) EXPECT_TRUE(same(a.ps.own_mass[l], fresh.own_mass[l])) << c << " " << l;
    EXPECT_EQ(a.ps.fixed_count, fresh.fixed_count);
    EXPECT_EQ(a.ps.prescribed_count, fresh.prescribed_count);
    EXPECT_EQ(a.ps.load_count, fresh.load_count);
    double stepped = 0;  // the stepped tets' mass against rho V: what the factors make up for
    for (std::size_t l = 0; l < std::size_t(n); ++l)
      for (const Range& r : a.body.levels[l].stepped_runs)
        for (std::size_t e = r.begin; e < r.end; ++e) stepped += 4 * a.ps.quarter_mass[l][e];
    worst_sliver = std::max(worst_sliver, std::abs(stepped / expected - 1));
    if (::testing::Test::HasFailure()) break;
  }
  if (renormalisations) *renormalisations = a.ps.renormalisations;
  return worst;
}

TEST(ApplyChanges, RandomSplitsAndMergesGiveWhatTheFullApplyGivesNested) {
  // Nested Kuhn levels (ratio 2): the stepped tets tile the body exactly, so every mass equals
  // the full apply's to rounding (its global factor and the patch's local one are both 1 + eps).
  double worst_total = 0, worst_sliver = 0;
  const double worst = random_changes(bar({16, 4, 4}, 3, 2), 60, worst_total, worst_sliver);
  std::printf("nested, 60 random changes: masses within %.3g of the full apply's, total within %.3g of rho V (stepped "
              "tets' mass within %.3g)\n",
              worst, worst_total, worst_sliver);
  EXPECT_LT(worst, 8e-15);        // 8.9e-16 measured
  EXPECT_LT(worst_total, 2e-14);  // 2.7e-15 measured
}

TEST(ApplyChanges, RandomSplitsAndMergesGiveWhatTheFullApplyGivesNonNested) {
  // A coarse level of 5-tet cells under a fine one of 6-tet cells: the levels do not nest, their stepped tets tile the body up to slivers, and the two
  // keep rho V differently (apply_changes.hpp): the full apply rescales every node by one global
  // factor, the patch keeps the changed nodes' sum (or renormalises, when that sum's factor is 2%
  // off the body's). Everything but the masses is equal; the masses differ by the slivers' share;
  // the total is rho V for both.
  double worst_total = 0, worst_sliver = 0;
  BodyDef def = bar({18, 6, 6}, 2, 2);
  MeshSourceDef coarse = def.mesh;  // five tets a cell: its diagonals cross the fine cells'
  coarse.cells = {6, 2, 2};
  coarse.tets_per_cell = 5;
  def.multiresolution.coarser = {coarse};
  std::int64_t renormalised = 0;
  const double worst = random_changes(def, 60, worst_total, worst_sliver, &renormalised);
  std::printf("non-nested, 60 random changes (%lld renormalised): masses within %.3g of the full apply's, total within "
              "%.3g of rho V (stepped tets' mass within %.3g)\n",
              static_cast<long long>(renormalised), worst, worst_total, worst_sliver);
  EXPECT_GT(worst_sliver, 1e-3);  // 0.0054 measured: the case is not nested (else this test checks nothing more)
  EXPECT_LT(worst, 0.1);          // 0.020 measured, 6 of 60 changes renormalised (slivers: 0.54% of the volume)
  EXPECT_LT(worst_total, 1e-13);  // 2.2e-14 measured
}

TEST(ApplyChanges, RandomSplitsAndMergesOnTheOrgan) {
#if PLIANT_HAS_CGAL
  // The organ on three CGAL levels of simplified surfaces: far from nested (slivers up to 2% of the
  // volume). Everything but the masses equal to the full apply's; the masses within about the 2%
  // that triggers a renormalisation (apply_changes.hpp), and equal after one.
  BodyDef b;
  b.name = "organ";
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.01;
  b.material.young = 2e4;
  b.material.poisson = 0.45;
  b.multiresolution.levels = 3;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  double worst_total = 0, worst_sliver = 0;
  std::int64_t renormalised = 0;
  const double worst = random_changes(b, 300, worst_total, worst_sliver, &renormalised);
  std::printf("organ, 300 random changes (%lld renormalised): masses within %.3g of the full apply's, total within %.3g "
              "of rho V (stepped tets' mass within %.3g)\n",
              static_cast<long long>(renormalised), worst, worst_total, worst_sliver);
  EXPECT_GT(worst_sliver, 5e-3);  // 0.017 measured: the case is not nested
  EXPECT_LT(worst, 0.1);          // 0.031 measured, 52 of 300 changes renormalised
  EXPECT_LT(worst_total, 2e-14);  // 2.4e-15 measured
  std::printf("momentum kept to %.3g (relative)\n", worst_momentum);
  EXPECT_LT(worst_momentum, 2e-13);  // 2.3e-14 measured (the issue asks for 1e-9)
#else
  GTEST_SKIP() << "SKIPPED: the organ is meshed with CGAL (PLIANT_WITH_CGAL=OFF)";
#endif
}

// One coarse node of a 2-level bar a cells long (x 8 x 8) split, then merged back: the nodes
// changed and the apply's work (nodes and tets read or written: PatchStats), with the body's size.
struct LocalWork {
  std::size_t body_nodes = 0, body_tets = 0, changed[2] = {0, 0};
  PatchStats work[2];
};
LocalWork split_and_merge(int cells) {
  const BodyDef def = bar({cells, 8, 8}, 2, 2);
  Adaptive a(def);
  LocalWork w;
  for (const auto& L : a.body.levels) {
    w.body_nodes += L.node_count;
    w.body_tets += L.tet_count;
  }
  // The coarse node nearest (0.2, 0.05, 0.05): the same neighbourhood in every bar, away from the
  // load (whose region is written again when its nodes change) and the ends.
  const TetMesh& coarse = a.h.meshes[0];
  std::int32_t node = 0;
  double best = 1e300;
  for (std::size_t i = 0; i < coarse.node_count(); ++i) {
    const Vec3d p = coarse.point(i);
    const double d = std::hypot(p[0] - 0.2, p[1] - 0.05, p[2] - 0.05);
    if (d < best) {
      best = d;
      node = std::int32_t(i);
    }
  }
  for (int step = 0; step < 2; ++step) {
    a.as->set_target(0, node, step == 0 ? 1 : 0);
    const ActivationState::Changes ch = a.as->update();
    const ChangeSet cs = apply_changes(a.body, a.ps, *a.as, ch, 0.0);
    w.work[step] = cs.stats;
    for (const auto& c : cs.changed) w.changed[step] += c.size();
    compare(a.body, a.full(0.0), step == 0 ? "split" : "merge");
  }
  std::printf("%d cells long: %zu nodes, %zu tets; split: %zu nodes changed, %zu nodes and %zu tets touched, %zu entries "
              "written; merge: %zu changed, %zu nodes and %zu tets touched, %zu entries\n",
              cells, w.body_nodes, w.body_tets, w.changed[0], w.work[0].nodes, w.work[0].tets, w.work[0].entries,
              w.changed[1], w.work[1].nodes, w.work[1].tets, w.work[1].entries);
  return w;
}

TEST(ApplyChanges, OneSplitAndItsMergeTouchOnlyTheNodesAroundIt) {
  const LocalWork a = split_and_merge(64), b = split_and_merge(128);
  EXPECT_GT(b.body_nodes, 19 * a.body_nodes / 10);  // the body doubles (6 090 -> 12 074 nodes)
  for (int step = 0; step < 2; ++step) {
    EXPECT_GT(a.changed[step], 0u);
    // The work does not grow with the body: the same, node for node, on a bar twice as long.
    EXPECT_EQ(a.changed[step], b.changed[step]);
    EXPECT_EQ(a.work[step].nodes, b.work[step].nodes);
    EXPECT_EQ(a.work[step].tets, b.work[step].tets);
    EXPECT_EQ(a.work[step].entries, b.work[step].entries);
    // And it is a few times the nodes changed. Measured (split and merge alike): 66 nodes changed,
    // 148 nodes and 2 136 tets touched, of 6 090 nodes and 27 648 tets (2.4%, 7.7%).
    EXPECT_LT(a.work[step].nodes, 10 * a.changed[step]);
    EXPECT_LT(double(a.work[step].nodes), 0.05 * double(a.body_nodes));
    EXPECT_LT(double(a.work[step].tets), 0.25 * double(a.body_tets));
  }
}

// undo_change (adaptivity.hpp), on a bent and moving bar split around one bump: a decision that
// only merges (the bar straightened) is undone, and every array of every level and the patch state
// are the same bits as before it; non-nested levels too, where the masses depend on the history of
// changes (apply_changes.hpp), so an undo that only applied the old activation again would not
// give them back. A decision that merges and splits (a bump elsewhere) is applied again without
// its merges: the merged nodes are split again, and every node the splits left alone has the bits
// it had. The counts: the merges dropped are not counted as merges but as deferred.
struct UndoOutcome {
  std::int64_t splits = 0, merges = 0;
};

template <class A>
bool same_bits(const A& got, const A& want) {
  // (memcmp of an empty array's null data() is undefined, even for 0 bytes: UBSan says so.)
  return got.size() == want.size() && (got.empty() || std::memcmp(got.data(), want.data(), got.size() * sizeof(got[0])) == 0);
}

// cap >= 0: no split beyond that level (World::set_adapt_cap), so the levels finer than it step
// nothing, before the change or after it: save_state does not copy them (their nodes are
// inactive, and nothing the change or its undo does writes them), and their bits must still be
// what they were.
UndoOutcome undo_a_change(BodyDef def, bool and_split, int cap = -1) {
  def.multiresolution.active.adapt.min_dwell = 0;  // a region calm at one decision merges at it
  Adaptive a(def);
  a.body.adapt = make_adaptive_state(std::shared_ptr<const Hierarchy>(&a.h, [](const Hierarchy*) {}),
                                     def.multiresolution.active, a.body);
  AdaptiveState& st = *a.body.adapt;
  if (cap >= 0) st.cap = cap;
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> velocity(-0.1, 0.1);
  const double length = def.mesh.max[0];
  // A bump of 1 cm, an eighth of the bar wide, about x = c (none: c < 0); every node moving.
  auto bend = [&](double c) {
    for (auto& L : a.body.levels)
      for (std::size_t i = 0; i < L.node_count; ++i) {
        const double d = (L.X[0][i] - c) / (0.125 * length);
        for (int k = 0; k < 3; ++k) L.x[k][i] = L.X[k][i];
        if (c >= 0) L.x[1][i] += 0.01 * std::exp(-d * d);
        for (int k = 0; k < 3; ++k) L.v[k][i] = velocity(rng);
      }
  };
  bend(0.3 * length);
  EXPECT_TRUE(adapt_body(a.body, 0.0));  // splits around the bump
  bend(and_split ? 0.7 * length : -1);   // the first region calm (merges); a second bump (splits)
  const SimBody<double> before = a.body;
  const PatchState ps_before = st.patch;
  const std::int64_t splits = st.splits, merges = st.merges, changes = st.changes;
  EXPECT_TRUE(adapt_body(a.body, 0.01));
  EXPECT_TRUE(st.undoable);
  for (std::size_t l = std::size_t(cap) + 1; cap >= 0 && l < a.body.levels.size(); ++l) {  // idle throughout
    EXPECT_EQ(before.levels[l].stepped_count, 0u) << l;
    EXPECT_EQ(a.body.levels[l].stepped_count, 0u) << l;
  }
  UndoOutcome out;
  std::vector<TargetChange> merged;
  for (const TargetChange& c : st.decided) {
    (c.kind == TargetChange::merge ? out.merges : out.splits)++;
    if (c.kind == TargetChange::merge) merged.push_back(c);
  }
  EXPECT_EQ(undo_change(a.body, 0.01), and_split);  // something applied again: the splits
  EXPECT_FALSE(st.undoable);
  for (const TargetChange& c : merged) EXPECT_EQ(st.activation->target(c.level, c.node), c.from);  // split again
  for (std::size_t l = 0; l < a.body.levels.size(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    const Level<double>& G = a.body.levels[l];
    const Level<double>& W = before.levels[l];
    if (and_split) {  // the nodes the splits left alone (same state, not a ghost, whose entries lag)
      std::size_t differ = 0;
      for (std::size_t i = 0; i < G.node_count; ++i)
        if (G.state[i] == W.state[i] && G.state[i] != kNodeGhost && G.state[i] != kNodeInactive)
          for (int k = 0; k < 3; ++k) differ += G.x[k][i] != W.x[k][i] || G.v[k][i] != W.v[k][i];
      EXPECT_EQ(differ, 0u);
      continue;
    }
    EXPECT_EQ(G.stepped_runs.size(), W.stepped_runs.size());
    for (std::size_t r = 0; r < std::min(G.stepped_runs.size(), W.stepped_runs.size()); ++r)
      EXPECT_TRUE(G.stepped_runs[r].begin == W.stepped_runs[r].begin && G.stepped_runs[r].end == W.stepped_runs[r].end);
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(same_bits(G.x[k], W.x[k])) << "x";
      EXPECT_TRUE(same_bits(G.v[k], W.v[k])) << "v";
      EXPECT_TRUE(same_bits(G.external[k], W.external[k])) << "external";
    }
    EXPECT_TRUE(same_bits(G.mass, W.mass)) << "mass";
    EXPECT_TRUE(same_bits(G.inv_mass, W.inv_mass)) << "inv_mass";
    EXPECT_TRUE(same_bits(G.state, W.state)) << "state";
    EXPECT_TRUE(same_bits(G.ghosts, W.ghosts) && same_bits(G.ghost_offsets, W.ghost_offsets) &&
                same_bits(G.ghost_source_node, W.ghost_source_node) && same_bits(G.ghost_weight, W.ghost_weight))
        << "ghosts";
    EXPECT_TRUE(same_bits(G.receivers, W.receivers) && same_bits(G.receive_offsets, W.receive_offsets) &&
                same_bits(G.receive_weight, W.receive_weight))
        << "receivers";
    for (std::size_t m = 0; m < a.body.motions.size(); ++m) EXPECT_EQ(a.body.motions[m].nodes[l], before.motions[m].nodes[l]);
    EXPECT_TRUE(same_bits(st.patch.own_mass[l], ps_before.own_mass[l])) << "own_mass";
    EXPECT_TRUE(same_bits(st.patch.raw_mass[l], ps_before.raw_mass[l])) << "raw_mass";
  }
  if (!and_split) {
    EXPECT_EQ(st.patch.raw_total, ps_before.raw_total);
    EXPECT_EQ(st.patch.load_count, ps_before.load_count);
  }
  EXPECT_EQ(st.merges, merges);
  EXPECT_EQ(st.deferred_merges, out.merges);
  EXPECT_EQ(st.splits, splits + out.splits);
  EXPECT_EQ(st.changes, changes + (and_split ? 1 : 0));
  EXPECT_EQ(st.undone, 1);
  return out;
}

TEST(ApplyChanges, AnUndoneChangeLeavesTheBodyAsItWasToTheBit) {
  const UndoOutcome merges = undo_a_change(bar({16, 4, 4}, 3, 2), false);
  const UndoOutcome both = undo_a_change(bar({16, 4, 4}, 3, 2), true);
  BodyDef def = bar({18, 6, 6}, 2, 2);
  MeshSourceDef coarse = def.mesh;  // non-nested, as in the random changes above
  coarse.cells = {6, 2, 2};
  coarse.tets_per_cell = 5;
  def.multiresolution.coarser = {coarse};
  const UndoOutcome non_nested = undo_a_change(def, false);
  const UndoOutcome capped = undo_a_change(bar({16, 4, 4}, 3, 2), false, 1);  // the finest level idle
  std::printf("undone: %lld merges (nested, 3 levels); %lld merges, %lld splits kept (a second bump); %lld merges "
              "(non-nested); %lld merges (nested, the finest level idle)\n",
              static_cast<long long>(merges.merges), static_cast<long long>(both.merges), static_cast<long long>(both.splits),
              static_cast<long long>(non_nested.merges), static_cast<long long>(capped.merges));
  EXPECT_GT(merges.merges, 0);
  EXPECT_EQ(merges.splits, 0);
  EXPECT_GT(both.merges, 0);
  EXPECT_GT(both.splits, 0);
  EXPECT_GT(non_nested.merges, 0);
  EXPECT_GT(capped.merges, 0);
}


// adapt_body's measure on an executor's threads (chunks of 256 stepped tets) decides as on one: the
// same peak strain to the bit, the same decisions, the same body after them. The coarser level of
// this bar steps 1 536 tets: 6 chunks.
// What a change adds to the body's energy, measured where it acts (Simulation::
// change_energy_added: the nodes whose state, mass, position or velocity changed and the stepped
// tets around them), must be the difference of the whole body's energies after and before, up to
// the rounding of those two sums; over decisions that split and merge under random bends and
// velocities, corotational (listed energy kernel) and stvk (one tet at a time), nested and not.
// Returns the largest difference over the body's energy before.
double change_energy_against_whole_sums(BodyDef def, int& changes) {
  def.multiresolution.active.adapt.min_dwell = 0;
  def.multiresolution.active.adapt.refine_above = 0.3;
  def.multiresolution.active.adapt.coarsen_below = 0.1;
  Adaptive a(def);
  a.body.adapt = make_adaptive_state(std::shared_ptr<const Hierarchy>(&a.h, [](const Hierarchy*) {}),
                                     def.multiresolution.active, a.body);
  Simulation<double> sim;
  sim.bodies.push_back(std::move(a.body));
  SimBody<double>& body = sim.bodies[0];
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1), velocity(-0.1, 0.1);
  const double length = def.mesh.max[0];
  double worst = 0, largest = 0;
  changes = 0;
  for (int d = 0; d < 40; ++d) {
    // One or two bumps of random height and place; every node moving, or every node at rest.
    const double c1 = u(rng) * length, c2 = d % 3 == 0 ? u(rng) * length : -1, height = 0.02 * u(rng);
    for (auto& L : body.levels)
      for (std::size_t i = 0; i < L.node_count; ++i) {
        const double d1 = (L.X[0][i] - c1) / (0.125 * length), d2 = (L.X[0][i] - c2) / (0.125 * length);
        for (int k = 0; k < 3; ++k) L.x[k][i] = L.X[k][i];
        L.x[1][i] += height * (std::exp(-d1 * d1) + (c2 >= 0 ? std::exp(-d2 * d2) : 0.0));
        for (int k = 0; k < 3; ++k) L.v[k][i] = d % 2 ? velocity(rng) : 0.0;  // at rest: only positions differ
      }
    double e_before = 0;
    auto before_change = [&] {
      sim.save_change_energy(body);
      e_before = sim.body_energy(nullptr, body);
    };
    if (!adapt_body(body, 0.01 * d, {}, before_change)) continue;
    ++changes;
    const Simulation<double>::ChangeEnergy local = sim.change_energy_added(body);
    const double whole = sim.body_energy(nullptr, body) - e_before;
    worst = std::max(worst, std::abs(local.added - whole) / e_before);
    EXPECT_LE(local.before_here, e_before * (1 + 1e-12));  // a part of the whole (terms >= 0)
    EXPECT_GT(local.before_here, 0.0);
    largest = std::max(largest, std::abs(whole) / e_before);
  }
  EXPECT_GT(largest, 1e-3);  // changes that add or take a measurable share of the energy
  return worst;
}

TEST(ApplyChanges, TheEnergyAChangeAddsIsTheDifferenceOfTheBodysEnergies) {
  // Measured (2026-11-28): at most 2.3e-14 of the body's energy before (the rounding of two
  // whole-body sums of a few thousand terms); leaving out the kinetic energy of the nodes a change
  // turns on gave 0.53. (Every node whose position changed here also changed state or velocity,
  // or neighbours one that did: the position test is not what this separates.)
  int changes = 0;
  BodyDef nested = bar({16, 4, 4}, 3, 2);
  EXPECT_LT(change_energy_against_whole_sums(nested, changes), 1e-13);
  EXPECT_GT(changes, 10);
  nested.model = ForceModel::stvk;
  EXPECT_LT(change_energy_against_whole_sums(nested, changes), 1e-13);
  EXPECT_GT(changes, 10);
  BodyDef non_nested = bar({18, 6, 6}, 2, 2);
  MeshSourceDef coarse = non_nested.mesh;
  coarse.cells = {6, 2, 2};
  coarse.tets_per_cell = 5;
  non_nested.multiresolution.coarser = {coarse};
  EXPECT_LT(change_energy_against_whole_sums(non_nested, changes), 1e-13);
  EXPECT_GT(changes, 10);
}

TEST(ApplyChanges, TheMeasureOnTwoThreadsDecidesAsOnOne) {
  const BodyDef def = bar({32, 8, 8}, 2, 2);
  Executor two(2);
  Adaptive serial(def), threaded(def);
  for (Adaptive* a : {&serial, &threaded}) {
    a->body.adapt = make_adaptive_state(std::shared_ptr<const Hierarchy>(&a->h, [](const Hierarchy*) {}),
                                        def.multiresolution.active, a->body);
    ASSERT_GT(a->body.levels[0].stepped_count, 5u * 256u);
  }
  // A bump of 1 cm about x = c, every node moving (the same on both bodies).
  auto bend = [&](Adaptive& a, double c) {
    for (auto& L : a.body.levels)
      for (std::size_t i = 0; i < L.node_count; ++i) {
        const double d = (L.X[0][i] - c) / (0.125 * def.mesh.max[0]);
        for (int k = 0; k < 3; ++k) L.x[k][i] = L.X[k][i];
        L.x[1][i] += 0.01 * std::exp(-d * d);
        for (int k = 0; k < 3; ++k) L.v[k][i] = 0.01 * std::sin(double(i) + k);
      }
  };
  int changes = 0;
  for (int round = 0; round < 3; ++round) {
    const double c = (0.25 + 0.25 * round) * def.mesh.max[0], t = 0.01 * round;
    bend(serial, c);
    bend(threaded, c);
    const bool a = adapt_body(serial.body, t);
    const bool b = adapt_body(threaded.body, t, {}, {}, &two);
    ASSERT_EQ(a, b) << round;
    changes += a;
    const AdaptiveState& sa = *serial.body.adapt;
    const AdaptiveState& sb = *threaded.body.adapt;
    EXPECT_GT(sa.peak_strain, 0.0);
    EXPECT_EQ(std::memcmp(&sa.peak_strain, &sb.peak_strain, sizeof(double)), 0) << round;
    ASSERT_EQ(sa.decided.size(), sb.decided.size()) << round;
    for (std::size_t i = 0; i < sa.decided.size(); ++i) {
      EXPECT_EQ(sa.decided[i].node, sb.decided[i].node);
      EXPECT_EQ(sa.decided[i].to, sb.decided[i].to);
    }
    for (std::size_t l = 0; l < serial.body.levels.size(); ++l)
      for (int k = 0; k < 3; ++k) {
        EXPECT_TRUE(same_bits(serial.body.levels[l].x[k], threaded.body.levels[l].x[k])) << round << " " << l;
        EXPECT_TRUE(same_bits(serial.body.levels[l].v[k], threaded.body.levels[l].v[k])) << round << " " << l;
      }
  }
  EXPECT_GT(changes, 0);
}

// adapt_body's `finest` (the finest level's stepped tets as its force pass lists them) gives the
// peak strain that the level's own arrays give, to the bit, whatever the list's order: here the
// stepped tets in reverse. The finest level is stretched 30 % along the bar, so that its tets hold
// the body's peak strain (Green-Lagrange (1.3^2 - 1) / 2 = 0.345; the coarser level's bump gives at
// most 0.11 here), and its nodes moved by a pseudo-random 0.5 % of its cells, so that one tet holds
// it (a list that dropped half its tets, or read them shifted by one, passed without).
TEST(ApplyChanges, TheFinestLevelsListGivesThePeakStrainItsArraysGive) {
  const BodyDef def = bar({16, 4, 4}, 2, 2);
  Adaptive by_tet(def), by_list(def);
  for (Adaptive* a : {&by_tet, &by_list})
    a->body.adapt = make_adaptive_state(std::shared_ptr<const Hierarchy>(&a->h, [](const Hierarchy*) {}),
                                        def.multiresolution.active, a->body);
  const double cell = def.mesh.max[0] / def.mesh.cells[0];  // m, the finest level's
  auto bend = [&](Adaptive& a, double c) {
    for (std::size_t l = 0; l < a.body.levels.size(); ++l) {
      auto& L = a.body.levels[l];
      for (std::size_t i = 0; i < L.node_count; ++i) {
        const double d = (L.X[0][i] - c) / (0.125 * def.mesh.max[0]);
        for (int k = 0; k < 3; ++k) L.x[k][i] = L.X[k][i];
        L.x[1][i] += 0.01 * std::exp(-d * d);
        if (l + 1 == a.body.levels.size()) {
          L.x[0][i] *= 1.3;
          for (int k = 0; k < 3; ++k) L.x[k][i] += 0.005 * cell * std::sin(1e3 * double(i) + 7.0 * k + c);
        }
      }
    }
  };
  std::vector<std::int32_t> list;
  AlignedVector<std::int32_t> tet[4];
  AlignedVector<double> grad[9];
  int rounds_with_list = 0;
  for (int round = 0; round < 4; ++round) {
    const double c = (0.3 + 0.15 * round) * def.mesh.max[0], t = 0.01 * round;
    bend(by_tet, c);
    bend(by_list, c);
    const Level<double>& F = by_list.body.levels.back();
    list.clear();
    for (const Range& r : F.stepped_runs)
      for (std::size_t e = r.begin; e < r.end; ++e) list.push_back(std::int32_t(e));
    std::reverse(list.begin(), list.end());
    ListedRest<double> finest;
    for (int a = 0; a < 4; ++a) {
      tet[a].resize(list.size());
      for (std::size_t i = 0; i < list.size(); ++i) tet[a][i] = F.tet[a][std::size_t(list[i])];
      finest.tet[a] = tet[a].data();
    }
    for (int q = 0; q < 9; ++q) {
      grad[q].resize(list.size());
      for (std::size_t i = 0; i < list.size(); ++i) grad[q][i] = F.grad[q][std::size_t(list[i])];
      finest.grad[q] = grad[q].data();
    }
    finest.count = list.size();
    rounds_with_list += !list.empty();
    const bool a = adapt_body(by_tet.body, t);
    const bool b = adapt_body(by_list.body, t, {}, {}, nullptr, &finest);
    ASSERT_EQ(a, b) << round;
    const double pa = by_tet.body.adapt->peak_strain, pb = by_list.body.adapt->peak_strain;
    EXPECT_GT(pa, 0.0);
    EXPECT_EQ(std::memcmp(&pa, &pb, sizeof(double)), 0) << round << ": " << pa << " against " << pb;
    if (!list.empty()) {
      EXPECT_GT(pa, 0.3) << round;  // the stretched finest level's strain is the peak
    }
  }
  EXPECT_GE(rounds_with_list, 2);  // the first round split, the finest level stepped after it
}

}  // namespace
// A listed level's list edited at each change of resolution (Simulation::edit_list: a tet no longer
// stepped gives its position to the list's last, a new one is appended) against the list made
// afresh from the same body (make_list, a Simulation prepared from a copy): the same tets listed,
// each with its rest data and rotation, every node's gather entries naming the same tets and
// corners in the same order (the order of the sums: the same bits), each offset encoded for the
// block's stride, and the contexts pointing at the arrays. Random splits and merges of a 3-level
// bar under gravity, with 16 ticks between them so that the rotations move.
template <class T>
void edited_lists_are_the_lists_made_afresh(std::uint32_t seed) {
  const BodyDef def = bar({16, 4, 4}, 3, 2);
  AdaptiveBody<T> a(def);
  Executor exec(1);
  Simulation<T> sim;
  sim.bodies.push_back(a.body);
  sim.gravity[2] = T(-9.81);
  const double tick = sim.bodies[0].levels.back().stable_dt;  // s: the finest level steps every tick
  sim.prepare(tick);
  std::mt19937 rng(seed);
  const int levels = int(a.h.levels());
  double t = 0;
  std::int64_t index = 0;
  int edited = 0, compared = 0;
  for (int change = 0; change < 40; ++change) {
    std::string where;
    for (int k = 0; k < 16; ++k, t += tick) ASSERT_TRUE(sim.step(exec, t, tick, where, index++)) << where;
    std::vector<std::vector<std::int32_t>> before(static_cast<std::size_t>(levels));
    for (int l = 0; l < levels; ++l) before[std::size_t(l)] = sim.job_of(sim.bodies[0], sim.bodies[0].levels[std::size_t(l)])->stepped;
    a.set_random_targets(rng, 6);
    const ActivationState::Changes ch = a.as->update();
    keep_momentum(sim.bodies[0], apply_changes(sim.bodies[0], a.ps, *a.as, ch, t));
    sim.prepare(tick);
    // The fresh lists take every rotation from Level::rotation: the listed ones written there.
    sim.write_back_rotations();
    Simulation<T> fresh;
    fresh.bodies = sim.bodies;
    fresh.prepare(tick);
    for (int l = 0; l < levels; ++l) {
      SCOPED_TRACE("change " + std::to_string(change) + ", level " + std::to_string(l));
      const Level<T>& L = sim.bodies[0].levels[std::size_t(l)];
      const LevelJobState<T>& e = *sim.job_of(sim.bodies[0], L);
      const LevelJobState<T>& f = *fresh.job_of(fresh.bodies[0], fresh.bodies[0].levels[std::size_t(l)]);
      ASSERT_EQ(e.stepped.empty(), f.stepped.empty());
      if (f.stepped.empty()) continue;
      ++compared;
      std::vector<std::int32_t> was = before[std::size_t(l)], now = e.stepped;
      std::sort(was.begin(), was.end());
      std::sort(now.begin(), now.end());
      edited += !before[std::size_t(l)].empty() && was != now;
      const std::size_t n = f.stepped.size();
      ASSERT_EQ(e.stepped.size(), n);
      ASSERT_EQ(e.list_position.size(), L.tet_count);
      std::size_t positions = 0;
      for (const std::int32_t p : e.list_position) positions += p >= 0;
      EXPECT_EQ(positions, n);  // no tet left behind
      for (std::size_t i = 0; i < n; ++i) {
        const std::int32_t tet = f.stepped[i];
        const std::int32_t p = e.list_position[std::size_t(tet)];
        ASSERT_GE(p, 0) << "tet " << tet;
        const auto q = std::size_t(p);
        ASSERT_EQ(e.stepped[q], tet);
        for (int c = 0; c < 4; ++c) EXPECT_EQ(e.listed_tet[c][q], f.listed_tet[c][i]);
        for (int g = 0; g < 9; ++g) EXPECT_EQ(std::memcmp(&e.listed_grad[g][q], &f.listed_grad[g][i], sizeof(T)), 0);
        EXPECT_EQ(std::memcmp(&e.listed_volume[q], &f.listed_volume[i], sizeof(T)), 0);
        for (int k = 0; k < 4; ++k) EXPECT_EQ(std::memcmp(&e.listed_rotation[k][q], &f.listed_rotation[k][i], sizeof(T)), 0);
      }
      const std::size_t stride = e.listed_corner_force.stride();
      EXPECT_GE(stride, n);
      EXPECT_EQ(e.gc.offsets, L.incidence_offsets.data());
      EXPECT_EQ(e.gc.ends, e.gather_end.data());
      EXPECT_EQ(e.gc.corner_stride, stride);
      EXPECT_EQ(e.gc.corner_offset, e.gather_corner_offset.data());
      EXPECT_EQ(e.ec.listed_tet[0], e.listed_tet[0].data());
      EXPECT_EQ(e.ec.corner_force[0], e.listed_corner_force[0].data());
      EXPECT_EQ(e.listed_corner_force[0].size(), n);
      for (std::size_t v = 0; v < L.node_count; ++v) {
        const std::int32_t from = L.incidence_offsets[v];
        ASSERT_EQ(e.gather_end[v] - from, f.gather_end[v] - from) << "node " << v;
        for (std::int32_t k = from; k < e.gather_end[v]; ++k) {
          const std::int32_t ce = e.gather_incidence[std::size_t(k)], cf = f.gather_incidence[std::size_t(k)];
          EXPECT_EQ(e.stepped[std::size_t(ce >> 2)], f.stepped[std::size_t(cf >> 2)]) << "node " << v;
          EXPECT_EQ(ce & 3, cf & 3) << "node " << v;
          EXPECT_EQ(std::int64_t(e.gather_corner_offset[std::size_t(k)]), 3 * std::int64_t(stride) * (ce & 3) + (ce >> 2));
        }
      }
    }
    if (::testing::Test::HasFailure()) break;
  }
  std::printf("%d listed levels compared, %d of them edited by a change\n", compared, edited);
  EXPECT_GE(edited, 30);  // 36 and 42 with these seeds: the test keeps exercising edits
}

TEST(ApplyChanges, EditedListsAreTheListsMadeAfreshDouble) { edited_lists_are_the_lists_made_afresh<double>(21); }
TEST(ApplyChanges, EditedListsAreTheListsMadeAfreshFloat) { edited_lists_are_the_lists_made_afresh<float>(22); }

}  // namespace pliant::detail
