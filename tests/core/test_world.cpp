// World behaviour: bitwise determinism across thread counts, the stable step and its refusal,
// sub-stepping, divergence reports, prescribed motion, probes and API errors.
#include <gtest/gtest.h>
#include <gmock/gmock.h>

#include <cmath>
#include <fmt/format.h>

#include "pliant/run.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;

BodyDef beam_def(ForceModel model) {
  BodyDef b;
  b.name = "beam";
  b.model = model;
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.4, 0.1, 0.1};
  b.mesh.cells = {16, 6, 6};
  b.material.young = 2e5;
  b.material.poisson = 0.35;
  b.material.density = 1000;
  b.material.damping.stiffness = 1e-4;
  b.material.damping.mass = 0.5;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-6, 1, 1};
  b.fixed.push_back(clamp);
  PrescribedMotionDef push;
  push.region.kind = RegionDef::Kind::sphere;
  push.region.center = {0.4, 0.05, 0.1};
  push.region.radius = 0.03;
  push.keyframes = {{0.0, {0, 0, 0}}, {0.02, {0, 0, -0.01}}};
  b.prescribed.push_back(push);
  NodalLoadDef load;
  load.region.min = {0.3, -1, -1};
  load.region.max = {0.35, 1, 1};
  load.total_force = {0, 0.5, 0};
  b.loads.push_back(load);
  return b;
}

std::uint64_t hash_after(ForceModel model, Precision precision, int threads, int steps) {
  WorldDef wd;
  wd.precision = precision;
  wd.threads = threads;
  World w(wd);
  w.add_body(beam_def(model));
  for (int i = 0; i < steps; ++i) w.step();
  return w.state_hash();
}

class Determinism : public ::testing::TestWithParam<std::tuple<ForceModel, Precision>> {};

TEST_P(Determinism, StateHashIsIdenticalForOneTwoAndFourThreadsAndAcrossRuns) {
  const auto [model, precision] = GetParam();
  const std::uint64_t h1 = hash_after(model, precision, 1, 500);
  EXPECT_EQ(h1, hash_after(model, precision, 2, 500));
  EXPECT_EQ(h1, hash_after(model, precision, 4, 500));
  EXPECT_EQ(h1, hash_after(model, precision, 2, 500));
  // And the state did move (the hash is not that of the rest state).
  EXPECT_NE(h1, hash_after(model, precision, 1, 0));
}

INSTANTIATE_TEST_SUITE_P(AllModels, Determinism,
                         ::testing::Combine(::testing::Values(ForceModel::linear, ForceModel::stvk,
                                                              ForceModel::corotational, ForceModel::springs),
                                            ::testing::Values(Precision::float32, Precision::float64)));

TEST(StableStep, AutoPicksTheCourantBound) {
  WorldDef wd;
  wd.time_step.courant = 0.5;
  World w(wd);
  BodyDef b = beam_def(ForceModel::corotational);
  b.material.damping = {};
  w.add_body(b);
  const double nu = b.material.poisson, E = b.material.young;
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  const Level<double>& L = w.level<double>(0);
  const double h = L.min_altitude;
  // The classic Courant bound, and the measured highest mode (stable_step.cpp): the step is
  // built for the higher frequency of the two, never above the classic bound.
  const double classic = 0.5 * h * std::sqrt(b.material.density / (lambda + 2 * mu));
  EXPECT_GT(h, 0.0);
  EXPECT_NEAR(L.omega_geometric, 1.0 / classic, 1e-12 / classic);  // 2 c_p / h_min = C / classic
  EXPECT_GT(L.omega_measured, 0.5 * L.omega_geometric);
  EXPECT_EQ(L.omega_max, std::max(L.omega_geometric, L.omega_measured / 0.98));
  EXPECT_NEAR(w.stable_dt(), 0.5 * 2 / L.omega_max, 1e-12 * classic);
  EXPECT_LE(w.stable_dt(), classic * (1 + 1e-12));
  EXPECT_LE(w.dt(), w.stable_dt());
  EXPECT_EQ(w.substeps(), 1);
}

TEST(StableStep, MeasuredModeDoesNotDependOnTheThreadCount) {
  for (ForceModel m : {ForceModel::corotational, ForceModel::springs})
    for (Precision p : {Precision::float32, Precision::float64}) {
      double first = 0;
      for (int threads : {1, 2, 4}) {
        WorldDef wd;
        wd.threads = threads;
        wd.precision = p;
        World w(wd);
        BodyDef b = beam_def(m);
        b.mesh.cells = {40, 6, 6};  // 8640 tets: several tasks per pass
        w.add_body(b);
        if (threads == 1) first = w.stable_dt();
        EXPECT_EQ(w.stable_dt(), first) << to_string(m) << " " << threads << " threads";
      }
      EXPECT_GT(first, 0.0);
    }
}

