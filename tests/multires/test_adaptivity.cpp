// Adaptivity (multiresolution.active = adaptive; engine/src/multires/adaptivity.*): splits where
// the body strains and merges where it is calm again, conserves mass exactly and linear momentum
// to rounding at every change, does not pump energy into a vibrating body over 100 forced
// split/merge cycles, gives the same bits for 1, 2 and 4 threads, and parses from scenes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "pliant/level.hpp"
#include "pliant/scene.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;

// A free 10 x 4 x 4 cm rubber block of nested Kuhn levels (coarse cells 2x the fine ones).
BodyDef block(double damping = 0) {
  BodyDef b;
  b.name = "block";
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.1, 0.04, 0.04};
  b.mesh.cells = {10, 4, 4};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.poisson = 0.3;
  b.material.density = 1000;
  b.material.damping.mass = damping;
  b.multiresolution.levels = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  return b;
}

WorldDef no_gravity(int threads = 1) {
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  wd.threads = threads;
  return wd;
}

// Every free node's mass and momentum, over all levels.
struct Totals {
  double mass = 0;
  Vec3d momentum{0, 0, 0};
};
Totals totals(const World& w) {
  Totals t;
  for (int l = 0; l < w.level_count(0); ++l) {
    const Level<double>& L = w.level<double>(0, l);
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree) {
        t.mass += L.mass[n];
        for (int k = 0; k < 3; ++k) t.momentum[std::size_t(k)] += L.mass[n] * L.v[k][n];
      }
  }
  return t;
}

// Stretch the block along x by 3% and give it a drift (body frame: the arrays are relative).
void stretch_and_drift(World& w) {
  for (int l = 0; l < w.level_count(0); ++l) {
    Level<double>& L = w.level<double>(0, l);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      L.x[0][n] = 1.03 * L.X[0][n];
      L.v[0][n] = 0.2;
      L.v[1][n] = -0.1;
    }
  }
}

TEST(Adaptivity, ForcedSplitsAndMergesConserveMassAndMomentumAndPumpNoEnergy) {
  World w(no_gravity());
  BodyDef b = block();
  b.multiresolution.active.adapt.refine_above = 10;  // only the forced changes: no strain reaches 10,
  b.multiresolution.active.adapt.coarsen_below = 0;  // and no measure is below 0
  w.add_body(b);
  stretch_and_drift(w);
  const Totals t0 = totals(w);
  const double e0 = w.energies().total();
  const double expected_mass = 1000 * 0.1 * 0.04 * 0.04;
  double worst_mass = 0, worst_momentum = 0, max_energy = e0;
  int cycles = 0;
  for (; cycles < 100; ++cycles)
    for (int level : {1, 0}) {
      w.force_level(0, level);
      for (int i = 0; i < 6; ++i) w.step();
      const Totals t = totals(w);
      worst_mass = std::max(worst_mass, std::abs(t.mass - expected_mass) / expected_mass);
      for (int k = 0; k < 3; ++k)
        worst_momentum = std::max(worst_momentum, std::abs(t.momentum[std::size_t(k)] - t0.momentum[std::size_t(k)]) /
                                                      std::abs(t0.momentum[0]));
      max_energy = std::max(max_energy, w.energies().total());
    }
  const World::AdaptStats a = w.adapt_stats(0);
  std::printf("%d cycles: %lld changes, %lld splits, %lld merges; mass %.3g, momentum %.3g (relative); energy %.6g -> "
              "%.6g J (max %.6g)\n",
              cycles, static_cast<long long>(a.changes), static_cast<long long>(a.splits), static_cast<long long>(a.merges),
              worst_mass, worst_momentum, e0, w.energies().total(), max_energy);
  EXPECT_EQ(a.changes, 200);
  EXPECT_LT(worst_mass, 1e-13);      // 1.9e-14 measured (the issue asks for exact)
  EXPECT_LT(worst_momentum, 1e-13);  // 1.4e-14 measured (the issue asks for 1e-9)
  EXPECT_LE(max_energy, 1.01 * e0);  // the issue's bound; measured: never above the start. The transfers
                                     // dissipate: the vibration's 0.010 J is gone after 200 changes
}

TEST(Adaptivity, AMergeCarriesATurnedBodyOverWithoutStrainingIt) {
  // The block turned a quarter turn about z, at rest (corotational: no force, nothing moves), split
  // all and merged back: the coarse nodes must land where the turn puts them. A merge that took the
  // mass-weighted average of the finer displacements around a node put every node on the block's
  // surface (all of the coarse level's) about h/4 inside, i.e. 7 mm off here: 0.25 J of elastic
  // energy from nothing (and, in a pushed beam, 3.5x its energy at the first merge).
  World w(no_gravity());
  BodyDef b = block();
  b.multiresolution.active.adapt.refine_above = 10;
  b.multiresolution.active.adapt.coarsen_below = 0;
  w.add_body(b);
  auto turned = [](const Level<double>& L, std::size_t n, int k) {  // (x, y, z) -> (-y, x, z)
    return k == 0 ? -L.X[1][n] : k == 1 ? L.X[0][n] : L.X[2][n];
  };
  for (int l = 0; l < w.level_count(0); ++l) {
    Level<double>& L = w.level<double>(0, l);
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int k = 0; k < 3; ++k) L.x[k][n] = turned(L, n, k);
  }
  w.force_level(0, 1);
  w.step();
  ASSERT_EQ(w.level_info(0, 0).stepped_tets, 0u);
  w.force_level(0, 0);
  w.step();
  ASSERT_EQ(w.level_info(0, 1).stepped_tets, 0u);
  const Level<double>& C = w.level<double>(0, 0);
  double worst = 0;
  for (std::size_t n = 0; n < C.node_count; ++n)
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(C.x[k][n] - turned(C, n, k)));
  std::printf("after the merge: coarse nodes within %.3g m of the turned block, elastic energy %.3g J\n", worst,
              w.energies().elastic);
  EXPECT_LT(worst, 1e-16);                // measured 1.4e-17 m
  EXPECT_LT(w.energies().elastic, 1e-25);  // measured 2.6e-30 J
}

// Fixes the nodes at x = 0 (a clamped end).
void clamp_end(BodyDef& b) {
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-9, 1, 1};
  b.fixed.push_back(clamp);
}

