// Tool collision (engine/src/collision/) against brute force: on random poses, sizes and
// speeds of spheres and capsules over the shipped meshes, the triangles Embree + the exact test
// report equal the triangles an independent exact computation finds over the whole surface.
// The independent computation: the distance between two convex hulls of points (the tool's
// swept axis, a triangle) as the minimum over every pair of faces of the two simplices of the
// unconstrained least-squares distance of their affine hulls, kept when its barycentric
// weights are all >= 0 (the optimum lies inside some pair of faces) — a different algorithm
// from the Voronoi-region code the engine runs.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>

#include "../../engine/src/collision/closest_points.hpp"
#include "../../engine/src/collision/tool_contact.hpp"
#include "pliant/scheduler/executor.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using detail::P3;

// Squared distance between hull(A) and hull(B) (|A|, |B| <= 4), by enumeration of face pairs.
double hull_distance2(const std::vector<P3>& A, const std::vector<P3>& B) {
  double best = 1e300;
  const int na = int(A.size()), nb = int(B.size());
  for (int sa = 1; sa < (1 << na); ++sa)
    for (int sb = 1; sb < (1 << nb); ++sb) {
      std::vector<int> ia, ib;
      for (int i = 0; i < na; ++i)
        if (sa >> i & 1) ia.push_back(i);
      for (int i = 0; i < nb; ++i)
        if (sb >> i & 1) ib.push_back(i);
      // x = A[ia0] + sum_i l_i (A[ia_i] - A[ia0]) - B[ib0] - sum_j m_j (B[ib_j] - B[ib0]); minimise |x|^2.
      const int k = int(ia.size()) - 1 + int(ib.size()) - 1;
      Eigen::Vector3d c;
      for (int d = 0; d < 3; ++d) c[d] = A[std::size_t(ia[0])][std::size_t(d)] - B[std::size_t(ib[0])][std::size_t(d)];
      Eigen::VectorXd z = Eigen::VectorXd::Zero(k);
      if (k > 0) {
        Eigen::MatrixXd M(3, k);
        int col = 0;
        for (std::size_t i = 1; i < ia.size(); ++i, ++col)
          for (int d = 0; d < 3; ++d) M(d, col) = A[std::size_t(ia[i])][std::size_t(d)] - A[std::size_t(ia[0])][std::size_t(d)];
        for (std::size_t j = 1; j < ib.size(); ++j, ++col)
          for (int d = 0; d < 3; ++d) M(d, col) = -(B[std::size_t(ib[j])][std::size_t(d)] - B[std::size_t(ib[0])][std::size_t(d)]);
        z = M.completeOrthogonalDecomposition().solve(-c);
        c += M * z;
      }
      // Barycentric weights of both points must be >= 0 (within rounding).
      const double tol = -1e-12;
      double la0 = 1, mb0 = 1;
      bool ok = true;
      int col = 0;
      for (std::size_t i = 1; i < ia.size(); ++i, ++col) {
        ok &= z[col] >= tol;
        la0 -= z[col];
      }
      for (std::size_t j = 1; j < ib.size(); ++j, ++col) {
        ok &= z[col] >= tol;
        mb0 -= z[col];
      }
      ok &= la0 >= tol && mb0 >= tol;
      if (ok) best = std::min(best, c.squaredNorm());
    }
  return best;
}

struct Case {
  const char* file;
};

class ToolCollision : public ::testing::TestWithParam<const char*> {};