TEST(StableStep, DampingTightensTheBound) {
  World a, b;
  BodyDef d = beam_def(ForceModel::corotational);
  d.material.damping = {};
  a.add_body(d);
  d.material.damping.stiffness = 1e-3;
  b.add_body(d);
  EXPECT_LT(b.stable_dt(), a.stable_dt());
}

TEST(StableStep, ExplicitStepAboveTheBoundIsRefusedWithTheBound) {
  World probe;
  probe.add_body(beam_def(ForceModel::corotational));
  const double bound = probe.stable_dt();
  WorldDef wd;
  wd.time_step.dt = 1.5 * bound;
  World w(wd);
  try {
    w.add_body(beam_def(ForceModel::corotational));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("above the stable bound"));
    EXPECT_THAT(e.what(), HasSubstr(fmt::format("{:.6g}", bound)));
  }
  EXPECT_EQ(w.body_count(), 0u);
}

TEST(StableStep, SubsteppingSplitsAnExplicitStep) {
  World probe;
  probe.add_body(beam_def(ForceModel::corotational));
  WorldDef wd;
  wd.time_step.dt = 2.5 * probe.stable_dt();
  wd.time_step.substep = true;
  World w(wd);
  w.add_body(beam_def(ForceModel::corotational));
  EXPECT_EQ(w.substeps(), 3);
  w.step();
  EXPECT_NEAR(w.time(), 2.5 * probe.stable_dt(), 1e-15);
}

TEST(StableStep, ExplicitStepBelowTheBoundIsUsed) {
  World probe;
  probe.add_body(beam_def(ForceModel::corotational));
  WorldDef wd;
  wd.time_step.dt = 0.5 * probe.stable_dt();
  World w(wd);
  w.add_body(beam_def(ForceModel::corotational));
  EXPECT_DOUBLE_EQ(w.dt(), 0.5 * probe.stable_dt());
}

TEST(Divergence, NonFiniteStateStopsAtOnceNamingBodyLevelStepAndNode) {
  World w;
  w.add_body(beam_def(ForceModel::corotational));
  w.step();
  w.level<double>(0).v[1][37] = std::nan("");
  try {
    w.step();
    FAIL() << "expected DivergenceError";
  } catch (const DivergenceError& e) {
    EXPECT_THAT(e.what(), HasSubstr("body 'beam'"));
    EXPECT_THAT(e.what(), HasSubstr("level 0"));
    EXPECT_THAT(e.what(), HasSubstr("step 1"));
    EXPECT_THAT(e.what(), HasSubstr("node"));
  }
}

TEST(Divergence, RunawayFiniteStateStopsAtOnce) {
  // 1e200 m/s is finite in double: it must not run on (energies() would report inf later).
  for (Precision p : {Precision::float64, Precision::float32}) {
    WorldDef wd;
    wd.precision = p;
    World w(wd);
    w.add_body(beam_def(ForceModel::stvk));
    w.step();
    if (p == Precision::float64)
      w.level<double>(0).v[1][37] = 1e200;
    else
      w.level<float>(0).v[1][37] = 1e30f;
    try {
      w.step();
      FAIL() << "expected DivergenceError";
    } catch (const DivergenceError& e) {
      EXPECT_THAT(e.what(), HasSubstr("step 1"));
      EXPECT_THAT(e.what(), HasSubstr("node"));
      EXPECT_THAT(e.what(), HasSubstr("beyond 1e+15"));
    }
  }
}

TEST(PrescribedMotion, NodesFollowTheKeyframesExactly) {
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  World w(wd);
  BodyDef b = beam_def(ForceModel::linear);
  b.prescribed[0].keyframes = {{0.0, {0, 0, 0}}, {1.0, {0.01, -0.02, 0.03}}};
  w.add_body(b);
  for (int i = 0; i < 20; ++i) w.step();
  const auto& L = w.level<double>(0);
  const double s = w.time();
  int moved = 0;
  for (std::size_t n = 0; n < L.node_count; ++n) {
    const double dx = L.X[0][n] - 0.4, dy = L.X[1][n] - 0.05, dz = L.X[2][n] - 0.1;
    if (std::sqrt(dx * dx + dy * dy + dz * dz) > 0.03) continue;
    ++moved;
    EXPECT_NEAR(L.x[0][n] - L.X[0][n], 0.01 * s, 1e-12);
    EXPECT_NEAR(L.x[1][n] - L.X[1][n], -0.02 * s, 1e-12);
    EXPECT_NEAR(L.x[2][n] - L.X[2][n], 0.03 * s, 1e-12);
    EXPECT_NEAR(L.v[2][n], 0.03, 1e-9);
  }
  EXPECT_GT(moved, 0);
}