// A 20 x 2 x 2 cm bar of 2 nested levels, damped, clamped at x = 0, its tip pushed `amplitude` m
// sideways over 0.1 s and held (and brought back by 0.3 s when `release`).
BodyDef pushed_bar(double amplitude, bool release) {
  BodyDef b = block(20);
  b.mesh.max = {0.2, 0.02, 0.02};
  b.mesh.cells = {20, 2, 2};
  clamp_end(b);
  PrescribedMotionDef push;
  push.region.min = {0.2 - 1e-9, -1, -1};
  push.region.max = {1, 1, 1};
  push.keyframes = {{0.0, {0, 0, 0}}, {0.1, {0, amplitude, 0}}, {0.2, {0, amplitude, 0}}};
  if (release) push.keyframes.push_back({0.3, {0, 0, 0}});
  b.prescribed.push_back(push);
  return b;
}

// A 20 x 10 x 4 cm slab of 2 nested levels, damped, clamped at its base.
BodyDef clamped_slab() {
  BodyDef b = block(20);
  b.mesh.max = {0.2, 0.1, 0.04};
  b.mesh.cells = {10, 6, 2};
  RegionDef base;
  base.min = {-1, -1, -1};
  base.max = {1, 1, 1e-9};
  b.fixed.push_back(base);
  return b;
}

TEST(Adaptivity, AChangeAcrossTwoLevelsCarriesTheFieldOver) {
  // A 3-level block: the field jumps from the coarsest level to the finest and back, skipping the
  // middle one, whose nodes were never simulated and sit at rest. The nodes that start being
  // simulated must take the field that was simulated (through the middle level's links), not
  // their own stale state: a finest node whose middle-level tet was inactive kept its rest place,
  // 100 J of strain from nothing in a stress scene (docs/stress.md, the 3-level failures).
  World w(no_gravity());
  BodyDef b = block();
  b.mesh.cells = {8, 4, 4};
  b.multiresolution.levels = 3;
  b.multiresolution.active.adapt.refine_above = 10;
  b.multiresolution.active.adapt.coarsen_below = 0;
  w.add_body(b);
  w.force_level(0, 0);
  w.step();
  ASSERT_EQ(w.level_info(0, 1).stepped_tets, 0u);
  ASSERT_EQ(w.level_info(0, 2).stepped_tets, 0u);
  // (x, y, z) -> (-y, x, z) turns: a quarter for quarter == 1, a half for 2 (rigid, at rest: no force).
  auto turned = [](const Level<double>& L, std::size_t n, int k, int quarters) {
    const double x = L.X[0][n], y = L.X[1][n];
    if (k == 2) return L.X[2][n];
    if (quarters == 1) return k == 0 ? -y : x;
    return k == 0 ? -x : -y;
  };
  auto turn = [&](int level, int quarters) {
    Level<double>& L = w.level<double>(0, level);
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int k = 0; k < 3; ++k) L.x[k][n] = turned(L, n, k, quarters);
  };
  auto worst_off = [&](int level, int quarters) {
    const Level<double>& L = w.level<double>(0, level);
    double worst = 0;
    for (std::size_t n = 0; n < L.node_count; ++n)
      if (L.state[n] == kNodeFree)
        for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(L.x[k][n] - turned(L, n, k, quarters)));
    return worst;
  };
  // Decisions fall on ticks where every level ends its window (the coarsest steps every few ticks).
  auto step_until_only = [&](int level) {
    for (int i = 0; i < 32 && w.level_info(0, level).stepped_tets != w.level_info(0, 0).stepped_tets +
                                                                          w.level_info(0, 1).stepped_tets +
                                                                          w.level_info(0, 2).stepped_tets;
         ++i)
      w.step();
  };
  turn(0, 1);
  w.force_level(0, 2);
  step_until_only(2);
  ASSERT_EQ(w.level_info(0, 0).stepped_tets, 0u);
  ASSERT_EQ(w.level_info(0, 1).stepped_tets, 0u);
  const double split_off = worst_off(2, 1), split_energy = w.energies().elastic;
  turn(2, 2);
  w.force_level(0, 0);
  step_until_only(0);
  ASSERT_EQ(w.level_info(0, 1).stepped_tets, 0u);
  ASSERT_EQ(w.level_info(0, 2).stepped_tets, 0u);
  const double merge_off = worst_off(0, 2), merge_energy = w.energies().elastic;
  std::printf("coarsest -> finest: finest nodes within %.3g m of the turned block, elastic %.3g J; finest -> coarsest: "
              "%.3g m, %.3g J\n",
              split_off, split_energy, merge_off, merge_energy);
  EXPECT_LT(split_off, 1e-16);  // measured 2.8e-17 m (0.07 m: every finest node at rest, before)
  EXPECT_LT(split_energy, 5e-29);  // measured 8.7e-30 J
  EXPECT_LT(merge_off, 1e-16);  // measured 2.8e-17 m
  EXPECT_LT(merge_energy, 5e-29);  // measured 3.9e-30 J
}

TEST(Adaptivity, SplitsWhereTheBodyStrainsAndMergesWhenItCalms) {
  // A bar clamped at x = 0, its tip pushed 1.5 cm sideways and back: the strain near the clamp
  // passes 2% while it is bent, and the bar comes to rest after it is let go (damped).
  World w(no_gravity());
  w.add_body(pushed_bar(0.03, true));
  const std::size_t coarse_tets = w.level_info(0, 0).stepped_tets;
  std::size_t most_fine = 0;
  while (w.time() < 0.2) {
    w.step();
    most_fine = std::max(most_fine, w.level_info(0, 1).stepped_tets);
  }
  const World::AdaptStats bent = w.adapt_stats(0);
  while (w.time() < 1.0) w.step();
  const World::AdaptStats end = w.adapt_stats(0);
  std::printf("coarse tets at rest %zu; while bent: %lld splits, up to %zu fine tets stepped; by 1 s: %lld merges, %zu fine "
              "tets stepped\n",
              coarse_tets, static_cast<long long>(bent.splits), most_fine, static_cast<long long>(end.merges),
              w.level_info(0, 1).stepped_tets);
  EXPECT_GT(bent.splits, 0);
  EXPECT_GT(most_fine, 0u);
  EXPECT_GT(end.merges, 0);
  EXPECT_LT(w.level_info(0, 1).stepped_tets, most_fine);
  // The decision points are timed, applies included (summary.json check_us_mean; no speed asserted).
  EXPECT_GT(end.checks, 0);
  EXPECT_GT(end.check_seconds, 0.0);
  EXPECT_LE(end.apply_seconds, end.check_seconds);
  EXPECT_LE(end.check_max_seconds, end.check_seconds);
  EXPECT_GE(end.check_max_seconds * double(end.checks), end.check_seconds);
}

