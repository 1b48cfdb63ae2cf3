// What a host may put in a WorldDef, BodyDef, ProbeDef or ToolDef that a scene file cannot, and
// calls with impossible arguments: each is refused with an InputError naming the field, never a
// crash, a hang or a world that silently does not move (found by an audit of the API on
// 2026-11-29: an unknown enum value crashed add_body, levels = INT_MAX tried to allocate 100 GB, a
// world without a stable step made advance_to loop for ever, and so on).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;

BodyDef small_box(const char* name = "box") {
  BodyDef b;
  b.name = name;
  b.mesh.kind = MeshSourceDef::Kind::box;
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.2, 0.05, 0.05};
  b.mesh.cells = {8, 2, 2};
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-6, 1, 1};
  b.fixed.push_back(clamp);
  return b;
}

// Runs `call`; it must throw an InputError whose message holds every one of `words`.
void expect_refused(const std::function<void()>& call, std::initializer_list<const char*> words, const std::string& what) {
  try {
    call();
    ADD_FAILURE() << what << ": accepted";
  } catch (const InputError& e) {
    for (const char* w : words) EXPECT_THAT(e.what(), HasSubstr(w)) << what;
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": threw something else than an InputError: " << e.what();
  }
}

void expect_body_refused(const BodyDef& b, std::initializer_list<const char*> words, const std::string& what,
                         const WorldDef& wd = {}) {
  World w(wd);
  expect_refused([&] { w.add_body(b); }, words, what);
}

TEST(BadInput, EnumValuesOutsideTheirListAreRefusedNamingTheField) {
  {
    BodyDef b = small_box();
    b.model = static_cast<ForceModel>(9);
    expect_body_refused(b, {"box", "model"}, "ForceModel 9");
  }
  {
    BodyDef b = small_box();
    b.mesh.kind = static_cast<MeshSourceDef::Kind>(9);
    expect_body_refused(b, {"box", "mesh.kind"}, "mesh kind 9");
  }
  {
    BodyDef b = small_box();
    b.fixed[0].kind = static_cast<RegionDef::Kind>(9);
    expect_body_refused(b, {"box", "fixed[0]", "kind"}, "region kind 9");
  }
  {
    BodyDef b = small_box();
    b.multiresolution.levels = 2;
    b.multiresolution.active.kind = static_cast<ActiveDef::Kind>(9);  // crashed (null read)
    expect_body_refused(b, {"box", "multiresolution.active"}, "active kind 9");
  }
  {
    BodyDef b = small_box();
    b.multiresolution.levels = 2;
    b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
    b.multiresolution.active.adapt.measure = static_cast<AdaptDef::Measure>(9);
    expect_body_refused(b, {"box", "multiresolution.adapt.measure"}, "adapt measure 9");
  }
  for (int which = 0; which < 3; ++which) {
    WorldDef wd;
    const char* field = "precision";
    if (which == 0) wd.precision = static_cast<Precision>(7);
    if (which == 1) wd.schedule = static_cast<Schedule>(7), field = "schedule";
    if (which == 2) wd.packed_corners = static_cast<PackedCorners>(7), field = "packed_corners";
    expect_refused([&] { World w(wd); }, {field}, field);
  }
  {
    World w;
    w.add_body(small_box());
    ToolDef t;
    t.shape.kind = static_cast<ToolShapeDef::Kind>(9);
    t.keyframes.push_back({});
    expect_refused([&] { w.add_tool(t); }, {"tool", "shape"}, "tool shape 9");
  }
}

// levels = INT_MAX tried to build INT_MAX meshes (std::bad_alloc); 0 and -3 made a single-level
// body without a word. The scene reader takes 1..8.
TEST(BadInput, LevelsOutsideOneToEightAreRefusedBeforeAnyMeshIsBuilt) {
  for (int levels : {0, -3, 9, INT_MAX}) {
    BodyDef b = small_box();
    b.multiresolution.levels = levels;
    expect_body_refused(b, {"box", "multiresolution.levels", "1", "8"}, "levels " + std::to_string(levels));
  }
}

