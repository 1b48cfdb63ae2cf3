// Stepping a multiresolution body (engine/src/core/simulation.cpp, docs/multiresolution.md):
// conservation (mass, linear and angular momentum), the patch test across level interfaces,
// energy over long undamped runs, determinism, and staggered = naive bit for bit. Box
// hierarchies with an even ratio and Kuhn cells nest exactly, so these hold to rounding.
#include <gtest/gtest.h>

#include <cmath>

#include "pliant/world.hpp"

namespace pliant {
namespace {

constexpr double kL = 0.8, kW = 0.2;  // m

// A 3-level bar: fine at x > 0.55, middle at x > 0.3 (before the split rule rounds them to
// whole coarse tets), coarse elsewhere.
BodyDef split_bar(ForceModel model = ForceModel::corotational, int levels = 3) {
  BodyDef b;
  b.name = "bar";
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {kL, kW, kW};
  b.mesh.cells = {16, 4, 4};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.poisson = 0.3;
  b.material.density = 1000;
  b.model = model;
  b.multiresolution.levels = levels;
  b.multiresolution.active.kind = ActiveDef::Kind::regions;
  ActiveRegionDef fine, middle;
  fine.level = levels - 1;
  fine.region.kind = RegionDef::Kind::box;
  fine.region.min = {0.65, -1, -1};
  fine.region.max = {2, 2, 2};
  middle = fine;
  middle.level = 1;
  middle.region.min = {0.45, -1, -1};
  b.multiresolution.active.regions = {fine, middle};
  return b;
}

WorldDef world_def(int threads = 1) {
  WorldDef w;
  w.gravity = {0, 0, 0};
  w.precision = Precision::float64;
  w.threads = threads;
  w.time_step.adapt = false;
  return w;
}

struct Momenta {
  double p[3] = {0, 0, 0}, l[3] = {0, 0, 0}, mass = 0;
};

// Linear and angular momentum of the nodes, plus the impulses received and not applied yet (at the
// positions they will be applied at).
Momenta momenta(const World& w, BodyId b) {
  Momenta m;
  for (int lv = 0; lv < w.level_count(b); ++lv) {
    const Level<double>& L = w.level<double>(b, lv);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      double q[3];
      for (int k = 0; k < 3; ++k) q[k] = L.mass[n] * L.v[k][n] + (L.impulse[k].empty() ? 0.0 : L.impulse[k][n]);
      const double x[3] = {L.x[0][n], L.x[1][n], L.x[2][n]};
      for (int k = 0; k < 3; ++k) m.p[k] += q[k];
      m.l[0] += x[1] * q[2] - x[2] * q[1];
      m.l[1] += x[2] * q[0] - x[0] * q[2];
      m.l[2] += x[0] * q[1] - x[1] * q[0];
      m.mass += L.mass[n];
    }
  }
  return m;
}

TEST(MultilevelStep, LevelsHaveTheirOwnPeriodsAndEveryLevelSteps) {
  World w(world_def());
  const BodyId b = w.add_body(split_bar());
  ASSERT_EQ(w.level_count(b), 3);
  EXPECT_EQ(w.level<double>(b, 2).period, 1);
  EXPECT_EQ(w.level<double>(b, 1).period, 2);
  EXPECT_EQ(w.level<double>(b, 0).period, 4);
  for (int l = 0; l < 3; ++l) {
    EXPECT_GT(w.level<double>(b, l).stepped_count, 0u) << l;
    EXPECT_LT(w.level<double>(b, l).stepped_count, w.tet_count(b, l)) << l;
  }
}

TEST(MultilevelStep, TotalMassIsDensityTimesVolume) {
  World w(world_def());
  const BodyId b = w.add_body(split_bar());
  EXPECT_NEAR(momenta(w, b).mass, 1000 * kL * kW * kW, 1e-13 * 1000 * kL * kW * kW);
}

// Patch test: every node of every level on an affine map of the rest state, the outer boundary
// held there; after one window of every level no free node has moved: no node, interface nodes
// included, feels a net force.
TEST(MultilevelStep, AffineStateIsInEquilibriumAcrossTheInterfaces) {
  for (ForceModel model : {ForceModel::linear, ForceModel::stvk, ForceModel::corotational}) {
    SCOPED_TRACE(to_string(model));
    BodyDef def = split_bar(model);
    for (int k = 0; k < 3; ++k) {  // the six faces held
      RegionDef lo, hi;
      lo.min = {-1, -1, -1};
      lo.max = {2, 2, 2};
      hi = lo;
      lo.max[k] = 0;
      hi.min[k] = k == 0 ? kL : kW;
      def.fixed.push_back(lo);
      def.fixed.push_back(hi);
    }
    World w(world_def());
    const BodyId b = w.add_body(def);
    const double A[3][3] = {{0.02, 0.01, -0.005}, {0.004, -0.01, 0.003}, {0.006, 0.002, 0.015}};
    for (int l = 0; l < 3; ++l) {
      Level<double>& L = w.level<double>(b, l);
      for (std::size_t n = 0; n < L.node_count; ++n)
        for (int i = 0; i < 3; ++i)
          L.x[i][n] = L.X[i][n] + A[i][0] * L.X[0][n] + A[i][1] * L.X[1][n] + A[i][2] * L.X[2][n];
    }
    for (int t = 0; t < 4; ++t) w.step();
    double vmax = 0;
    std::size_t free_nodes = 0;
    for (int l = 0; l < 3; ++l) {
      const Level<double>& L = w.level<double>(b, l);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        if (L.state[n] != kNodeFree) continue;
        ++free_nodes;
        for (int k = 0; k < 3; ++k) vmax = std::max(vmax, std::abs(L.v[k][n]));
      }
    }
    EXPECT_GT(free_nodes, 20u);
    // The strain's force on one node would give |v| ~ 1e-2 m/s after these steps; measured 1e-15.
    EXPECT_LT(vmax, 1e-12);
  }
}