TEST(Adaptivity, ACapOfZeroMergesWhatIsSplitThenDecidesNothingUntilItIsLifted) {
  // The real-time controller's coarsest rung (World::set_adapt_cap(body, 0)): what is split merges
  // at the next decision, and while the cap holds and nothing is split a decision skips its measure
  // (nothing could change). Lifted while the bar is still bent, the decisions split again.
  World w(no_gravity());
  w.add_body(pushed_bar(0.03, true));
  while (w.time() < 0.1) w.step();
  const World::AdaptStats bent = w.adapt_stats(0);
  ASSERT_GT(bent.splits, 0);
  ASSERT_GT(w.level_info(0, 1).stepped_tets, 0u);
  w.set_adapt_cap(0, 0);
  EXPECT_EQ(w.adapt_cap(0), 0);
  while (w.time() < 0.2) w.step();
  const World::AdaptStats capped = w.adapt_stats(0);
  EXPECT_EQ(w.level_info(0, 1).stepped_tets, 0u);  // every split node merged
  EXPECT_GT(capped.merges, bent.merges);
  EXPECT_EQ(capped.splits, bent.splits);           // none while capped, though the bar is bent
  EXPECT_GT(capped.checks, bent.checks + 10);      // the decision points go on (every 2 ms)
  w.set_adapt_cap(0, w.level_count(0) - 1);
  while (w.time() < 0.25) w.step();
  EXPECT_GT(w.adapt_stats(0).splits, capped.splits);
  EXPECT_GT(w.level_info(0, 1).stepped_tets, 0u);
}

// The bar above pushed 3 cm and held, in 3 levels, alone in a world without gravity.
void add_three_level_bar(World& w) {
  BodyDef b = pushed_bar(0.03, false);
  b.multiresolution.levels = 3;
  w.add_body(b);
  ASSERT_EQ(w.level_count(0), 3);
}

TEST(Adaptivity, ACapOfOneKeepsAThreeLevelBodyOffItsFinestLevelUntilLifted) {
  // Capped at its middle level, a bent 3-level bar splits its coarsest nodes but none of its middle
  // ones (their measure is not even taken); lifted, the middle nodes split too.
  World w(no_gravity());
  add_three_level_bar(w);
  w.set_adapt_cap(0, 1);
  while (w.time() < 0.1) w.step();
  EXPECT_GT(w.level_info(0, 1).stepped_tets, 0u);
  EXPECT_EQ(w.level_info(0, 2).stepped_tets, 0u);
  w.set_adapt_cap(0, 2);
  while (w.time() < 0.15) w.step();
  EXPECT_GT(w.level_info(0, 2).stepped_tets, 0u);
}

// The largest distance (m) from a ghost's own position to where its sources are, over the body's
// levels.
double worst_ghost_offset(const World& w) {
  double worst = 0;
  for (int l = 0; l < w.level_count(0); ++l) {
    const Level<double>& L = w.level<double>(0, l);
    for (std::size_t g = 0; g < L.ghosts.size(); ++g) {
      double x[3] = {0, 0, 0}, d2 = 0;
      for (auto e = L.ghost_offsets[g]; e < L.ghost_offsets[g + 1]; ++e) {
        const Level<double>& S = w.level<double>(0, L.ghost_source_level[std::size_t(e)]);
        for (int k = 0; k < 3; ++k) x[k] += L.ghost_weight[std::size_t(e)] * S.x[k][std::size_t(L.ghost_source_node[std::size_t(e)])];
      }
      for (int k = 0; k < 3; ++k) d2 += (x[k] - L.x[k][std::size_t(L.ghosts[g])]) * (x[k] - L.x[k][std::size_t(L.ghosts[g])]);
      worst = std::max(worst, std::sqrt(d2));
    }
  }
  return worst;
}

TEST(Adaptivity, NewGhostsStandWhereTheirSourcesAreWhenTheMonitorMeasures) {
  // A 3-level bar bent 3 cm while capped at its middle level: its finest nodes, inactive, keep
  // their positions at rest. Lifted, the finest level splits in; its new ghosts took their place
  // from their sources only at the next window's start, but the deformation monitor measures the
  // stepped tets at the start of the next step, before it: on the 50k-tet organ lifted to its
  // finest level, 68 new ghosts up to 7.9 mm off (its fine tets are 4.3 mm) made a fine tet look
  // 140 times stiffer, and the steps were cut into 15 sub-steps for 3 ms (frames of 5-7 ms,
  // 2026-11-28). A change now puts every ghost of the body where its sources are.
  World w(no_gravity());
  add_three_level_bar(w);
  ASSERT_EQ(w.precision(), Precision::float64);
  w.set_adapt_cap(0, 1);
  while (w.time() < 0.1) w.step();
  ASSERT_EQ(w.level_info(0, 2).stepped_tets, 0u);
  w.set_adapt_cap(0, 2);
  std::int64_t changes = w.adapt_stats(0).changes;
  double worst = 0;
  int measured = 0;
  while (w.time() < 0.15) {  // right after each change, before the next step
    w.step();
    if (w.adapt_stats(0).changes == changes) continue;
    changes = w.adapt_stats(0).changes;
    worst = std::max(worst, worst_ghost_offset(w));
    ++measured;
  }
  ASSERT_GT(w.level_info(0, 2).stepped_tets, 0u);
  std::printf("after %d changes: ghosts at most %.3g m off their sources\n", measured, worst);
  EXPECT_GT(measured, 0);
  EXPECT_LT(worst, 1e-12);  // measured 0 (the same sums as the engine's); before, 0.019 m
}