// A fixed level outside the hierarchy was clamped to its ends; adaptivity on a single level was
// ignored. The scene reader refuses both.
TEST(BadInput, ActiveLevelsThatDoNotExistAreRefused) {
  for (int level : {-1, 2, 5}) {
    BodyDef b = small_box();
    b.multiresolution.levels = 2;
    b.multiresolution.active.kind = ActiveDef::Kind::level;
    b.multiresolution.active.level = level;
    expect_body_refused(b, {"box", "multiresolution.active.level"}, "level " + std::to_string(level));
  }
  BodyDef b = small_box();
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  expect_body_refused(b, {"box", "adaptive", "2 levels"}, "adaptive on one level");
}

// Without a body the world has no step (0 s): advance_to looped for ever.
TEST(BadInput, AdvancingAWorldWithoutABodyIsAnError) {
  World w;
  expect_refused([&] { w.advance_to(0.01); }, {"no body"}, "advance_to without a body");
  WorldDef wd;
  wd.time_step.dt = 1.0;  // far above the bound: the body is refused, and the world has none again
  World v(wd);
  EXPECT_THROW(v.add_body(small_box()), InputError);
  expect_refused([&] { v.advance_to(0.01); }, {"no body"}, "advance_to after the only body was refused");
}

// Numbers each finite whose stable step is not: damping whose damping ratio overflows, a mesh so
// small that its face areas underflow. The body was accepted with a step of 0 s (or NaN): step()
// did nothing and advance_to hung.
TEST(BadInput, ABodyWithoutAFinitePositiveStableStepIsRefused) {
  const struct {
    const char* what;
    std::function<void(BodyDef&)> spoil;
    const char* word;
  } cases[] = {
      {"damping.stiffness 1e300", [](BodyDef& b) { b.material.damping.stiffness = 1e300; }, "damping"},
      {"shear_viscosity 1e300", [](BodyDef& b) { b.material.damping.shear_viscosity = 1e300; }, "damping"},
      // Face areas' squares underflow to 0: an altitude of 0, an infinite frequency.
      {"mesh 1e-91 m", [](BodyDef& b) { b.mesh.scale = 1e-90; }, "mesh"},
  };
  for (const auto& c : cases) {
    BodyDef b = small_box();
    c.spoil(b);
    expect_body_refused(b, {"box", "stable", c.word}, c.what);
  }
}

// Mass damping alpha far beyond critical: the step's formula (2/w)(sqrt(1+z^2) - z), z = alpha/(2w),
// cancelled to 0 s (or to a number off by orders) at alpha = 1e12 1/s. Its value there is
// 4 / (alpha (1 + sqrt(1 + 1/z^2))) = 2 / alpha to 1e-14 (z >= 1e7 here), times the Courant factor.
TEST(BadInput, AStronglyMassDampedBodyGetsItsStepWithoutCancellation) {
  for (double alpha : {1e11, 1e12}) {
    BodyDef b = small_box();
    b.material.damping.mass = alpha;
    World w;
    w.add_body(b);
    const double courant = WorldDef{}.time_step.courant;
    EXPECT_NEAR(w.stable_dt(), courant * 2 / alpha, 1e-12 * courant * 2 / alpha) << alpha;
  }
}

// A mesh reaching beyond the divergence limit (1e15 m from its centre) was accepted and stopped at
// its first step, at rest, with a DivergenceError.
TEST(BadInput, AMeshBeyondTheDivergenceLimitIsRefused) {
  BodyDef b = small_box();
  b.mesh.scale = 1e17;  // 2e16 m long
  b.fixed.clear();
  expect_body_refused(b, {"box", "beyond", "scale"}, "mesh of 2e16 m");
  b.mesh.scale = 1e14;  // 2e13 m: within the limit
  World w;
  EXPECT_NO_THROW(w.add_body(b));
}