TEST(PrescribedMotion, HostCanDriveARegion) {
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  World w(wd);
  w.add_body(beam_def(ForceModel::corotational));
  w.set_motion_offset(0, 0, {0, 0, 0.005});
  w.step();
  const auto& L = w.level<double>(0);
  bool found = false;
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (L.state[n] == kNodeFixed && L.X[0][n] > 0.39) {
      EXPECT_NEAR(L.x[2][n] - L.X[2][n], 0.005, 1e-12);
      found = true;
    }
  EXPECT_TRUE(found);
  EXPECT_THROW(w.set_motion_offset(0, 3, {0, 0, 0}), InputError);
}

TEST(Regions, ARegionThatSelectsNoNodeIsAnError) {
  World w;
  BodyDef b = beam_def(ForceModel::corotational);
  b.fixed[0].min = {5, 5, 5};
  b.fixed[0].max = {6, 6, 6};
  try {
    w.add_body(b);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("fixed[0]"));
    EXPECT_THAT(e.what(), HasSubstr("selects no node"));
  }
}

TEST(Regions, FixedNodesDoNotMoveUnderGravity) {
  World w;
  w.add_body(beam_def(ForceModel::stvk));
  for (int i = 0; i < 50; ++i) w.step();
  const auto& L = w.level<double>(0);
  for (std::size_t n = 0; n < L.node_count; ++n) {
    if (L.X[0][n] <= 1e-6) {
      for (int k = 0; k < 3; ++k) EXPECT_EQ(L.x[k][n], L.X[k][n]);
    }
  }
  EXPECT_GT(w.max_displacement(), 0.0);
}

TEST(Probes, FollowTheMaterialPoint) {
  WorldDef wd;
  World w(wd);
  w.add_body(beam_def(ForceModel::corotational));
  const int p = w.add_probe({"tip", "beam", {0.4, 0.0, 0.0}});  // a mesh node (corner)
  for (int i = 0; i < 30; ++i) w.step();
  const auto& L = w.level<double>(0);
  std::size_t corner = 0;
  for (std::size_t n = 0; n < L.node_count; ++n)
    if (L.X[0][n] > 0.4 - 1e-9 && L.X[1][n] < 1e-9 && L.X[2][n] < 1e-9) corner = n;
  const Vec3d q = w.probe_position(p);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(q[k], L.x[k][corner], 1e-12);
  EXPECT_THROW(w.add_probe({"far", "beam", {3, 3, 3}}), InputError);
  EXPECT_THROW(w.add_probe({"nobody", "ghost", {0, 0, 0}}), InputError);
}

TEST(Api, ErrorsAreClear) {
  World w;
  w.add_body(beam_def(ForceModel::corotational));
  EXPECT_THROW(w.level<float>(0), InputError);
  EXPECT_THROW(w.level<double>(3), InputError);
  EXPECT_THROW(w.add_body(beam_def(ForceModel::linear)), InputError);  // same name
  EXPECT_EQ(w.find_body("beam"), 0);
  EXPECT_EQ(w.find_body("nope"), -1);
  WorldDef bad;
  bad.time_step.courant = 1.5;
  EXPECT_THROW(World{bad}, InputError);
  BodyDef nu = beam_def(ForceModel::linear);
  nu.name = "b2";
  nu.material.poisson = 0.5;
  try {
    w.add_body(nu);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("poisson"));
  }
}

TEST(Energy, MeasuringDoesNotChangeTheTrajectory) {
  World a, b;
  a.add_body(beam_def(ForceModel::corotational));
  b.add_body(beam_def(ForceModel::corotational));
  for (int i = 0; i < 100; ++i) {
    a.step();
    b.step();
    (void)b.energies();
    (void)b.snapshot(0);
  }
  EXPECT_EQ(a.state_hash(), b.state_hash());
}

TEST(Runner, SummaryHasTheDocumentedFields) {
  SceneDef scene;
  scene.duration = 0.01;
  scene.bodies.push_back(beam_def(ForceModel::corotational));
  scene.probes.push_back({"tip", "beam", {0.4, 0.05, 0.05}});
  RunOptions opt;
  opt.write_files = false;
  const RunSummary s = run_scene(scene, opt);
  EXPECT_EQ(s.status, "ok");
  EXPECT_GT(s.steps, 0);
  EXPECT_GE(s.simulated_time, 0.01);
  EXPECT_EQ(s.state_hash.size(), 16u);
  EXPECT_EQ(s.model, "corotational");
  EXPECT_GT(s.max_displacement, 0.0);
}

}  // namespace
}  // namespace pliant