TEST(Adaptivity, TheDeformationMonitorChecksAsOftenAsTheFinestSteppedLevelMoves) {
  // World's deformation monitor (TimeStepDef::adapt) measures the stepped tets every 1 to 16 steps.
  // A 3-level bar capped at its coarsest level moves only once per window of that level: it is
  // measured every 16 of those windows, not every 16 fine steps (then 12% of the 50k-tet organ's
  // stepping on its coarser levels, for positions that had not moved). Lifted, the finest level
  // steps again and the checks come within 16 fine steps at once, not at the end of the long
  // interval already planned.
  World w(no_gravity());
  add_three_level_bar(w);
  w.set_adapt_cap(0, 0);
  for (int i = 0; i < 200; ++i) w.step();  // the first checks come every 1, 2, 4 ... steps
  ASSERT_EQ(w.level_info(0, 1).stepped_tets, 0u);
  ASSERT_EQ(w.level_info(0, 2).stepped_tets, 0u);
  const int coarse = w.level_info(0, 0).period;
  ASSERT_GE(coarse, 2);  // fine ticks per coarse step (one sub-step per step here)
  ASSERT_EQ(w.substeps(), 1);
  const std::int64_t steps = 64 * 16 * coarse, before = w.stiffness_checks();
  for (std::int64_t i = 0; i < steps; ++i) w.step();
  const std::int64_t capped = w.stiffness_checks() - before;
  EXPECT_LE(capped, steps / (16 * coarse) + 1) << "period " << coarse;  // 64 (at every 16 fine steps: 64 x period)
  EXPECT_GE(capped, steps / (16 * coarse) - 1) << "period " << coarse;

  // Lifted right after a check, and every node split at once: from the step where the finest level
  // steps again, no 16 steps in a row go without a check (the interval planned while capped was
  // 16 coarse windows, 32 fine steps here).
  for (std::int64_t c = w.stiffness_checks(); w.stiffness_checks() == c;) w.step();
  w.set_adapt_cap(0, 2);
  w.force_level(0, 2);
  std::int64_t last_check = w.steps(), checks = w.stiffness_checks(), longest = 0;
  bool fine = false;
  for (int i = 0; i < 400; ++i) {
    w.step();
    if (w.stiffness_checks() > checks) {
      checks = w.stiffness_checks();
      last_check = w.steps();
    }
    if (!fine && w.level_info(0, 2).stepped_tets > 0) {
      fine = true;
      last_check = std::max(last_check, w.steps() - 1);  // counted from its first step
    }
    if (fine) longest = std::max(longest, w.steps() - last_check);
  }
  ASSERT_TRUE(fine) << "the finest level never stepped";
  EXPECT_LE(longest, 16);
}

TEST(Adaptivity, ASplitBudgetSpreadsARegionsSplitsOverDecisions) {
  // The bent bar of the test above, unlimited and with at most one split per decision
  // (World::set_adapt_split_budget, which the real-time controller sets to 2): unlimited, some
  // decision splits several nodes at once; with the budget, no decision splits more than one, and
  // the region still refines, over more decisions.
  World free_w(no_gravity()), budget_w(no_gravity());
  free_w.add_body(pushed_bar(0.03, true));
  budget_w.add_body(pushed_bar(0.03, true));
  EXPECT_EQ(budget_w.adapt_split_budget(0), std::numeric_limits<int>::max());
  budget_w.set_adapt_split_budget(0, 1);
  EXPECT_EQ(budget_w.adapt_split_budget(0), 1);
  std::int64_t most_free = 0, most_budget = 0;
  std::size_t fine_budget = 0;
  World::AdaptStats a = free_w.adapt_stats(0), b = budget_w.adapt_stats(0);
  while (free_w.time() < 0.2) {
    free_w.step();
    budget_w.step();
    const World::AdaptStats a2 = free_w.adapt_stats(0), b2 = budget_w.adapt_stats(0);
    ASSERT_LE(a2.checks - a.checks, 1) << "one decision point per step here";
    ASSERT_LE(b2.checks - b.checks, 1);
    // The splits that refine more (not those keeping a refined region, which no budget limits).
    most_free = std::max(most_free, (a2.splits - a2.keeping_splits) - (a.splits - a.keeping_splits));
    most_budget = std::max(most_budget, (b2.splits - b2.keeping_splits) - (b.splits - b.keeping_splits));
    fine_budget = std::max(fine_budget, budget_w.level_info(0, 1).stepped_tets);
    a = a2;
    b = b2;
  }
  std::printf("most refining splits in one decision: %lld unlimited, %lld with a budget of 1; %lld and %lld splits by 0.2 s "
              "(%lld and %lld keeping refined regions); up to %zu fine tets stepped with the budget\n",
              static_cast<long long>(most_free), static_cast<long long>(most_budget), static_cast<long long>(a.splits),
              static_cast<long long>(b.splits), static_cast<long long>(a.keeping_splits),
              static_cast<long long>(b.keeping_splits), fine_budget);
  EXPECT_GT(most_free, 1);
  EXPECT_EQ(most_budget, 1);
  EXPECT_GT(b.splits, 1);
  EXPECT_GT(fine_budget, 0u);
  try {
    budget_w.set_adapt_split_budget(0, 0);
    ADD_FAILURE() << "a budget of 0 was accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("set_adapt_split_budget"));
  }
}

TEST(Adaptivity, AChangeIntervalHoldsTheNextDecisionBack) {
  // The bent bar of the tests above, with its changes at most 10 ms apart (World::
  // set_adapt_change_interval; the real-time controller sets one frame): without the interval it
  // changes at decision points closer than that; with it, never, and it still refines. The same
  // bits on 1 and 2 threads (the decision points are fixed ticks).
  constexpr double kInterval = 0.01;  // s: several of the bar's decision points
  auto change_times = [&](double interval, int threads, std::uint64_t* hash) {
    World w(no_gravity(threads));
    w.add_body(pushed_bar(0.03, true));
    EXPECT_EQ(w.adapt_change_interval(0), 0.0);
    if (interval > 0) w.set_adapt_change_interval(0, interval);
    EXPECT_EQ(w.adapt_change_interval(0), interval);
    std::vector<double> times;
    std::int64_t changes = 0;
    while (w.time() < 0.4) {
      w.step();
      if (w.adapt_stats(0).changes > changes) {
        changes = w.adapt_stats(0).changes;
        times.push_back(w.time());
      }
    }
    EXPECT_GT(w.adapt_stats(0).splits, 0);
    if (hash) *hash = w.state_hash();
    return times;
  };
  auto closest = [](const std::vector<double>& t) {
    double gap = std::numeric_limits<double>::infinity();
    for (std::size_t i = 1; i < t.size(); ++i) gap = std::min(gap, t[i] - t[i - 1]);
    return gap;
  };
  std::uint64_t one = 0, two = 0;
  const std::vector<double> free_times = change_times(0, 1, nullptr), held = change_times(kInterval, 1, &one);
  change_times(kInterval, 2, &two);
  std::printf("%zu changes without the interval (closest %.4g s apart), %zu with it (closest %.4g s)\n", free_times.size(),
              closest(free_times), held.size(), closest(held));
  ASSERT_GE(free_times.size(), 3u);
  EXPECT_LT(closest(free_times), kInterval);
  ASSERT_GE(held.size(), 2u);
  EXPECT_GE(closest(held), kInterval - 1e-9);
  EXPECT_EQ(one, two);
  World w(no_gravity());
  w.add_body(pushed_bar(0.03, true));
  for (const double bad : {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    try {
      w.set_adapt_change_interval(0, bad);
      ADD_FAILURE() << "an interval of " << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr("set_adapt_change_interval"));
    }
  }
}

