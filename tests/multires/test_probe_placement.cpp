// Probes placed again after changes of resolution (engine/src/core/probe_placement.hpp): from the
// candidates kept around each probe's material point, the same level, tet and weights, to the bit,
// as reading every stepped tet of the body, for points inside tets, on faces, edges and nodes
// shared by several tets, and outside the body (where the candidates leave the choice to the scan).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <cstring>
#include <random>
#include <vector>

#include "../../engine/src/core/probe_placement.hpp"
#include "../../engine/src/multires/apply_changes.hpp"
#include "pliant/world.hpp"
#include "../support/adaptive_body.hpp"

namespace pliant::detail {
namespace {

// A 3-level adaptive box bar, 12 x 4 x 4 fine cells, clamped at x = 0.
BodyDef bar() {
  BodyDef b;
  b.name = "bar";
  b.mesh.min = {0, 0, 0};
  b.mesh.max = {0.3, 0.1, 0.1};
  b.mesh.cells = {12, 4, 4};
  b.mesh.tets_per_cell = 6;
  b.material.young = 1e5;
  b.material.density = 1000;
  b.multiresolution.levels = 3;
  b.multiresolution.ratio = 2;
  b.multiresolution.active.kind = ActiveDef::Kind::adaptive;
  RegionDef clamp;
  clamp.min = {-1, -1, -1};
  clamp.max = {1e-9, 1, 1};
  b.fixed.push_back(clamp);
  return b;
}

template <class T>
using Adaptive = AdaptiveBody<T>;

// Points (body frame) of every kind: tet centroids, face and edge midpoints and nodes of the
// finest and coarsest meshes (each on several tets: ties the first of equals must break), and two
// points outside the body.
template <class T>
std::vector<std::array<double, 3>> probe_points(const SimBody<T>& body) {
  std::vector<std::array<double, 3>> out;
  for (const std::size_t l : {body.levels.size() - 1, std::size_t(0)}) {
    const Level<T>& L = body.levels[l];
    for (const std::size_t e : {std::size_t(0), L.tet_count / 3, L.tet_count / 2 + 1, L.tet_count - 1}) {
      std::array<std::array<double, 3>, 4> c;
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) c[std::size_t(a)][std::size_t(k)] = double(L.X[k][std::size_t(L.tet[a][e])]);
      std::array<double, 3> centroid{}, face{}, edge{};
      for (int k = 0; k < 3; ++k) {
        const auto K = std::size_t(k);
        centroid[K] = 0.25 * (c[0][K] + c[1][K] + c[2][K] + c[3][K]);
        face[K] = (c[1][K] + c[2][K] + c[3][K]) / 3;
        edge[K] = 0.5 * (c[0][K] + c[1][K]);
      }
      out.push_back(centroid);
      out.push_back(face);
      out.push_back(edge);
      out.push_back(c[2]);  // a node
    }
  }
  out.push_back({1.0, 1.0, 1.0});   // far outside (the body frame's origin is the bar's centre)
  out.push_back({-0.16, 0.0, 0.0});  // 1 cm beyond the clamped end
  return out;
}

template <class T>
void same_choice_as_the_scan(unsigned seed) {
  Adaptive<T> a(bar());
  SimBody<T>& body = a.body;
  // The probes as World::add_probe places them (the scan), with their candidates.
  std::vector<ProbeState> probes;
  std::vector<std::array<double, 3>> points = probe_points(body);
  for (const auto& x : points) {
    ProbeState p;
    place_probe_by_scan(body, x.data(), p);
    make_probe_candidates(body, x.data(), p.candidates);
    probes.push_back(p);
  }
  std::mt19937 rng(seed);
  std::size_t by_candidates = 0, outside_by_candidates = 0, compared = 0;
  for (int change = 0; change < 60; ++change) {
    a.set_random_targets(rng, 10);
    const ActivationState::Changes ch = a.as->update();
    keep_momentum(body, apply_changes(body, a.ps, *a.as, ch, 0.01 * change));
    for (std::size_t i = 0; i < probes.size(); ++i) {
      SCOPED_TRACE("change " + std::to_string(change) + ", point " + std::to_string(i));
      // Inside: the point where the probe reads now (World's probes drift by rounding from one
      // placement to the next). Outside: the point itself every time (a placed probe reads where its
      // weights were clamped, on the body's surface), so that every change asks the scan.
      const bool outside = i + 2 >= probes.size();
      double X[3] = {points[i][0], points[i][1], points[i][2]};
      if (!outside) probe_rest_point(body, probes[i], X);
      ProbeState scan = probes[i], fast = probes[i];
      place_probe_by_scan(body, X, scan);
      const bool found = place_probe_from_candidates(body, X, fast);
      if (found) {
        ++by_candidates;
        outside_by_candidates += outside;
      } else {
        EXPECT_EQ(fast.level, probes[i].level);  // untouched: the caller scans
        EXPECT_EQ(fast.tet, probes[i].tet);
        place_probe_by_scan(body, X, fast);
      }
      EXPECT_EQ(fast.level, scan.level);
      EXPECT_EQ(fast.tet, scan.tet);
      EXPECT_EQ(0, std::memcmp(fast.weights.data(), scan.weights.data(), sizeof(double) * 4));
      ++compared;
      probes[i] = fast;  // as Simulation::relocate_probes keeps it
    }
    if (::testing::Test::HasFailure()) break;
  }
  std::printf("%zu placements compared, %zu from the candidates (%zu of points outside)\n", compared, by_candidates,
              outside_by_candidates);
  EXPECT_EQ(compared, 60 * probes.size());
  EXPECT_GT(by_candidates, compared / 2);  // the candidates decide most placements
  EXPECT_EQ(outside_by_candidates, 0u);     // outside every tet: always the scan
}

TEST(ProbePlacement, CandidatesChooseWhatTheScanChoosesDouble) { same_choice_as_the_scan<double>(11); }
TEST(ProbePlacement, CandidatesChooseWhatTheScanChoosesFloat) { same_choice_as_the_scan<float>(12); }

// The candidates are made again when the point is beyond their reach, and kept within it.
TEST(ProbePlacement, CandidatesAreMadeAgainBeyondTheirReach) {
  Adaptive<double> a(bar());
  const double x[3] = {0.05, 0.01, 0.02};  // body frame: inside the bar
  ProbeState p;
  place_probe_by_scan(a.body, x, p);
  make_probe_candidates(a.body, x, p.candidates);
  const double reach = p.candidates.reach;
  ASSERT_GT(reach, 0);
  // Half the margin between the two thresholds over the largest weight gradient of the body: in
  // the fine level's Kuhn cells of 2.5 cm, sqrt(2) / 2.5 cm (a corner whose gradient is (1, -1, 0) / h).
  const double expected = 0.5 * (kProbeInside - kProbeCandidate) * 0.025 / std::sqrt(2.0);
  EXPECT_NEAR(reach, expected, 1e-14 * expected);  // the rest gradients rounded (8e-16 relative measured)
  const double near[3] = {x[0] + 0.5 * reach, x[1], x[2]};
  ASSERT_TRUE(place_probe_from_candidates(a.body, near, p));
  EXPECT_EQ(p.candidates.X[0], x[0]);  // kept
  const double far[3] = {x[0] + 0.03, x[1], x[2]};
  ASSERT_TRUE(place_probe_from_candidates(a.body, far, p));
  EXPECT_EQ(p.candidates.X[0], far[0]);  // made again
  ProbeState scan = p;
  place_probe_by_scan(a.body, far, scan);
  EXPECT_EQ(p.tet, scan.tet);
  EXPECT_EQ(p.level, scan.level);
}

// Where the body is now at its material point `point` (world frame), from level l: the positions of
// a stepped tet of that level containing the point, weighted by its rest barycentric weights (any
// such tet: the field is continuous across their faces). False if no stepped tet contains it.
bool deformed_point(const World& w, int l, const Vec3d& point, Vec3d& out) {
  const Level<double>& L = w.level<double>(0, l);
  const Vec3d o = w.body_origin(0);
  const double X[3] = {point[0] - o[0], point[1] - o[1], point[2] - o[2]};
  for (const Range& run : L.stepped_runs)
    for (std::size_t e = run.begin; e < run.end; ++e) {
      double wgt[4];
      if (probe_weights(L, e, X, wgt) < -1e-9) continue;
      for (int k = 0; k < 3; ++k) {
        out[std::size_t(k)] = o[std::size_t(k)];
        for (int a = 0; a < 4; ++a) out[std::size_t(k)] += wgt[a] * L.x[k][std::size_t(L.tet[a][e])];
      }
      return true;
    }
  return false;
}

// Through World (whose add_probe makes the candidates): the clamped bar bends under gravity on its
// finest level, then on its coarsest, and after each change the probe reads where its point is in
// the finest level stepped there (a probe left on a level no longer stepped, or on a tet that does
// not contain its point, would read somewhere else: the point has moved by millimetres).
TEST(ProbePlacement, ProbesReadTheirPointOnTheFinestSteppedLevel) {
  WorldDef wd;
  wd.precision = Precision::float64;
  World w(wd);
  BodyDef b = bar();
  b.multiresolution.active.adapt.refine_above = 1e9;  // only force_level changes the levels
  b.multiresolution.active.adapt.coarsen_below = 0;   // and nothing merges on its own
  w.add_body(b);
  ProbeDef pd;
  pd.name = "middle";
  pd.body = "bar";
  pd.point = {0.2, 0.04, 0.06};
  w.add_probe(pd);
  for (const int level : {2, 0, 1}) {
    SCOPED_TRACE("level " + std::to_string(level));
    w.force_level(0, level);
    for (int i = 0; i < 400; ++i) w.step();
    Vec3d want{};
    ASSERT_TRUE(deformed_point(w, level, pd.point, want));
    for (int finer = level + 1; finer < 3; ++finer) EXPECT_EQ(w.level_info(0, finer).stepped_tets, 0u);
    const Vec3d got = w.probe_position(0);
    double moved = 0;
    for (int k = 0; k < 3; ++k) {
      // The same tet or one beside it (the field is continuous): rounding, 2e-17 m measured.
      EXPECT_NEAR(got[std::size_t(k)], want[std::size_t(k)], 1e-15);
      moved = std::max(moved, std::abs(want[std::size_t(k)] - pd.point[std::size_t(k)]));
    }
    std::printf("level %d: the point moved %.3g mm\n", level, 1e3 * moved);
    EXPECT_GT(moved, 1e-4);
  }
}

}  // namespace
}  // namespace pliant::detail