TEST_P(ToolCollision, ContactSetEqualsBruteForceOnRandomPosesSizesAndSpeeds) {
  const std::filesystem::path path = std::filesystem::path(PLIANT_DATA_MESHES) / GetParam();
  ASSERT_TRUE(std::filesystem::is_regular_file(path)) << path << " is missing: it ships with the repository (data/meshes)";
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  World w(wd);
  BodyDef bd;
  bd.mesh.kind = MeshSourceDef::Kind::file;
  bd.mesh.path = path;
  w.add_body(bd);
  Level<double>& L = w.level<double>(0);
  const Vec3d origin = w.body_origin(0);
  Executor exec(2);
  detail::EmbreeDevice device;
  detail::LevelContact<double> lc = detail::make_level_contact(device, L, 0, 0, exec, ToolPose{});

  // Mean boundary edge length: the scale of tools and speeds.
  double edge = 0;
  for (const auto& t : L.boundary)
    for (int e = 0; e < 3; ++e) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = L.x[k][std::size_t(t[std::size_t(e)])] - L.x[k][std::size_t(t[std::size_t((e + 1) % 3)])];
        d2 += d * d;
      }
      edge += std::sqrt(d2);
    }
  edge /= 3.0 * double(L.boundary.size());

  std::mt19937_64 rng(20261125);
  std::uniform_real_distribution<double> u(-1, 1), pos(0, 1);
  std::size_t total_hits = 0, poses = 0, empty = 0;
  std::string error;
  // The surface moves between queries (a random walk of up to 0.4 margin per vertex and trial,
  // back to rest every 12 trials), so that the lazy refit is exercised: queries on a BVH whose
  // vertices moved less than the margin, and refits once one moved more.
  std::uniform_real_distribution<double> jiggle(-0.4 * lc.margin / std::sqrt(3.0), 0.4 * lc.margin / std::sqrt(3.0));
  for (int trial = 0; trial < 240; ++trial) {
    if (trial % 12 == 0) {
      for (int k = 0; k < 3; ++k) L.x[k] = L.X[k];
    } else {
      for (std::size_t n = 0; n < L.node_count; ++n)
        for (int k = 0; k < 3; ++k) L.x[k][n] += jiggle(rng);
    }
    ToolShapeDef shape;
    shape.kind = trial % 2 ? ToolShapeDef::Kind::capsule : ToolShapeDef::Kind::sphere;
    shape.radius = edge * (0.1 + 3.0 * pos(rng));
    shape.length = edge * (0.5 + 6.0 * pos(rng));
    // Centre near a random surface vertex, within two radii of it.
    const auto& tri = L.boundary[std::size_t(rng() % L.boundary.size())];
    const auto n = std::size_t(tri[0]);
    ToolPose from;
    for (int k = 0; k < 3; ++k)
      from.position[std::size_t(k)] = origin[std::size_t(k)] + L.x[k][n] + 2 * shape.radius * u(rng);
    from.orientation = {u(rng), u(rng), u(rng), u(rng)};
    const double qn = std::sqrt(from.orientation[0] * from.orientation[0] + from.orientation[1] * from.orientation[1] +
                                from.orientation[2] * from.orientation[2] + from.orientation[3] * from.orientation[3]);
    for (double& q : from.orientation) q /= qn;
    // Speeds: a third of the poses still, the others moving up to 3 radii over the step; capsules
    // translate (their swept axis is then exactly the parallelogram the engine tests).
    ToolPose to = from;
    if (trial % 3 != 0)
      for (int k = 0; k < 3; ++k) to.position[std::size_t(k)] += 3 * shape.radius * u(rng);
    ASSERT_TRUE(detail::find_tool_contacts(lc, L, shape, from, to, origin, exec, error)) << error;

    Vec3d a0, b0, a1, b1;
    tool_axis(shape, from, a0, b0);
    tool_axis(shape, to, a1, b1);
    std::vector<P3> swept{detail::sub(a0, origin), detail::sub(a1, origin)};
    if (shape.kind == ToolShapeDef::Kind::capsule) {
      swept.push_back(detail::sub(b0, origin));
      swept.push_back(detail::sub(b1, origin));
    }
    const double r2 = shape.radius * shape.radius;
    std::set<std::uint32_t> expected, borderline;
    for (std::size_t t = 0; t < lc.triangles.size(); ++t) {
      std::vector<P3> T3;
      for (int k = 0; k < 3; ++k) {
        const auto node = std::size_t(lc.surface_nodes[std::size_t(lc.triangles[t][std::size_t(k)])]);
        T3.push_back({L.x[0][node], L.x[1][node], L.x[2][node]});
      }
      // Cheap exact rejection first: bounding balls apart.
      P3 c{0, 0, 0};
      for (const P3& p : T3) c = detail::add(c, detail::mul(p, 1.0 / 3));
      double rt = 0;
      for (const P3& p : T3) rt = std::max(rt, std::sqrt(detail::norm2(detail::sub(p, c))));
      double near = 1e300;
      for (const P3& p : swept) near = std::min(near, std::sqrt(detail::norm2(detail::sub(p, c))));
      double sweep_size = 0;
      for (const P3& p : swept)
        for (const P3& q : swept) sweep_size = std::max(sweep_size, std::sqrt(detail::norm2(detail::sub(p, q))));
      if (near - sweep_size > rt + shape.radius * 1.01) continue;
      const double d2 = hull_distance2(swept, T3);
      // Documented tolerance: 1e-9 of the radius on either side of the boundary.
      if (d2 <= r2 * (1 - 1e-9)) expected.insert(std::uint32_t(t));
      else if (d2 <= r2 * (1 + 1e-9)) borderline.insert(std::uint32_t(t));
    }
    const std::set<std::uint32_t> found(lc.hits.begin(), lc.hits.end());
    for (std::uint32_t t : expected) EXPECT_TRUE(found.count(t)) << "missed triangle " << t << " at trial " << trial;
    for (std::uint32_t t : found)
      EXPECT_TRUE(expected.count(t) || borderline.count(t)) << "false contact with triangle " << t << " at trial " << trial;
    total_hits += expected.size();
    empty += expected.empty();
    ++poses;
  }
  // The poses exercise contact: most touch something, some touch nothing.
  EXPECT_GT(total_hits, 2 * poses);
  EXPECT_GT(poses - empty, poses / 2);
  // Both paths ran: queries on a BVH refit earlier, and refits.
  EXPECT_GT(lc.refits, 10);
  EXPECT_LT(lc.refits, lc.queries);
  std::printf("%s: %zu poses, %zu contacts in all, %zu poses touching nothing; %lld refits for %lld queries\n", GetParam(),
              poses, total_hits, empty, static_cast<long long>(lc.refits), static_cast<long long>(lc.queries));
}