// A motion of the nodes within 2 cm of the box's free end, with the given keyframes.
PrescribedMotionDef end_motion(std::vector<KeyframeDef> keyframes) {
  PrescribedMotionDef m;
  m.region.kind = RegionDef::Kind::sphere;
  m.region.center = {0.2, 0.025, 0.025};
  m.region.radius = 0.02;
  m.keyframes = std::move(keyframes);
  return m;
}

ProbeDef tip_probe(const Vec3d& point) {
  ProbeDef p;
  p.name = "tip";
  p.body = "box";
  p.point = point;
  return p;
}

// An infinite point was accepted and the probe read NaN.
TEST(BadInput, AProbeAtANonFinitePointIsRefused) {
  World w;
  w.add_body(small_box());
  expect_refused([&] { w.add_probe(tip_probe({INFINITY, 0.01, 0.01})); }, {"probe 'tip'", "point"}, "probe at infinity");
}

// Out-of-range probe numbers threw std::out_of_range from a vector.
TEST(BadInput, ProbeNumbersOutOfRangeAreInputErrors) {
  World w;
  w.add_body(small_box());
  w.add_probe(tip_probe({0.2, 0.025, 0.025}));
  for (int id : {-1, 1, 3}) {
    expect_refused([&] { w.probe_name(id); }, {"no probe", std::to_string(id).c_str()}, "probe_name");
    expect_refused([&] { w.probe_position(id); }, {"no probe", std::to_string(id).c_str()}, "probe_position");
  }
}

// A normal of finite components whose squared length overflows passed the check, then divided by
// an infinite length: [0, 0, 0], an obstacle that stopped nothing.
TEST(BadInput, AnObstacleNormalOfHugeComponentsIsStillItsDirection) {
  WorldDef wd;
  ObstacleDef floor;
  floor.point = {0, 0, -0.01};
  floor.normal = {0, 0, 1e200};
  wd.obstacles.push_back(floor);
  World w(wd);
  ASSERT_EQ(w.obstacles().size(), 1u);
  const Vec3d n = w.obstacles()[0].normal;
  EXPECT_EQ(n[0], 0.0);
  EXPECT_EQ(n[1], 0.0);
  EXPECT_EQ(n[2], 1.0);
  // And one of tiny components (squared length below the double range) too.
  wd.obstacles[0].normal = {3e-200, 0, 4e-200};
  World v(wd);
  EXPECT_NEAR(v.obstacles()[0].normal[0], 0.6, 1e-15);
  EXPECT_NEAR(v.obstacles()[0].normal[2], 0.8, 1e-15);
}

// A prescribed motion without keyframes held its region at rest without a word; the header and the
// scene reader say "at least one".
TEST(BadInput, APrescribedMotionWithoutKeyframesIsRefused) {
  BodyDef b = small_box();
  b.prescribed.push_back(end_motion({}));
  expect_body_refused(b, {"box", "prescribed[0].keyframes", "at least one"}, "no keyframes");
}

// A node in two motions followed the last one listed without a word.
TEST(BadInput, TwoMotionsMovingOneNodeDifferentlyAreRefused) {
  BodyDef b = small_box();
  const PrescribedMotionDef m = end_motion({{0.0, {0, 0, 0}}, {0.1, {0, 0, 0.01}}});
  b.prescribed = {m, m};
  b.prescribed[1].region.radius = 0.04;  // overlaps the first
  {
    World w;  // the same keyframes twice say one thing
    EXPECT_NO_THROW(w.add_body(b));
  }
  b.prescribed[1].keyframes[1].offset = {0, 0, -0.01};
  expect_body_refused(b, {"box", "prescribed[0] and prescribed[1] both move node", "one motion"}, "two motions");
}

// Face counts are for surfaces: a box's coarser levels are boxes; they were ignored.
TEST(BadInput, FaceCountsOnABoxAreRefused) {
  BodyDef b = small_box();
  b.multiresolution.levels = 2;
  b.multiresolution.faces = {100};
  expect_body_refused(b, {"box", "multiresolution.faces", "box"}, "faces on a box");
}