// A free body, spinning and vibrating: linear and angular momentum stay put over 10^4 fine steps.
TEST(MultilevelStep, FreeBodyConservesMomentum) {
  for (ForceModel model : {ForceModel::stvk, ForceModel::corotational}) {
    SCOPED_TRACE(to_string(model));
    World w(world_def());
    const BodyId b = w.add_body(split_bar(model));
    for (int l = 0; l < 3; ++l) {
      Level<double>& L = w.level<double>(b, l);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        const double x = L.X[0][n] - kL / 2, y = L.X[1][n] - kW / 2, z = L.X[2][n] - kW / 2;
        L.v[0][n] = 0.3 - 2.0 * y + 0.5 * x;   // translation + spin about z + stretch
        L.v[1][n] = 0.1 + 2.0 * x;
        L.v[2][n] = -0.2 + 1.0 * x * x;
        (void)z;
      }
    }
    const Momenta m0 = momenta(w, b);
    for (int i = 0; i < 10000; ++i) w.step();
    const Momenta m1 = momenta(w, b);
    const double p = std::hypot(m0.p[0], m0.p[1], m0.p[2]), l = std::hypot(m0.l[0], m0.l[1], m0.l[2]);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(m1.p[k], m0.p[k], 1e-9 * p) << k;
      EXPECT_NEAR(m1.l[k], m0.l[k], 1e-9 * l) << k;
    }
  }
}

TEST(MultilevelStep, StaggeredAndNaiveGiveTheSameBitsForAnyThreadCount) {
  std::uint64_t first = 0;
  for (Schedule s : {Schedule::staggered, Schedule::naive})
    for (int threads : {1, 2, 4}) {
      WorldDef wd = world_def(threads);
      wd.gravity = {0, 0, -9.81};
      wd.schedule = s;
      BodyDef def = split_bar();
      RegionDef clamp;
      clamp.min = {-1, -1, -1};
      clamp.max = {0, 1, 1};
      def.fixed = {clamp};
      World w(wd);
      w.add_body(def);
      for (int i = 0; i < 300; ++i) w.step();
      if (first == 0) first = w.state_hash();
      EXPECT_EQ(w.state_hash(), first) << to_string(s) << " " << threads;
    }
}

}  // namespace
}  // namespace pliant

namespace pliant {
namespace {

// Undamped, clamped at one end, set swinging: total energy (time-centred kinetic + elastic) over
// 10^4 fine steps.
TEST(MultilevelStep, UndampedEnergyStaysWithinOnePercent) {
  for (int levels : {1, 3}) {
    SCOPED_TRACE(levels);
    BodyDef def = split_bar(ForceModel::corotational, levels);
    if (levels == 1) def.multiresolution = {};
    RegionDef clamp;
    clamp.min = {-1, -1, -1};
    clamp.max = {0, 1, 1};
    def.fixed = {clamp};
    World w(world_def());
    const BodyId b = w.add_body(def);
    for (int l = 0; l < w.level_count(b); ++l) {
      Level<double>& L = w.level<double>(b, l);
      for (std::size_t n = 0; n < L.node_count; ++n)
        if (L.state[n] == kNodeFree) L.v[2][n] = 0.5 * (L.X[0][n] / kL) * (L.X[0][n] / kL);  // m/s, first bending mode-like
    }
    const double e0 = w.energies().total();
    double worst = 0;
    for (int i = 0; i < 10000; ++i) {
      w.step();
      if (i % 100 == 99) worst = std::max(worst, std::abs(w.energies().total() / e0 - 1));
    }
    std::printf("levels %d: largest relative energy change %.3g over 10^4 steps\n", levels, worst);
    EXPECT_LT(worst, levels == 1 ? 1.5e-3 : 5e-3);  // the issue asks < 1%; measured 1.5e-4 (1 level), 1.0e-3 (3 levels)
  }
}

}  // namespace
}  // namespace pliant