INSTANTIATE_TEST_SUITE_P(ShippedMeshes, ToolCollision,
                         ::testing::Values("liver.msh", "raptorTetra_8418.vtu", "Armadillo_Tetra_4406.vtu"));

TEST(ClosestPoints, SegmentTriangleAgreesWithHullDistanceOnRandomShapes) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const P3 p{u(rng), u(rng), u(rng)}, q{u(rng), u(rng), u(rng)};
    const P3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)}, c{u(rng), u(rng), u(rng)};
    const double mine = detail::closest_segment_triangle(p, q, a, b, c).distance2;
    const double ref = hull_distance2({p, q}, {a, b, c});
    worst = std::max(worst, std::abs(std::sqrt(mine) - std::sqrt(ref)));
    // Points too (p == q).
    const double mine_p = detail::closest_segment_triangle(p, p, a, b, c).distance2;
    const double ref_p = hull_distance2({p}, {a, b, c});
    worst = std::max(worst, std::abs(std::sqrt(mine_p) - std::sqrt(ref_p)));
  }
  EXPECT_LT(worst, 5e-15);  // both exact: they differ by rounding only (measured 1.1e-15)
  std::printf("largest difference of distances over 40000 shapes: %.3g\n", worst);
}

// A sphere's contact (its axis a point) takes closest_point_triangle, a shortcut of the general
// segment case for p == q: it must return the general case's bits (distance, segment parameter,
// point and weights), most of all where rounding picks between a face's and an edge's nearest
// point: points in the triangle's plane, on its edges and corners, near-degenerate triangles.
TEST(ClosestPoints, APointTakesTheGeneralSegmentCasesBits) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1), w01(0, 1);
  int edge_won = 0;  // cases where the general path's edge test beat closest_on_triangle by a rounding
  for (int i = 0; i < 200000; ++i) {
    const P3 a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)};
    P3 c{u(rng), u(rng), u(rng)};
    if (i % 7 == 0) c = detail::add(a, detail::mul(detail::sub(b, a), w01(rng)));  // degenerate: c on ab
    P3 p{u(rng), u(rng), u(rng)};
    switch (i % 5) {
      case 1: {  // in the plane, inside or outside
        const double s = 2 * u(rng), t = 2 * u(rng);
        p = detail::add(a, detail::add(detail::mul(detail::sub(b, a), s), detail::mul(detail::sub(c, a), t)));
        break;
      }
      case 2: p = detail::add(b, detail::mul(detail::sub(c, b), w01(rng))); break;  // on an edge
      case 3: p = (i % 2) ? a : c; break;                                            // on a corner
      case 4: {  // off an edge, along the face's normal and across the edge
        const P3 e = detail::add(a, detail::mul(detail::sub(b, a), w01(rng)));
        const P3 n = detail::cross(detail::sub(b, a), detail::sub(c, a));
        p = detail::add(e, detail::mul(n, 1e-9 * u(rng)));
        break;
      }
      default: break;
    }
    const detail::SegmentTriangle fast = detail::closest_point_triangle(p, a, b, c);
    const detail::SegmentTriangle general = detail::closest_segment_triangle_general(p, p, a, b, c);
    ASSERT_EQ(std::memcmp(&fast.distance2, &general.distance2, sizeof(double)), 0) << i;
    ASSERT_EQ(std::memcmp(&fast.s, &general.s, sizeof(double)), 0) << i;
    ASSERT_EQ(std::memcmp(fast.on_triangle.point.data(), general.on_triangle.point.data(), 3 * sizeof(double)), 0) << i;
    ASSERT_EQ(std::memcmp(fast.on_triangle.w.data(), general.on_triangle.w.data(), 3 * sizeof(double)), 0) << i;
    const detail::TrianglePoint face = detail::closest_on_triangle(p, a, b, c);
    edge_won += std::memcmp(face.point.data(), general.on_triangle.point.data(), 3 * sizeof(double)) != 0;
  }
  std::printf("the edge test changed the nearest point in %d of 200000 cases\n", edge_won);
}