TEST(Adaptivity, TheNextDecisionComesAtTheFirstAlignedTickFromItsAnnouncedTime) {
  // World::adapt_next_decision, which the real-time runner reads to start a frame early: no
  // decision point comes before the time it announced before the step, and each comes within one
  // step of the coarsest level after it (the first tick from then on where every level's window
  // ends). The bent bar of the tests above, with and without a change interval; a lowered cap
  // brings the next decision to the next such tick. A body that is not adaptive never decides.
  for (const double interval : {0.0, 0.01}) {
    World w(no_gravity());
    w.add_body(pushed_bar(0.03, true));
    if (interval > 0) w.set_adapt_change_interval(0, interval);
    const double coarse_step = w.level_info(0, 0).dt;
    std::int64_t checks = 0, changes = 0;
    double latest = 0;  // s: the most a decision point came after its announced time (or after the step began)
    while (w.time() < 0.3) {
      const double announced = w.adapt_next_decision(0), began = w.time();
      w.step();
      if (w.adapt_stats(0).checks == checks) {
        EXPECT_LT(w.time() + 1e-12, std::max(announced, began) + coarse_step) << "no decision point at t = " << w.time();
        continue;
      }
      checks = w.adapt_stats(0).checks;
      EXPECT_GE(w.time() + 1e-12, announced) << "a decision point before its announced time, t = " << w.time();
      latest = std::max(latest, w.time() - std::max(announced, began));
      if (w.adapt_stats(0).changes > changes) {
        changes = w.adapt_stats(0).changes;
        EXPECT_GE(w.adapt_next_decision(0) + 1e-12, w.time() + interval);
      }
    }
    std::printf("change interval %g s: %lld decision points, %lld changes; the latest came %.3g s after its announced time "
                "(coarsest step %.3g s)\n",
                interval, static_cast<long long>(checks), static_cast<long long>(changes), latest, coarse_step);
    EXPECT_GT(checks, 10);
    EXPECT_GT(changes, 1);
    // A lowered cap: at the next tick where every window ends, unless a change interval holds it.
    const double before = w.adapt_next_decision(0);
    w.set_adapt_cap(0, 0);
    EXPECT_LE(w.adapt_next_decision(0), before);
    EXPECT_LE(w.adapt_next_decision(0), std::max(w.time(), interval > 0 ? w.time() + interval : 0.0));
  }
  World fixed(no_gravity());
  BodyDef all_fine = pushed_bar(0.03, true);
  all_fine.multiresolution.active.kind = ActiveDef::Kind::finest;
  fixed.add_body(all_fine);
  EXPECT_EQ(fixed.adapt_next_decision(0), std::numeric_limits<double>::infinity());
}

TEST(Adaptivity, ATouchingToolRefinesAroundItAndItsRegionCoarsensWhenItLeaves) {
  // refine_near only: no strain splits (threshold out of reach), and merges as soon as allowed.
  World w(no_gravity());
  BodyDef b = clamped_slab();
  AdaptDef& a = b.multiresolution.active.adapt;
  a.refine_above = 1e9;
  a.coarsen_below = 1e8;
  a.min_dwell = 0.01;
  a.refine_near = 0.02;
  w.add_body(b);
  ToolDef t;
  t.shape.radius = 0.01;
  // Over the slab's top near x = 0.05, down onto it, then away.
  t.keyframes = {{0.0, {0.05, 0.05, 0.1}}, {0.1, {0.05, 0.05, 0.05}}, {0.2, {0.05, 0.05, 0.05}}, {0.3, {0.05, 0.05, 0.2}}};
  w.add_tool(t);
  const std::size_t all_fine = w.tet_count(0, 1);
  std::size_t most = 0;
  while (w.time() < 0.2) {
    w.step();
    most = std::max(most, w.level_info(0, 1).stepped_tets);
  }
  // Only the region around the tool is fine, and it is: the fine level steps there.
  EXPECT_GT(most, 0u);
  EXPECT_LT(most, all_fine / 2);
  while (w.time() < 0.5) w.step();
  std::printf("near the tool: up to %zu of %zu fine tets stepped; after it left: %zu (%lld splits, %lld merges)\n", most,
              all_fine, w.level_info(0, 1).stepped_tets, static_cast<long long>(w.adapt_stats(0).splits),
              static_cast<long long>(w.adapt_stats(0).merges));
  EXPECT_EQ(w.level_info(0, 1).stepped_tets, 0u);
}

TEST(Adaptivity, AToolOnATriangleItCannotPushRefinesThereWhateverRefineNear) {
  // A bar clamped at x = 0, on its coarsest level (cells 5 cm), refine_near 0 and strain
  // thresholds out of reach: nothing refines by distance or strain. A sphere presses its top 3 cm
  // from the clamped end, 8 mm deep, on a coarse triangle whose point lies near fixed corners:
  // moving only the free corners would fling them (kMaxCornerPush), so the response leaves it
  // alone. Before 2026-11-28 the tool then sank through it unfelt (a stress scene: 19 mm, then
  // 3.3x its energy budget when a split put a finer surface inside the tool); now the contact
  // refines there, and the finer surface, free under the tool, holds it. Measured: 2 splits, 72
  // fine tets stepped, 0.125 mm deepest, 0.025 mm at the end, 14.7 N (before: no split, 8 mm
  // deep, 0 N).
  World w(no_gravity());
  BodyDef b = block();
  b.mesh.max = {0.2, 0.05, 0.05};
  b.mesh.cells = {8, 2, 2};
  clamp_end(b);
  AdaptDef& a = b.multiresolution.active.adapt;
  a.refine_above = 1e9;
  a.coarsen_below = 1e8;
  a.refine_near = 0;
  w.add_body(b);
  ToolDef t;
  t.shape.radius = 0.01;
  t.keyframes = {{0.0, {0.03, 0.02, 0.062}}, {0.1, {0.03, 0.02, 0.052}}, {0.2, {0.03, 0.02, 0.052}}};
  w.add_tool(t);
  double deepest = 0;
  int touching = 0;
  while (w.time() < 0.2) {
    w.step();
    const ToolReading r = w.tool_reading(0);
    deepest = std::max(deepest, r.max_penetration);
    touching += r.contacts > 0;
  }
  const ToolReading r = w.tool_reading(0);
  std::printf("tool on a triangle by the clamp: %d steps touching, %lld splits, %zu fine tets stepped, deepest %.3g mm, "
              "%.3g mm at the end, force %.3g N\n",
              touching, static_cast<long long>(w.adapt_stats(0).splits), w.level_info(0, 1).stepped_tets, 1e3 * deepest,
              1e3 * r.max_penetration, r.force[2]);
  EXPECT_GT(touching, 100);
  EXPECT_GT(w.adapt_stats(0).splits, 0);
  EXPECT_GT(w.level_info(0, 1).stepped_tets, 0u);
  EXPECT_LT(deepest, 0.3e-3);           // m
  EXPECT_LT(r.max_penetration, 0.1e-3);  // m
  EXPECT_GT(r.force[2], 5);              // N
}

