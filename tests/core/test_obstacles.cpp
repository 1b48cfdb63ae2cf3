// Static obstacles (WorldDef::obstacles) in a running world: a soft cube dropped on a floor
// comes to rest on it with no node below it beyond rounding, its energy never exceeds what it
// started with, its momentum changes by exactly the impulse of gravity plus the impulse the
// floor reports, Coulomb friction stops a sliding cube where μ g says, the result is the same
// bits for 1, 2 and 4 threads, and bad obstacles are refused with a clear message.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "pliant/run.hpp"
#include "pliant/scene.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;

// A 10 cm cube of soft rubber (E = 100 kPa) whose bottom face is `height` m above the plane z = 0.
BodyDef cube(double height, ForceModel model = ForceModel::corotational) {
  BodyDef b;
  b.name = "cube";
  b.model = model;
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {-0.05, -0.05, height};
  b.mesh.max = {0.05, 0.05, height + 0.1};
  b.mesh.cells = {4, 4, 4};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.poisson = 0.3;
  b.material.density = 1000;
  return b;
}

WorldDef floor_world(double friction, Precision precision = Precision::float64, int threads = 1) {
  WorldDef wd;
  wd.precision = precision;
  wd.threads = threads;
  ObstacleDef floor;
  floor.point = {0, 0, 0};
  floor.normal = {0, 0, 2};  // any length
  floor.friction = friction;
  wd.obstacles.push_back(floor);
  return wd;
}

template <class T>
double lowest(const World& w) {
  const auto x = w.positions<T>(0);  // body frame: relative to body_origin
  return w.body_origin(0)[2] + double(*std::min_element(x[2].begin(), x[2].end()));
}

Vec3d momentum(const World& w) {  // of the stored velocities, kg m/s
  const Level<double>& L = w.level<double>(0);
  Vec3d p{0, 0, 0};
  for (std::size_t n = 0; n < L.node_count; ++n)
    for (int k = 0; k < 3; ++k) p[k] += L.mass[n] * L.v[k][n];
  return p;
}

double body_mass(const World& w) {
  const Level<double>& L = w.level<double>(0);
  double m = 0;
  for (std::size_t n = 0; n < L.node_count; ++n) m += L.mass[n];
  return m;
}

TEST(Obstacles, ADroppedCubeComesToRestOnTheFloorWithNoNodeBelowIt) {
  BodyDef b = cube(0.05);
  b.material.damping.mass = 4;  // so that it settles within the second
  World w(floor_world(0.5));
  w.add_body(b);
  double min_z = 1;
  while (w.time() < 3.0) {
    w.step();
    min_z = std::min(min_z, lowest<double>(w));
  }
  // Measured: the projection puts nodes exactly on z = 0 (min_z = 0 exactly).
  EXPECT_GE(min_z, -1e-15);
  EXPECT_LT(lowest<double>(w), 1e-15);  // it is on the floor, not above it (measured 0)
  // At rest: no node faster than 1 mm/s (measured: 2e-4 m/s, the last wobble of its top corners
  // decaying), the cube a little squashed.
  const auto v = w.velocities<double>(0);
  double vmax = 0;
  for (std::size_t n = 0; n < v[0].size(); ++n)
    vmax = std::max(vmax, std::sqrt(v[0][n] * v[0][n] + v[1][n] * v[1][n] + v[2][n] * v[2][n]));
  EXPECT_LT(vmax, 1e-3);
  const auto x = w.positions<double>(0);  // body frame
  const double top = w.body_origin(0)[2] + *std::max_element(x[2].begin(), x[2].end());
  EXPECT_GT(top, 0.09);
  EXPECT_LT(top, 0.1);
  // At rest the floor carries the weight: its impulse over the last 0.5 s is m g 0.5 s.
  const double m = body_mass(w);
  const double J0 = w.obstacle_impulse(0)[2];
  const double t0 = w.time();
  while (w.time() < t0 + 0.5) w.step();
  // Measured: within 1e-6.
  // measured 4.2e-8
  EXPECT_NEAR((w.obstacle_impulse(0)[2] - J0) / (m * 9.81 * (w.time() - t0)), 1.0, 4e-7);
}

