// Stepping a multiresolution body (engine/src/core/simulation.cpp, docs/multiresolution.md):
// conservation (mass, linear and angular momentum), the patch test across level interfaces,
// energy over long undamped runs, determinism, and staggered = naive bit for bit. Box
// hierarchies with an even ratio and Kuhn cells nest exactly, so these hold to rounding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

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

WorldDef world_def(int threads = 1, Precision precision = Precision::float64) {
  WorldDef w;
  w.gravity = {0, 0, 0};
  w.precision = precision;
  w.threads = threads;
  w.time_step.adapt = false;
  return w;
}

struct Momenta {
  double p[3] = {0, 0, 0}, l[3] = {0, 0, 0}, mass = 0;
};

// Linear and angular momentum of the nodes, plus the impulses received and not applied yet (at the
// positions they will be applied at).
template <class T = double>
Momenta momenta(const World& w, BodyId b) {
  Momenta m;
  for (int lv = 0; lv < w.level_count(b); ++lv) {
    const Level<T>& L = w.level<T>(b, lv);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      double q[3];
      for (int k = 0; k < 3; ++k)
        q[k] = double(L.mass[n]) * double(L.v[k][n]) + (L.impulse[k].empty() ? 0.0 : double(L.impulse[k][n]));
      const double x[3] = {double(L.x[0][n]), double(L.x[1][n]), double(L.x[2][n])};
      for (int k = 0; k < 3; ++k) m.p[k] += q[k];
      m.l[0] += x[1] * q[2] - x[2] * q[1];
      m.l[1] += x[2] * q[0] - x[0] * q[2];
      m.l[2] += x[0] * q[1] - x[1] * q[0];
      m.mass += double(L.mass[n]);
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
template <class T>
double largest_speed_after_affine_map(ForceModel model, std::size_t& free_nodes, int levels = 3) {
  BodyDef def = split_bar(model, levels);
  if (levels == 1) def.multiresolution = {};
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
  World w(world_def(1, sizeof(T) == 4 ? Precision::float32 : Precision::float64));
  const BodyId b = w.add_body(def);
  const double A[3][3] = {{0.02, 0.01, -0.005}, {0.004, -0.01, 0.003}, {0.006, 0.002, 0.015}};
  for (int l = 0; l < levels; ++l) {
    Level<T>& L = w.level<T>(b, l);
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int i = 0; i < 3; ++i) {
        const double X[3] = {double(L.X[0][n]), double(L.X[1][n]), double(L.X[2][n])};
        L.x[i][n] = T(X[i] + A[i][0] * X[0] + A[i][1] * X[1] + A[i][2] * X[2]);
      }
  }
  for (int t = 0; t < 4; ++t) w.step();
  double vmax = 0;
  free_nodes = 0;
  for (int l = 0; l < levels; ++l) {
    const Level<T>& L = w.level<T>(b, l);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      if (L.state[n] != kNodeFree) continue;
      ++free_nodes;
      for (int k = 0; k < 3; ++k) vmax = std::max(vmax, std::abs(double(L.v[k][n])));
    }
  }
  return vmax;
}

TEST(MultilevelStep, AffineStateIsInEquilibriumAcrossTheInterfaces) {
  for (ForceModel model : {ForceModel::linear, ForceModel::stvk, ForceModel::corotational}) {
    SCOPED_TRACE(to_string(model));
    std::size_t free_nodes = 0;
    const double vd = largest_speed_after_affine_map<double>(model, free_nodes);
    EXPECT_GT(free_nodes, 20u);
    const double vf = largest_speed_after_affine_map<float>(model, free_nodes);
    std::size_t single_free = 0;
    const double vd1 = largest_speed_after_affine_map<double>(model, single_free, 1);
    const double vf1 = largest_speed_after_affine_map<float>(model, single_free, 1);
    std::printf("%s: largest speed %.3g m/s (double), %.3g m/s (float); one level: %.3g, %.3g\n", to_string(model), vd,
                vf, vd1, vf1);
    // The strain's force on one node alone gives |v| ~ 1e-2 m/s after these steps. Measured
    // (double / float): 2e-14 / 8.6e-6 m/s with 3 levels, the rounding of positions and stresses,
    // as in the fine mesh alone (printed beside).
    EXPECT_LT(vd, 1e-13);
    EXPECT_LT(vf, 4.5e-5);
  }
}