// The lazy refit's margin check at its edge: a surface vertex moved a hair beyond the margin from
// where the BVH last saw it must refit the BVH (else a tool could miss a triangle that left its
// box), one moved just within it need not. Float levels compare in float with a 1e-5 shrink of
// the margin's square (tool_contact.cpp, left_margin): they may refit early, never late.
template <class T>
void margin_edge(Precision precision) {
  WorldDef wd;
  wd.gravity = {0, 0, 0};
  wd.precision = precision;
  World w(wd);
  BodyDef bd;
  bd.mesh.min = {0, 0, 0};
  bd.mesh.max = {0.04, 0.02, 0.02};
  bd.mesh.cells = {4, 2, 2};
  w.add_body(bd);
  Level<T>& L = w.level<T>(0);
  const Vec3d origin = w.body_origin(0);
  Executor exec(1);
  detail::EmbreeDevice device;
  detail::LevelContact<T> lc = detail::make_level_contact(device, L, 0, 0, exec, ToolPose{});
  ASSERT_GT(lc.margin, 0);
  ToolShapeDef shape;
  shape.radius = 0.001;
  ToolPose far;
  far.position = {origin[0] + 1, origin[1], origin[2]};  // touches nothing: only the margin check acts
  std::string error;
  const auto n = std::size_t(lc.surface_nodes[lc.surface_nodes.size() / 2]);
  const auto moved = [&](std::size_t node, double factor) {  // the node at factor x margin along x from its rest, then a query
    for (int k = 0; k < 3; ++k) L.x[k] = L.X[k];
    EXPECT_TRUE(detail::find_tool_contacts(lc, L, shape, far, far, origin, exec, error)) << error;  // refit at rest if needed
    const auto at_rest = lc.refits;
    L.x[0][node] = T(double(L.X[0][node]) + factor * lc.margin);
    EXPECT_TRUE(detail::find_tool_contacts(lc, L, shape, far, far, origin, exec, error)) << error;
    return lc.refits - at_rest;
  };
  const auto moved_by = [&](double factor) { return moved(n, factor); };
  EXPECT_EQ(moved_by(1 + 1e-5), 1) << "a vertex beyond the margin did not refit the BVH";
  EXPECT_EQ(moved_by(1.01), 1);
  EXPECT_EQ(moved_by(0.99), 0) << "a vertex well within the margin refit the BVH";
  EXPECT_EQ(moved_by(0.5), 0);

  // Only simulated vertices are read (LevelContact::simulated, from the node states): an inactive
  // node (a multiresolution level's part where another level is active) moved beyond the margin
  // refits nothing, and no triangle with it as a corner is a hit anyway; a simulated one still does.
  // Node n made inactive, with another node m of the surface kept simulated.
  const auto m = std::size_t(lc.surface_nodes[0]);
  ASSERT_NE(m, n);
  L.state[n] = kNodeInactive;
  detail::note_simulated_surface(lc, L);
  EXPECT_EQ(lc.simulated.size(), lc.surface_nodes.size() - 1);
  EXPECT_EQ(moved_by(2), 0) << "an inactive vertex moved beyond the margin refit the BVH";
  EXPECT_EQ(moved(m, 1 + 1e-5), 1) << "a simulated vertex beyond the margin did not refit the BVH";
  EXPECT_EQ(moved(m, 0.99), 0);
  // Simulated again: read again (the list is empty when every vertex is simulated).
  L.state[n] = kNodeFree;
  detail::note_simulated_surface(lc, L);
  EXPECT_TRUE(lc.simulated.empty());
  EXPECT_EQ(moved_by(1.01), 1);
}

TEST(ToolCollision, AVertexBeyondTheMarginRefitsTheBvhFloat) { margin_edge<float>(Precision::float32); }
TEST(ToolCollision, AVertexBeyondTheMarginRefitsTheBvhDouble) { margin_edge<double>(Precision::float64); }

}  // namespace
}  // namespace pliant