// The bar of SplitsWhereTheBodyStrainsAndMergesWhenItCalms (linear elasticity: its field scales with
// the push), pushed `amplitude` m sideways; the splits by 0.15 s, nothing refined by distance.
std::int64_t bar_splits(double amplitude, AdaptDef::Measure measure, double refine_above) {
  World w(no_gravity());
  BodyDef b = pushed_bar(amplitude, false);
  b.model = ForceModel::linear;
  AdaptDef& a = b.multiresolution.active.adapt;
  a.measure = measure;
  a.refine_above = refine_above;
  a.coarsen_below = refine_above / 5;
  a.refine_near = 0;
  w.add_body(b);
  while (w.time() < 0.15) w.step();
  return w.adapt_stats(0).splits;
}

TEST(Adaptivity, RelativeThresholdsDecideAlikeForAPushTenTimesSmaller) {
  // Relative (the default): thresholds are fractions of the body's peak strain, so the same shape
  // of deformation at a tenth of the amplitude splits the same nodes. Absolute: a 2% strain jump
  // is reached by the large push only.
  const std::int64_t large = bar_splits(0.03, AdaptDef::Measure::relative, 0.5);
  const std::int64_t small = bar_splits(0.003, AdaptDef::Measure::relative, 0.5);
  std::printf("relative 0.5: %lld splits (3 cm push), %lld (3 mm)\n", static_cast<long long>(large), static_cast<long long>(small));
  EXPECT_GT(large, 0);
  // Alike, not equal: the peak is a Green-Lagrange strain, which the bar's rotation raises more at
  // the larger push (measured 25 against 29 splits).
  EXPECT_NEAR(double(small), double(large), 0.2 * double(large));
  const std::int64_t large_abs = bar_splits(0.03, AdaptDef::Measure::absolute, 0.02);
  const std::int64_t small_abs = bar_splits(0.003, AdaptDef::Measure::absolute, 0.02);
  std::printf("absolute 0.02: %lld splits (3 cm push), %lld (3 mm)\n", static_cast<long long>(large_abs), static_cast<long long>(small_abs));
  EXPECT_GT(large_abs, 0);
  EXPECT_EQ(small_abs, 0);
}

// A 20 x 10 x 4 cm slab clamped at its base, strain thresholds out of reach: only distance refines.
// Returns the fine tets stepped after 0.05 s.
std::size_t fine_tets_near(bool motion, bool probe, bool probe_refines, double refine_near) {
  World w(no_gravity());
  BodyDef b = clamped_slab();
  if (motion) {  // the top of the slab's x = 0 end pushed 5 mm down
    PrescribedMotionDef push;
    push.region.min = {-1, -1, 0.04 - 1e-9};
    push.region.max = {0.02 + 1e-9, 1, 1};
    push.keyframes = {{0.0, {0, 0, 0}}, {0.05, {0, 0, -0.005}}};
    b.prescribed.push_back(push);
  }
  AdaptDef& a = b.multiresolution.active.adapt;
  a.refine_above = 1e9;
  a.coarsen_below = 1e8;
  a.refine_near = refine_near;
  w.add_body(b);
  if (probe) {
    ProbeDef p;
    p.name = "middle";
    p.body = "block";
    p.point = {0.15, 0.05, 0.03};
    p.refine = probe_refines;
    w.add_probe(p);
  }
  while (w.time() < 0.05) w.step();
  return w.level_info(0, 1).stepped_tets;
}

TEST(Adaptivity, PrescribedMotionsAndRefiningProbesKeepTheirSurroundingsFine) {
  const std::size_t all_fine = 10 * 6 * 2 * 6;
  const std::size_t by_motion = fine_tets_near(true, false, false, -1);
  const std::size_t by_probe = fine_tets_near(false, true, true, -1);
  std::printf("fine tets stepped of %zu: %zu around the prescribed motion, %zu around the probe (auto reach)\n", all_fine,
              by_motion, by_probe);
  EXPECT_GT(by_motion, 0u);
  EXPECT_LT(by_motion, all_fine / 2);
  EXPECT_GT(by_probe, 0u);
  EXPECT_LT(by_probe, all_fine / 2);
  EXPECT_EQ(fine_tets_near(true, false, false, 0), 0u);    // refine_near 0: distance refines nothing
  EXPECT_EQ(fine_tets_near(false, true, false, -1), 0u);   // a probe refines only when it asks
  EXPECT_GT(fine_tets_near(true, false, false, 0.1), by_motion);  // a longer reach refines more
}

// A slab twice as long as clamped_slab (grid rows of 41 fine nodes, most of them far from the
// push), one corner pushed 5 mm down over 50 ms with adaptivity's thresholds out of reach, so that
// only the push refines (by distance): its fine level steps a region around the corner. Added to
// w and run to the end of the push.
void push_a_long_slab_corner(World& w) {
  BodyDef b = clamped_slab();
  b.mesh.max[0] = 0.4;
  b.mesh.cells[0] = 20;
  PrescribedMotionDef push;
  push.region.min = {-1, -1, 0.04 - 1e-9};
  push.region.max = {0.02 + 1e-9, 1, 1};
  push.keyframes = {{0.0, {0, 0, 0}}, {0.05, {0, 0, -0.005}}};
  b.prescribed.push_back(push);
  b.multiresolution.active.adapt.refine_above = 1e9;
  b.multiresolution.active.adapt.coarsen_below = 1e8;
  w.add_body(b);
  while (w.time() < 0.05) w.step();
}