TEST(Obstacles, EnergyNeverExceedsWhatTheCubeStartedWith) {
  World w(floor_world(0.0));
  w.add_body(cube(0.05));  // no damping: only the contacts take energy out
  const double e0 = w.energies().total();
  double emax = e0, e_end = 0;
  int contacts = 0;
  while (w.time() < 0.6) {
    w.step();
    const double e = w.energies().total();
    emax = std::max(emax, e);
    e_end = e;
    contacts += lowest<double>(w) < 1e-12;
  }
  EXPECT_GT(contacts, 10);  // it did hit the floor
  // The fall from 5 cm releases m g h = 0.49 J; the contacts take much of it (measured: a third).
  const double mgh = body_mass(w) * 9.81 * 0.05;
  EXPECT_LT(e_end, e0 - 0.1 * mgh);
  // Measured: emax - e0 = 4e-16 J, rounding (the first value is the largest).
  EXPECT_LE(emax - e0, 4e-15);
}

TEST(Obstacles, MomentumChangesByTheImpulseOfGravityAndOfTheFloor) {
  for (double friction : {0.0, 0.6}) {
    World w(floor_world(friction));
    w.add_body(cube(0.02));
    // Thrown sideways and down: the floor's impulse has normal and (with friction) tangential parts.
    Level<double>& L = w.level<double>(0);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      L.v[0][n] = 0.8;
      L.v[2][n] = -0.5;
    }
    const Vec3d p0 = momentum(w);
    const double m = body_mass(w);
    while (w.time() < 0.3) w.step();
    const Vec3d p1 = momentum(w), J = w.obstacle_impulse(0), g = w.gravity();
    const double t = double(w.steps()) * w.dt();
    EXPECT_GT(J[2], 0.1 * m);  // the floor pushed
    for (int k = 0; k < 3; ++k)  // measured: within 1.3e-15 m
      EXPECT_NEAR(p1[k] - p0[k], m * g[k] * t + J[k], 1e-14 * m) << "friction " << friction << " component " << k;
    if (friction == 0) {
      EXPECT_EQ(J[0], 0.0);  // a frictionless floor pushes along its normal only
      EXPECT_EQ(J[1], 0.0);
    } else {
      EXPECT_LT(J[0], -0.1 * m);  // friction slowed the slide
    }
  }
}

TEST(Obstacles, CoulombFrictionStopsASlidingCubeWhereMuGSays) {
  // A stiff cube (so that it slides as a block) resting on the floor, sliding at 1 m/s: with
  // mu = 0.5 it stops after v^2 / (2 mu g) = 0.102 m, in v / (mu g) = 0.204 s.
  BodyDef b = cube(0.0);
  b.material.young = 1e7;
  b.material.damping.stiffness = 1e-4;
  World w(floor_world(0.5));
  w.add_body(b);
  Level<double>& L = w.level<double>(0);
  for (std::size_t n = 0; n < L.node_count; ++n) L.v[0][n] = 1.0;
  auto centre_x = [&] {
    double s = 0, m = 0;
    for (std::size_t n = 0; n < L.node_count; ++n) {
      s += L.mass[n] * L.x[0][n];
      m += L.mass[n];
    }
    return s / m;
  };
  const double x0 = centre_x();
  while (w.time() < 0.4) w.step();
  const double slide = centre_x() - x0;
  // Measured: 0.10195 m against 0.10194 m (1.3e-4).
  EXPECT_NEAR(slide / (1.0 / (2 * 0.5 * 9.81)), 1.0, 5e-4);
  EXPECT_LT(std::abs(momentum(w)[0]), 1e-10 * body_mass(w));  // it has stopped (measured: 1.8e-11 m/s)
}

TEST(Obstacles, OnAnInclineFrictionHoldsOrLetsSlideAsCoulombSays) {
  // A stiff cube on a floor under gravity tilted by 20 degrees (an incline). With mu = 0.2 <
  // tan 20 it slides with g (sin 20 - mu cos 20); with mu = 0.6 it should stay. Friction acts node
  // by node with the normal impulse of the same step, so a body that should stick creeps a little:
  // a limitation this test measures and bounds, not a feature.
  const double th = 20 * std::acos(-1.0) / 180, g = 9.81;
  for (double mu : {0.2, 0.6}) {
    WorldDef wd = floor_world(mu);
    wd.gravity = {g * std::sin(th), 0, -g * std::cos(th)};
    World w(wd);
    BodyDef b = cube(0.0);
    b.material.young = 1e7;
    b.material.damping.stiffness = 1e-4;
    w.add_body(b);
    auto centre_x = [&] {
      const auto x = w.positions<double>(0);
      double sum = 0;
      for (double v : x[0]) sum += v;
      return sum / double(x[0].size());
    };
    const double x0 = centre_x();
    while (w.time() < 1.0) w.step();
    const double slid = centre_x() - x0;
    if (mu == 0.2) {
      const double want = 0.5 * g * (std::sin(th) - mu * std::cos(th)) * w.time() * w.time();
      EXPECT_NEAR(slid / want, 1.0, 0.01);  // measured: 1.2e-3
    } else {
      EXPECT_LT(std::abs(slid), 0.005);  // creep, measured: 1.3 mm in 1 s (the free slide would be 1 m)
    }
  }
}