// A free body, spinning and vibrating: linear and angular momentum stay put over 10^4 fine steps.
// Returns the largest change of a component over the norm, linear and angular.
template <class T>
std::array<double, 2> momentum_change(ForceModel model) {
  World w(world_def(1, sizeof(T) == 4 ? Precision::float32 : Precision::float64));
  const BodyId b = w.add_body(split_bar(model));
  for (int l = 0; l < 3; ++l) {
    Level<T>& L = w.level<T>(b, l);
    for (std::size_t n = 0; n < L.node_count; ++n) {
      const double x = double(L.X[0][n]), y = double(L.X[1][n]);  // body frame: about the bar's centre
      L.v[0][n] = T(0.3 - 2.0 * y + 0.5 * x);  // translation + spin about z + stretch
      L.v[1][n] = T(0.1 + 2.0 * x);
      L.v[2][n] = T(-0.2 + 1.0 * x * x);
    }
  }
  const Momenta m0 = momenta<T>(w, b);
  for (int i = 0; i < 10000; ++i) w.step();
  const Momenta m1 = momenta<T>(w, b);
  const double p = std::hypot(m0.p[0], m0.p[1], m0.p[2]), l = std::hypot(m0.l[0], m0.l[1], m0.l[2]);
  std::array<double, 2> worst{0, 0};
  for (int k = 0; k < 3; ++k) {
    worst[0] = std::max(worst[0], std::abs(m1.p[k] - m0.p[k]) / p);
    worst[1] = std::max(worst[1], std::abs(m1.l[k] - m0.l[k]) / l);
  }
  return worst;
}