// calibrate needs fixed nodes (the weight's deflection against them); without, it did nothing.
TEST(BadInput, CalibrationWithoutFixedNodesIsRefused) {
  BodyDef b = small_box();
  b.fixed.clear();
  b.multiresolution.levels = 2;
  b.multiresolution.calibrate = true;
  expect_body_refused(b, {"box", "multiresolution.calibrate", "fixed"}, "calibrate without fixed nodes");
}

// An active region outside the body left it at its coarsest level without a word.
TEST(BadInput, AnActiveRegionThatSelectsNoNodeIsRefused) {
  BodyDef b = small_box();
  b.multiresolution.levels = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::regions;
  ActiveRegionDef r;
  r.level = 1;
  r.region.min = {5, 5, 5};
  r.region.max = {6, 6, 6};
  b.multiresolution.active.regions.push_back(r);
  expect_body_refused(b, {"body 'box'", "multiresolution.active.regions[0]", "selects no node"}, "region outside");
  b.multiresolution.active.regions[0].region.min = {0.15, -1, -1};  // the free end: accepted
  b.multiresolution.active.regions[0].region.max = {1, 1, 1};
  World w;
  EXPECT_NO_THROW(w.add_body(b));
}

// An empty node list selected nothing without a word, where a box that selects nothing is an
// error (and the scene reader refuses an empty list).
TEST(BadInput, ANodesRegionThatListsNoNodeIsRefused) {
  BodyDef b = small_box();
  b.fixed[0].kind = RegionDef::Kind::nodes;
  b.fixed[0].nodes.clear();
  expect_body_refused(b, {"box", "fixed[0]", "lists no node"}, "empty node list");
}

// Errors that named no body (a scene of several bodies left the reader guessing), nor the value.
TEST(BadInput, MeshAndNodeErrorsNameTheBody) {
  {
    BodyDef b = small_box();
    b.mesh.cells = {0, 2, 2};
    expect_body_refused(b, {"body 'box'", "cells"}, "box cells 0");
  }
  {
    BodyDef b = small_box();
    b.mesh.scale = 0;
    expect_body_refused(b, {"body 'box'", "mesh.scale"}, "scale 0");
  }
  {
    BodyDef b = small_box();
    b.mesh.translate = {0, std::nan(""), 0};
    expect_body_refused(b, {"body 'box'", "mesh.translate", "nan"}, "translate NaN");
  }
  {
    BodyDef b = small_box();
    b.multiresolution.levels = 2;
    b.multiresolution.active.kind = ActiveDef::Kind::regions;
    ActiveRegionDef r;
    r.level = 1;
    r.region.kind = RegionDef::Kind::nodes;
    r.region.nodes = {99999};
    b.multiresolution.active.regions.push_back(r);
    expect_body_refused(b, {"body 'box'", "node 99999"}, "active region node 99999");
  }
  World w;
  w.add_body(small_box());
  expect_refused([&] { w.node_position(0, 100000); }, {"body 'box'", "level 0", "100000"}, "node_position");
  expect_refused([&] { w.node_rest_position(0, 100000); }, {"body 'box'", "level 0", "100000"}, "node_rest_position");
  BodyDef pushed = small_box("pushed");
  pushed.prescribed.push_back(end_motion({{0.0, {0, 0, 0}}}));
  const BodyId p = w.add_body(pushed);
  expect_refused([&] { w.set_motion_offset(p, 0, {0, INFINITY, 0}); }, {"body 'pushed'", "motion 0", "inf"},
                 "set_motion_offset");
}

// A NaN position a host wrote was read as no displacement (std::max drops a NaN).
TEST(BadInput, TheLargestDisplacementOfANaNPositionIsNaN) {
  World w;
  w.add_body(small_box());
  EXPECT_EQ(w.max_displacement(), 0.0);
  auto& L = w.level<double>(0);
  L.x[1][L.node_count - 1] = std::nan("");
  EXPECT_TRUE(std::isnan(w.max_displacement()));
}

}  // namespace
}  // namespace pliant