TEST(Obstacles, SameBitsForOneTwoAndFourThreads) {
  for (Precision precision : {Precision::float32, Precision::float64}) {
    std::uint64_t hash[3];
    int i = 0;
    for (int threads : {1, 2, 4}) {
      World w(floor_world(0.4, precision, threads));
      BodyDef b = cube(0.001);
      b.mesh.cells = {12, 12, 12};  // 10k tets: several tasks per pass
      w.add_body(b);
      Level<float>* Lf = precision == Precision::float32 ? &w.level<float>(0) : nullptr;
      for (int s = 0; s < 400; ++s) {
        w.step();
        if (s == 0) {  // a sideways push, so that friction works too
          if (Lf)
            for (std::size_t n = 0; n < Lf->node_count; ++n) Lf->v[0][n] = 0.5f;
          else
            for (double& v : w.level<double>(0).v[0]) v = 0.5;
        }
      }
      EXPECT_GT(w.obstacle_impulse(0)[2], 0.0) << "the cube reached the floor";
      EXPECT_LT(w.obstacle_impulse(0)[0], 0.0) << "friction acted";
      hash[i++] = w.state_hash();
    }
    EXPECT_EQ(hash[0], hash[1]);
    EXPECT_EQ(hash[0], hash[2]);
  }
}

TEST(Obstacles, ABodyStartingInsideAnObstacleIsRefused) {
  World w(floor_world(0));
  try {
    w.add_body(cube(-0.01));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("body 'cube' starts inside obstacles[0]"));
    EXPECT_THAT(e.what(), HasSubstr("0.01 m into it"));
  }
  // Exactly on the plane is fine.
  World ok(floor_world(0));
  EXPECT_NO_THROW(ok.add_body(cube(0.0)));
}

TEST(Obstacles, BadObstaclesAreRefused) {
  WorldDef wd = floor_world(0);
  wd.obstacles[0].normal = {0, 0, 0};
  EXPECT_THROW({ World w(wd); }, InputError);
  wd = floor_world(-1);
  try {
    World w(wd);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("obstacles[0]: friction must be >= 0"));
  }
}

TEST(Obstacles, SceneFilesDeclareThem) {
  const SceneDef s = parse_scene(R"({"obstacles": [{"plane": {"point": [0, 0, -1], "normal": [0, 0, 1]}, "friction": 0.3}],
    "bodies": [{"mesh": {"box": {}}}]})", "s.json", ".");
  ASSERT_EQ(s.world.obstacles.size(), 1u);
  EXPECT_EQ(s.world.obstacles[0].point[2], -1.0);
  EXPECT_EQ(s.world.obstacles[0].friction, 0.3);
  auto error = [](const char* text) {
    try {
      parse_scene(text, "s.json", ".");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error(R"({"obstacles": [{"plane": {"point": [0,0,0], "normal": [0,0,0]}}], "bodies": [{"mesh": {"box": {}}}]})"),
              HasSubstr("s.json: obstacles[0].plane.normal: must not be [0, 0, 0]"));
  EXPECT_THAT(error(R"({"obstacles": [{"plane": {"point": [0,0,0]}}], "bodies": [{"mesh": {"box": {}}}]})"),
              HasSubstr("obstacles[0].plane.normal: missing (required)"));
  EXPECT_THAT(error(R"({"obstacles": [{"plane": {"point": [0,0,0], "normal": [0,0,1]}, "friction": -1}], "bodies": [{"mesh": {"box": {}}}]})"),
              HasSubstr("obstacles[0].friction: must be >= 0"));
  EXPECT_THAT(error(R"({"obstacles": [{"plain": {}}], "bodies": [{"mesh": {"box": {}}}]})"),
              HasSubstr("obstacles[0].plain: unknown key"));
}

}  // namespace
}  // namespace pliant