TEST(MultilevelStep, FreeBodyConservesMomentum) {
  for (ForceModel model : {ForceModel::stvk, ForceModel::corotational}) {
    SCOPED_TRACE(to_string(model));
    const auto d = momentum_change<double>(model);
    const auto f = momentum_change<float>(model);
    std::printf("%s: relative change over 10^4 steps: linear %.2g, angular %.2g (double); %.2g, %.2g (float)\n",
                to_string(model), d[0], d[1], f[0], f[1]);
    // The issue asks 1e-9. Measured: double 1.9e-15 (linear), 3.2e-15 (angular); float 4.8e-7, 3.3e-6
    // (the rounding of 10^4 steps of float sums).
    EXPECT_LT(d[0], 8e-15);
    EXPECT_LT(d[1], 1.3e-14);
    EXPECT_LT(f[0], 2.4e-6);
    EXPECT_LT(f[1], 1.65e-5);
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
    const double x0 = w.body_origin(b)[0];  // level arrays are in the body frame
    for (int l = 0; l < w.level_count(b); ++l) {
      Level<double>& L = w.level<double>(b, l);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        const double x = (x0 + L.X[0][n]) / kL;  // 0 at the clamp, 1 at the tip
        if (L.state[n] == kNodeFree) L.v[2][n] = 0.5 * x * x;  // m/s, first bending mode-like
      }
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

#ifdef PLIANT_HAS_CGAL
namespace pliant {
namespace {

// The default scene's organ (20 kPa, 1060 kg/m^3) on three non-nested levels, the finest in a 4 cm
// sphere under its push, the others elsewhere.
BodyDef organ_split() {
  BodyDef b;
  b.name = "organ";
  b.mesh.kind = MeshSourceDef::Kind::implicit;
  b.mesh.shape = "organ";
  b.mesh.cell_size = 0.01;
  b.material.young = 2e4;
  b.material.poisson = 0.45;
  b.material.density = 1060;
  b.multiresolution.levels = 3;
  b.multiresolution.active.kind = ActiveDef::Kind::regions;
  ActiveRegionDef fine;
  fine.level = 2;
  fine.region.kind = RegionDef::Kind::sphere;
  fine.region.center = {0.03, 0, 0.04};
  fine.region.radius = 0.04;
  b.multiresolution.active.regions = {fine};
  return b;
}

// The organ's three levels are non-nested (Mesh_3 of simplified surfaces): a body at rest, or
// turned rigidly, must stay as it is: every ghost reproduces affine motions exactly, those a little
// outside their coarser tet included.
TEST(MultilevelStep, NonNestedOrganAtRestOrTurnedStaysPut) {
  const BodyDef b = organ_split();
  for (bool turned : {false, true}) {
    World w(world_def());
    const BodyId id = w.add_body(b);
    double mass = 0;
    const double c = std::cos(2.0), s = std::sin(2.0);  // 115 deg about x
    for (int l = 0; l < 3; ++l) {
      Level<double>& L = w.level<double>(id, l);
      for (std::size_t n = 0; n < L.node_count; ++n) {
        if (L.state[n] == kNodeFree) {
          EXPECT_GT(L.mass[n], 0.0);
        }
        mass += L.mass[n];
        if (turned) {
          const double y = L.X[1][n], z = L.X[2][n];
          L.x[1][n] = c * y - s * z;
          L.x[2][n] = s * y + c * z;
        }
      }
    }
    for (int i = 0; i < 100; ++i) w.step();
    double vmax = 0;
    for (int l = 0; l < 3; ++l) {
      const Level<double>& L = w.level<double>(id, l);
      for (std::size_t n = 0; n < L.node_count; ++n)
        if (L.state[n] == kNodeFree)
          for (int k = 0; k < 3; ++k) vmax = std::max(vmax, std::abs(L.v[k][n]));
    }
    // Measured 4.4e-14 m/s (rest and turned); a ghost off by one part in 1e6 of the organ gives ~1e-3.
    std::printf("%s: largest speed %.3g m/s\n", turned ? "turned" : "at rest", vmax);
    EXPECT_LT(vmax, 4e-13) << (turned ? "turned" : "at rest");  // measured 4.65e-14 (at rest), 4.11e-14 (turned)
    EXPECT_GT(mass, 0.0);
  }
}

}  // namespace
}  // namespace pliant
#endif

#ifdef PLIANT_HAS_CGAL
namespace pliant {
namespace {

// The organ of the default scene, held at its ligament and pushed on top, a fine region around the
// push: no part of any level may move much more than the whole organ does at its finest level (a
// tet of a coarse level left dangling at the edge of the fine region, held by one node or edge,
// swings out).
TEST(MultilevelStep, OrganSplitMovesLikeTheFineOrgan) {
  auto run = [](int levels) {
    BodyDef b;
    b.name = "organ";
    b.mesh.kind = MeshSourceDef::Kind::implicit;
    b.mesh.shape = "organ";
    b.mesh.cell_size = 0.01;
    b.material.young = 2e4;
    b.material.poisson = 0.45;
    b.material.density = 1060;
    b.material.damping.mass = 3;
    b.material.damping.stiffness = 1e-4;
    RegionDef ligament;
    ligament.min = {-1, -1, -1};
    ligament.max = {-0.075, 1, 1};
    b.fixed = {ligament};
    PrescribedMotionDef push;
    push.region.kind = RegionDef::Kind::sphere;
    push.region.center = {0.03, 0, 0.04};
    push.region.radius = 0.015;
    push.keyframes = {{0, {0, 0, 0}}, {0.2, {0, 0, -0.015}}};
    b.prescribed = {push};
    b.multiresolution.levels = levels;
    b.multiresolution.active.kind = ActiveDef::Kind::regions;
    ActiveRegionDef fine;
    fine.level = levels - 1;
    fine.region.kind = RegionDef::Kind::sphere;
    fine.region.center = {0.03, 0, 0.04};
    fine.region.radius = 0.04;
    b.multiresolution.active.regions = {fine};
    if (levels == 1) {
      b.multiresolution = {};
    }
    WorldDef wd = world_def();
    wd.gravity = {0, 0, -9.81};
    World w(wd);
    w.add_body(b);
    double largest = 0;
    while (w.time() < 0.3) {
      w.step();
      largest = std::max(largest, w.max_displacement());
    }
    return largest;
  };
  const double fine = run(1), split = run(3);
  std::printf("largest displacement over 0.3 s: %.4g m (fine), %.4g m (3 levels)\n", fine, split);
  // Measured: 0.0314 m against 0.0329 m (0.95x: the coarse levels are stiffer; 0.91x when finer tets were
  // stepped by their centroids alone); with the dangling
  // tets of coarse levels left stepped, 0.0380 m (1.15x).
  EXPECT_LT(split, 1.1 * fine);
}

}  // namespace
}  // namespace pliant
#endif

#ifdef PLIANT_HAS_CGAL
namespace pliant {
namespace {

// The organ split on its three non-nested levels, held at its ligament and let go under gravity,
// undamped: it swings 0.3 m. Its levels overlap at their interfaces (a finer tet stepped for every
// active node, weighed by its mass share): kinetic + elastic + gravity's potential must stay what
// it was at rest (0), against the potential the swing moves through.
TEST(MultilevelStep, NonNestedOrganSwingsWithoutGainingEnergy) {
  BodyDef b = organ_split();
  RegionDef ligament;
  ligament.min = {-1, -1, -1};
  ligament.max = {-0.075, 1, 1};
  b.fixed = {ligament};
  WorldDef wd = world_def(2);
  wd.gravity = {0, 0, -9.81};
  World w(wd);
  w.add_body(b);
  double worst = 0, deepest = 0;  // |total| and |potential| (J)
  while (w.time() < 1.0) {
    w.step();
    const Energies e = w.energies();
    worst = std::max(worst, std::abs(e.total()));
    deepest = std::max(deepest, std::abs(e.potential));
  }
  std::printf("undamped swing over 1 s: |kinetic + elastic + potential| up to %.3g J, potential up to %.3g J\n", worst,
              deepest);
  EXPECT_GT(deepest, 0.5);           // it swings (measured 1.01 J)
  EXPECT_LT(worst, 2e-3 * deepest);  // measured 1.71e-3 J: 1.7e-3 of it
}

TEST(MultilevelStep, NonNestedSplitWeighsTheBody) {
  const BodyDef b = organ_split();
  World w(world_def());
  const BodyId id = w.add_body(b);
  const TetMesh finest = build_mesh(b.mesh);
  double volume = 0;
  for (const Tet& t : finest.tets)
    volume += signed_tet_volume(finest.point(t[0]), finest.point(t[1]), finest.point(t[2]), finest.point(t[3]));
  // measured 1.2e-15 of it
  EXPECT_NEAR(momenta(w, id).mass, 1060 * volume, 1e-14 * 1060 * volume);
}

}  // namespace
}  // namespace pliant
#endif

namespace pliant {
namespace {

// First-mode frequency (Hz) of a clamped beam's tip released under gravity: mean crossings of z.
double tip_frequency(BodyDef b, int level, bool calibrate) {
  b.multiresolution.active.kind = ActiveDef::Kind::level;
  b.multiresolution.active.level = level;
  b.multiresolution.calibrate = calibrate;
  WorldDef wd = world_def(2);
  wd.gravity = {0, 0, -9.81};
  World w(wd);
  w.add_body(b);
  w.add_probe({"tip", b.name, {1, 0.05, 0.05}});
  std::vector<double> t, z;
  while (w.time() < 1.0) {
    w.step();
    t.push_back(w.time());
    z.push_back(w.probe_position(0)[2]);
  }
  double mean = 0;
  for (double v : z) mean += v / double(z.size());
  std::vector<double> up;
  for (std::size_t i = 1; i < z.size(); ++i)
    if (z[i - 1] < mean && z[i] >= mean) up.push_back(t[i]);
  return double(up.size() - 1) / (up.back() - up.front());
}

// Linear tets lock in bending, the more so the coarser: calibrated, the coarser level of a
// cantilever swings at the finer one's frequency.
TEST(MultilevelStep, CalibrationMatchesTheFirstModeAcrossLevels) {
  BodyDef b;
  b.name = "beam";
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.max = {1, 0.1, 0.1};
  b.mesh.cells = {20, 2, 2};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1.4715e8;
  b.material.density = 1000;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {0, 1, 1};
  b.fixed = {clamp};
  b.multiresolution.levels = 2;
  const double fine = tip_frequency(b, 1, false);
  const double coarse = tip_frequency(b, 0, false), calibrated = tip_frequency(b, 0, true);
  std::printf("first mode: fine %.3f Hz, coarse %.3f Hz, coarse calibrated %.3f Hz\n", fine, coarse, calibrated);
  // Measured: 10x1x1 cells swing 43% faster than 20x2x2 (11.56 against 8.06 Hz); calibrated,
  // 8.066 Hz (+0.07%).
  EXPECT_GT(coarse / fine, 1.3);
  EXPECT_NEAR(calibrated / fine, 1.0, 0.0035);
}

}  // namespace
}  // namespace pliant

namespace pliant {
namespace {

// Tip sag (m, down) of a clamped bar under a load on its free end, settled by mass damping, with
// the levels active as `active` says. A load, not gravity: non-nested levels overlap (and their
// masses are scaled to the body's), so where the weight sits depends on the split.
double settled_tip_sag(const BodyDef& bar, const ActiveDef& active) {
  BodyDef b = bar;
  b.multiresolution.active = active;
  NodalLoadDef load;
  load.region.min = {b.mesh.max[0], -1, -1};
  load.region.max = {1, 1, 1};
  load.total_force = {0, 0, -2};  // N: 2 mm of tip sag at the fine level
  b.loads = {load};
  World w(world_def());
  w.add_body(b);
  const double tip[3] = {b.mesh.max[0], 0.5 * b.mesh.max[1], 0.5 * b.mesh.max[2]};
  w.add_probe({"tip", b.name, {tip[0], tip[1], tip[2]}});
  while (w.time() < 0.6) w.step();
  return tip[2] - w.probe_position(0)[2];
}

// A bar whose levels do not nest (9 fine cells along it over 5 coarse: the coarse nodes at
// x = 0.04, 0.08, ... are no fine nodes; or 15 over 8 over 4), the outer half or the clamped half
// at its finest level, the rest coarser. Linear tets lock in bending, the coarser the more, so a bar
// split in part must sag between its coarsest and its finest level: a split that sags more than
// the finest level has a hinge at its
// interface, a joint weaker than the material (stress scenes 826, 4732, 6804, 7270 and 12268 of
// seed 7, docs/stress.md, gained their energy when such a joint was refined).
TEST(MultilevelStep, NonNestedBarSplitInPartSagsBetweenItsLevels) {
  BodyDef b;
  b.name = "bar";
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.2, 0.04, 0.04};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e6;
  b.material.poisson = 0.3;
  b.material.density = 1000;
  b.material.damping.mass = 40;  // 1/s: settled within 0.6 s
  b.model = ForceModel::linear;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {0, 1, 1};
  b.fixed = {clamp};
  auto region = [](int level, double from, double to) {
    ActiveRegionDef r;
    r.level = level;
    r.region.kind = RegionDef::Kind::box;
    r.region.min = {from, -1, -1};
    r.region.max = {to, 1, 1};
    return r;
  };
  // 2 levels: 9 fine cells over 5; 3 levels: 15 over 8 over 4 (none nests in the next).
  for (int levels : {2, 3}) {
    b.mesh.cells = levels == 2 ? std::array<int, 3>{9, 2, 2} : std::array<int, 3>{15, 3, 3};
    b.multiresolution.levels = levels;
    ActiveDef fine, coarse;
    fine.kind = ActiveDef::Kind::finest;
    coarse.kind = ActiveDef::Kind::coarsest;
    const double sag_fine = settled_tip_sag(b, fine), sag_coarse = settled_tip_sag(b, coarse);
    const int f = levels - 1;
    struct Split {
      const char* what;
      std::vector<ActiveRegionDef> regions;
    };
    std::vector<Split> splits{{"outer half finest", {region(f, 0.1, 1)}}, {"clamped half finest", {region(f, -1, 0.1)}}};
    if (levels == 3) splits.push_back({"outer half finest, then the middle level", {region(2, 0.1, 1), region(1, 0.05, 1)}});
    for (const Split& sp : splits) {
      ActiveDef split;
      split.kind = ActiveDef::Kind::regions;
      split.regions = sp.regions;
      const double sag = settled_tip_sag(b, split);
      std::printf("%d levels: tip sag coarsest %.4g mm, finest %.4g mm, %s %.4g mm\n", levels, 1e3 * sag_coarse,
                  1e3 * sag_fine, sp.what, 1e3 * sag);
      // Measured, 2 levels: coarse 6.00 mm, fine 12.63 mm; outer half fine 7.53 mm, clamped half
      // 12.41 mm (with a finer tet stepped by its centroid alone: 22.45 and 16.19 mm). 3 levels:
      // 5.32 and 17.55 mm; 9.36, 17.27 and 13.22 mm (by centroids: 16.77, 19.14 and 20.96 mm).
      EXPECT_GT(sag, sag_coarse) << levels << " levels, " << sp.what;
      EXPECT_LT(sag, sag_fine) << levels << " levels, " << sp.what;
    }
  }
}

}  // namespace
}  // namespace pliant

namespace pliant {
namespace {

// The finest level refreshes its ghosts only where something they are made of moved (its sources
// end their windows, or a change, or a host's write; simulation.cpp, phase A): a host that moves a
// coarse node between two steps, in the middle of that coarse level's window, must see the finer
// level's ghosts follow it at the next tick. Each ghost then sits where its sources put it: the
// weighted sum of their positions (the refresh's own arithmetic, in double, rounded to T).
TEST(MultilevelStep, GhostsFollowAHostsWriteToTheirSourcesInTheMiddleOfAWindow) {
  World w(world_def());
  const BodyId b = w.add_body(split_bar());
  const int fine = w.level_count(b) - 1;
  for (int i = 0; i < 9; ++i) w.step();  // ticks 0..8: the coarse windows (4 ticks) are 1 tick into the third
  Level<double>& F = w.level<double>(b, fine);
  ASSERT_FALSE(F.ghosts.empty());
  // Every source of the finest level's ghosts moved by the host, 1 mm along y, between two steps.
  for (std::size_t g = 0; g < F.ghosts.size(); ++g)
    for (std::int32_t e = F.ghost_offsets[g]; e < F.ghost_offsets[g + 1]; ++e) {
      Level<double>& S = w.level<double>(b, F.ghost_source_level[std::size_t(e)]);
      S.x[1][std::size_t(F.ghost_source_node[std::size_t(e)])] = S.X[1][std::size_t(F.ghost_source_node[std::size_t(e)])] + 1e-3;
    }
  // Where the sources put each ghost: its sources do not move before the end of the tick.
  std::vector<double> expected(F.ghosts.size(), 0.0);
  for (std::size_t g = 0; g < F.ghosts.size(); ++g)
    for (std::int32_t e = F.ghost_offsets[g]; e < F.ghost_offsets[g + 1]; ++e)
      expected[g] += F.ghost_weight[std::size_t(e)] *
                     w.level<double>(b, F.ghost_source_level[std::size_t(e)]).x[1][std::size_t(F.ghost_source_node[std::size_t(e)])];
  w.step();  // tick 9: the finest level's window starts, no coarser one does (they start at even ticks)
  const Level<double>& G = w.level<double>(b, fine);
  double worst = 0;
  for (std::size_t g = 0; g < G.ghosts.size(); ++g) worst = std::max(worst, std::abs(G.x[1][std::size_t(G.ghosts[g])] - expected[g]));
  EXPECT_LT(worst, 1e-15);  // the same sum: 0 measured; stale ghosts would be about 1 mm off
  std::printf("%zu ghosts, largest distance from where their sources put them: %.3g m\n", G.ghosts.size(), worst);
}

}  // namespace
}  // namespace pliant