TEST(Adaptivity, TheNodePassesRunOverTheSimulatedNodesOnly) {
  // A slab's corner pushed: its fine level simulates the nodes around the push. Gathers,
  // integration and obstacles run over those (and gaps of at most 8 inactive nodes between them),
  // not the whole level: a 49k-tet organ stepping 86 fine tets near its tool gathered all 10k fine
  // nodes every tick, as much time as its tets took (docs/adaptivity.md, the guaranteed rate).
  World w(no_gravity());
  push_a_long_slab_corner(w);
  const LevelInfo fine = w.level_info(0, 1), coarse = w.level_info(0, 0);
  std::printf("fine level: %zu nodes, %zu simulated (%zu free or fixed, %zu ghosts), node passes over %zu; coarse: %zu of %zu\n",
              fine.nodes, fine.active_nodes + fine.ghost_nodes, fine.active_nodes, fine.ghost_nodes, fine.pass_nodes,
              coarse.pass_nodes, coarse.nodes);
  ASSERT_GT(fine.stepped_tets, 0u);
  // Its stepped tets lie in short runs (rows of the slab near the push): a list fills the lanes.
  EXPECT_TRUE(fine.listed);
  EXPECT_GE(fine.pass_nodes, fine.active_nodes + fine.ghost_nodes);
  EXPECT_LT(fine.pass_nodes, fine.nodes / 2);
  EXPECT_LE(coarse.pass_nodes, coarse.nodes);
  // A body of one level: every node, one run.
  World single(no_gravity());
  BodyDef s = clamped_slab();
  s.multiresolution = {};
  single.add_body(s);
  single.step();
  EXPECT_EQ(single.level_info(0, 0).pass_nodes, single.level_info(0, 0).nodes);
  EXPECT_FALSE(single.level_info(0, 0).listed);
}

TEST(Adaptivity, AListedLevelGathersItsSteppedTetsOnly) {
  // The slab of the test above: its fine level steps a region near the push, from a list. Its
  // gather sums the corner forces of its stepped tets only (their 4 corners each, all of them
  // simulated nodes), not of every tet around its nodes, and gives the bits of a gather over
  // every tet around them (the others' corner forces are zero: a sum that starts at +0 does not
  // change by adding a zero).
  World w(no_gravity());
  push_a_long_slab_corner(w);
  const LevelInfo fine = w.level_info(0, 1);
  ASSERT_TRUE(fine.listed);
  ASSERT_GT(fine.stepped_tets, 0u);
  EXPECT_EQ(fine.gather_entries, 4 * fine.stepped_tets);
  // The finest level's window ends on every tick: its corner forces are the ones its last gather
  // summed (kept by the step in list order: World::corner_forces reads them by tet).
  const Level<double>& L = w.level<double>(0, 1);
  std::size_t every_tet_around = 0, checked = 0, nonzero_tets = 0;
  for (std::size_t t = 0; t < L.tet_count; ++t) {
    const auto cf = w.corner_forces(0, 1, t);
    bool any = false;
    for (const auto& c : cf) any |= c[0] != 0 || c[1] != 0 || c[2] != 0;
    nonzero_tets += any;
  }
  EXPECT_GT(nonzero_tets, fine.stepped_tets / 2);  // stepped tets carry forces; the others none
  EXPECT_LE(nonzero_tets, fine.stepped_tets);
  for (std::size_t n = 0; n < L.node_count; ++n) {
    if (L.state[n] == kNodeInactive) continue;
    double f[3] = {0, 0, 0};
    for (auto e = L.incidence_offsets[n]; e < L.incidence_offsets[n + 1]; ++e) {
      const std::int32_t code = L.incidence[std::size_t(e)];
      const auto cf = w.corner_forces(0, 1, std::size_t(code >> 2));
      for (int k = 0; k < 3; ++k) f[k] += double(cf[std::size_t(code & 3)][std::size_t(k)]);
    }
    every_tet_around += std::size_t(L.incidence_offsets[n + 1] - L.incidence_offsets[n]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(std::memcmp(&f[k], &L.f[k][n], sizeof(double)), 0) << "node " << n << ", component " << k;
    ++checked;
  }
  EXPECT_GT(checked, 0u);
  std::printf("fine level: %zu stepped tets, gather entries %zu, every tet around its simulated nodes %zu\n",
              fine.stepped_tets, fine.gather_entries, every_tet_around);
  EXPECT_GT(every_tet_around, fine.gather_entries);  // what the gather read before (and the gaps' tets)
}

std::uint64_t adaptive_hash(int threads) {
  World w(no_gravity(threads));
  w.add_body(block());
  stretch_and_drift(w);
  bool listed = false;  // a level stepped from a list (kernels: the bits of the range passes)
  for (int i = 0; i < 200; ++i) {
    if (i == 50) w.force_level(0, 1);
    if (i == 120) w.force_level(0, 0);
    w.step();
    for (int l = 0; l < w.level_count(0); ++l) listed |= w.level_info(0, l).listed;
  }
  EXPECT_TRUE(listed);
  return w.state_hash();
}

// A 40 x 10 x 4 cm slab of 3 levels, adaptive at its defaults, its corner pushed 6 mm down: its
// coarser levels come to step a region from a list (a level of period > 1 with a few batches).
BodyDef pushed_three_level_slab() {
  BodyDef b = clamped_slab();
  b.mesh.max[0] = 0.4;
  b.mesh.cells = {24, 8, 4};
  b.multiresolution.levels = 3;
  PrescribedMotionDef push;
  push.region.min = {-1, -1, 0.04 - 1e-9};
  push.region.max = {0.03 + 1e-9, 1, 1};
  push.keyframes = {{0.0, {0, 0, 0}}, {0.02, {0, 0, -0.006}}};
  b.prescribed.push_back(push);
  return b;
}

// The slab above stepped for 30 ms with the given schedule; `listed_coarse` is set when a level of
// period > 1 was stepped from a list.
std::uint64_t pushed_slab_hash(Schedule schedule, int threads, bool& listed_coarse) {
  WorldDef wd = no_gravity(threads);
  wd.schedule = schedule;
  World w(wd);
  w.add_body(pushed_three_level_slab());
  listed_coarse = false;
  while (w.time() < 0.03) {
    w.step();
    for (int l = 0; l < w.level_count(0); ++l) {
      const LevelInfo i = w.level_info(0, l);
      listed_coarse |= i.listed && i.period > 1 && i.stepped_tets >= 2 * std::size_t(i.period) * 16;
    }
  }
  return w.state_hash();
}

TEST(Adaptivity, ABodyAddedInTheMiddleOfAListedLevelsWindowLosesNothing) {
  // The slab of the test below, and a second body added between two steps while its listed level
  // of period > 1 is in the middle of a window: the step is prepared again then, and the slices
  // the level computed before (its corner forces, kept by list position) must reach the gather at
  // the window's end, as they do when nothing computes before that end (naive).
  std::uint64_t hash[2] = {0, 0};
  int period = 0;
  for (Schedule schedule : {Schedule::naive, Schedule::staggered}) {
    WorldDef wd = no_gravity(1);
    wd.schedule = schedule;
    World w(wd);
    w.add_body(pushed_three_level_slab());
    // Step until a listed level of period > 1 has a few batches per tick, then until it is one tick
    // into a window (steps counted from 0).
    int listed_level = -1;
    while (listed_level < 0 && w.time() < 0.05) {
      w.step();
      for (int l = 0; l < w.level_count(0); ++l) {
        const LevelInfo i = w.level_info(0, l);
        if (i.listed && i.period > 1 && i.stepped_tets >= 2 * std::size_t(i.period) * 16) listed_level = l;
      }
    }
    ASSERT_GE(listed_level, 0);
    period = w.level_info(0, listed_level).period;
    while (w.steps() % period != 1) w.step();
    const double dt = w.dt();
    BodyDef other = block();  // far away, soft: its stable step is longer than the slab's
    other.name = "other";
    other.multiresolution = {};
    other.material.young = 1e3;
    for (auto& x : other.mesh.min) x += 5;
    for (auto& x : other.mesh.max) x += 5;
    w.add_body(other);
    ASSERT_EQ(w.dt(), dt);  // the tick, and so the windows, go on
    for (int i = 0; i < 3 * period; ++i) w.step();
    hash[schedule == Schedule::staggered] = w.state_hash();
  }
  EXPECT_EQ(hash[1], hash[0]) << "period " << period;
}

TEST(Adaptivity, ListedLevelsSlicedInWholeBatchesGiveTheNaiveBits) {
  // A listed level of period p > 1 computes its tets in slices of whole 16-lane batches over the
  // ticks of its window (LevelJob::align): which tick computes a tet must not change its forces,
  // so the staggered schedule gives the naive one's bits, for any thread count.
  bool listed = false;
  const std::uint64_t naive = pushed_slab_hash(Schedule::naive, 1, listed);
  for (int threads : {1, 2}) {
    EXPECT_EQ(pushed_slab_hash(Schedule::staggered, threads, listed), naive) << threads << " thread(s)";
    EXPECT_TRUE(listed) << "no listed level of period > 1 with a few batches per tick";
  }
}

TEST(Adaptivity, SameBitsForOneTwoAndFourThreads) {
  const std::uint64_t h1 = adaptive_hash(1);
  EXPECT_EQ(adaptive_hash(2), h1);
  EXPECT_EQ(adaptive_hash(4), h1);
}

TEST(Adaptivity, SceneKeysAndTheirErrors) {
  const SceneDef s = parse_scene(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"refine_above": 0.05, "coarsen_below": 0.01, "min_dwell": 0.1, "check_every": 0.002}}}]})",
                                 "t.json", ".");
  const ActiveDef& a = s.bodies[0].multiresolution.active;
  EXPECT_EQ(a.kind, ActiveDef::Kind::adaptive);
  EXPECT_EQ(a.adapt.refine_above, 0.05);
  EXPECT_EQ(a.adapt.coarsen_below, 0.01);
  EXPECT_EQ(a.adapt.min_dwell, 0.1);
  EXPECT_EQ(a.adapt.check_every, 0.002);
  EXPECT_EQ(a.adapt.measure, AdaptDef::Measure::relative);
  EXPECT_EQ(a.adapt.refine_near, -1);  // "auto": one mean edge of each level
  const SceneDef s2 = parse_scene(R"({"bodies": [{"name": "b", "mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"measure": "absolute", "refine_near": 0.01}}}], "probes": [{"body": "b", "point": [0.5, 0.5, 0.5], "refine": true}]})",
                                  "t.json", ".");
  EXPECT_EQ(s2.bodies[0].multiresolution.active.adapt.measure, AdaptDef::Measure::absolute);
  EXPECT_EQ(s2.bodies[0].multiresolution.active.adapt.refine_near, 0.01);
  EXPECT_TRUE(s2.probes[0].refine);
  auto error = [](const std::string& json) {
    try {
      parse_scene(json, "t.json", ".");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 1, "active": "adaptive"}}]})"),
              HasSubstr("bodies[0].multiresolution.active: \"adaptive\" needs at least 2 levels"));
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "finest", "adapt": {}}}]})"),
              HasSubstr("bodies[0].multiresolution.adapt: only with"));
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"refine_above": 0.01, "coarsen_below": 0.02}}}]})"),
              HasSubstr("bodies[0].multiresolution.adapt.coarsen_below: must be below refine_above"));
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"refine": 0.01}}}]})"),
              HasSubstr("bodies[0].multiresolution.adapt.refine"));
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"measure": "strain"}}}]})"),
              HasSubstr("bodies[0].multiresolution.adapt.measure: expected \"relative\""));
  EXPECT_THAT(error(R"({"bodies": [{"mesh": {"box": {}}, "multiresolution": {"levels": 2, "active": "adaptive",
      "adapt": {"refine_near": "far"}}}]})"),
              HasSubstr("bodies[0].multiresolution.adapt.refine_near"));
  EXPECT_THAT(error(R"({"bodies": [{"name": "b", "mesh": {"box": {}}}], "probes": [{"body": "b", "point": [0, 0, 0], "refine": 1}]})"),
              HasSubstr("probes[0].refine: expected true or false"));
  World w;
  BodyDef b = block();
  b.multiresolution.active.adapt.coarsen_below = 1;
  EXPECT_THROW(w.add_body(b), InputError);
  World w2;
  w2.add_body(BodyDef{});
  EXPECT_THROW(w2.force_level(0, 0), InputError);
}

}  // namespace
}  // namespace pliant
