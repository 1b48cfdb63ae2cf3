// Mesh quality measures and boundary extraction on tets whose answers are known in closed form:
// the regular tet, the right-corner tet, unit cubes cut into 5 or 6 tets, n x n x n grids.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "pliant/mesh_quality.hpp"

namespace pliant {
namespace {

double det3(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}
Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double volume6(const TetMesh& m, const Tet& t) {  // 6 * signed volume
  const Vec3d a = m.point(t[0]);
  return det3(sub(m.point(t[1]), a), sub(m.point(t[2]), a), sub(m.point(t[3]), a));
}

// Swaps two corners of every negative tet (the tests build tets by hand).
void orient(TetMesh& m) {
  for (Tet& t : m.tets)
    if (volume6(m, t) < 0) std::swap(t[2], t[3]);
}

// n x n x n unit cubes of side 1/n over [0,1]^3; each cube cut into 6 Kuhn tets around its
// (0,0,0)-(1,1,1) diagonal, or into 5 tets with alternating orientation so faces match.
TetMesh cube_grid(int n, int tets_per_cell) {
  TetMesh m;
  const auto id = [n](int i, int j, int k) { return static_cast<std::int32_t>(i + (n + 1) * (j + (n + 1) * k)); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.points.insert(m.points.end(), {double(i) / n, double(j) / n, double(k) / n});
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        std::int32_t c[8];  // corner b: bit 0 = +x, bit 1 = +y, bit 2 = +z
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1));
        if (tets_per_cell == 6) {
          const int axes[6][3] = {{1, 2, 4}, {1, 4, 2}, {2, 1, 4}, {2, 4, 1}, {4, 1, 2}, {4, 2, 1}};
          for (const auto& a : axes) m.tets.push_back({c[0], c[a[0]], c[a[0] + a[1]], c[7]});
        } else {
          // Odd-parity cells mirror the split in x so the face diagonals of neighbours agree.
          auto cc = [&](int b) { return (i + j + k) % 2 ? c[b ^ 1] : c[b]; };
          m.tets.push_back({cc(1), cc(2), cc(4), cc(7)});  // central tet, volume 1/3 of the cell
          m.tets.push_back({cc(0), cc(1), cc(2), cc(4)});
          m.tets.push_back({cc(3), cc(1), cc(2), cc(7)});
          m.tets.push_back({cc(5), cc(1), cc(4), cc(7)});
          m.tets.push_back({cc(6), cc(2), cc(4), cc(7)});
        }
      }
  orient(m);
  return m;
}

TEST(MeshQuality, RegularTet) {
  TetMesh m;
  m.points = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};  // edge 2*sqrt(2)
  m.tets = {{0, 1, 2, 3}};
  orient(m);
  const MeshQuality q = compute_mesh_quality(m);
  const double dihedral = std::acos(1.0 / 3.0) * 180 / std::numbers::pi;  // 70.5288 deg
  EXPECT_NEAR(q.min_dihedral_deg, 70.528779, 1e-6);
  EXPECT_NEAR(q.min_dihedral_deg, dihedral, 1e-9);
  EXPECT_NEAR(q.max_dihedral_deg, dihedral, 1e-9);
  // measured 1.1e-16
  EXPECT_NEAR(q.worst_aspect_ratio, 1.0, 1e-15);
  const double edge = 2 * std::sqrt(2.0);
  EXPECT_NEAR(q.min_edge, edge, 1e-12);
  EXPECT_NEAR(q.max_edge, edge, 1e-12);
  EXPECT_NEAR(q.min_altitude, edge * std::sqrt(2.0 / 3.0), 1e-12);
  EXPECT_NEAR(q.volume, 8.0 / 3.0, 1e-12);  // edge^3 / (6 sqrt 2)
  EXPECT_EQ(q.nodes, 4u);
  EXPECT_EQ(q.tets, 1u);
  EXPECT_EQ(q.boundary_triangles, 4u);
  EXPECT_EQ(q.bbox_min, (Vec3d{-1, -1, -1}));
  EXPECT_EQ(q.bbox_max, (Vec3d{1, 1, 1}));
}

TEST(MeshQuality, RightCornerTet) {
  TetMesh m;
  m.points = {0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0, 2};
  m.tets = {{0, 1, 2, 3}};
  const MeshQuality q = compute_mesh_quality(m);
  EXPECT_NEAR(q.max_dihedral_deg, 90.0, 1e-9);  // edges at the right corner
  EXPECT_NEAR(q.min_dihedral_deg, std::acos(1 / std::sqrt(3.0)) * 180 / std::numbers::pi, 1e-9);  // 54.7356
  EXPECT_NEAR(q.min_dihedral_deg, 54.735610, 1e-6);
  // Longest edge 2 sqrt 2, smallest altitude 2/sqrt 3 (onto the slanted face): sqrt6*sqrt(2/3)=2.
  // measured 2.2e-16
  EXPECT_NEAR(q.worst_aspect_ratio, 2.0, 2e-15);
  EXPECT_NEAR(q.min_altitude, 2 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(q.min_edge, 2.0, 1e-12);
  EXPECT_NEAR(q.max_edge, 2 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(q.volume, 8.0 / 6.0, 1e-12);
}

TEST(MeshQuality, InvertedTetSameMeasures) {
  TetMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.tets = {{0, 2, 1, 3}};  // negative orientation
  const MeshQuality q = compute_mesh_quality(m);
  EXPECT_NEAR(q.volume, 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(q.max_dihedral_deg, 90.0, 1e-9);
  // measured 2.2e-16
  EXPECT_NEAR(q.worst_aspect_ratio, 2.0, 2e-15);
}

TEST(MeshQuality, FlatTetHasInfiniteAspect) {
  TetMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  m.tets = {{0, 1, 2, 3}};
  const MeshQuality q = compute_mesh_quality(m);
  EXPECT_EQ(q.volume, 0.0);
  EXPECT_EQ(q.min_altitude, 0.0);
  EXPECT_TRUE(std::isinf(q.worst_aspect_ratio));
}

TEST(MeshQuality, EmptyMesh) {
  const MeshQuality q = compute_mesh_quality(TetMesh{});
  EXPECT_EQ(q.nodes, 0u);
  EXPECT_EQ(q.boundary_triangles, 0u);
  EXPECT_EQ(q.min_edge, 0.0);
  EXPECT_EQ(q.volume, 0.0);
}

// Divergence theorem with F = x / 3: V = sum over boundary triangles of (centroid . n A) / 3,
// true only if every triangle faces outwards (and the boundary is closed).
double divergence_volume(const TetMesh& m) {
  double v = 0;
  for (const auto& tri : boundary_triangles(m.tets)) {
    const Vec3d a = m.point(tri[0]), b = m.point(tri[1]), c = m.point(tri[2]);
    const Vec3d centroid{(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3};
    v += det3(centroid, sub(b, a), sub(c, a)) / 2 / 3;  // centroid . ((b-a)x(c-a)/2) / 3
  }
  return v;
}

class CubeSplit : public ::testing::TestWithParam<int> {};

TEST_P(CubeSplit, OneCube) {
  const TetMesh m = cube_grid(1, GetParam());
  ASSERT_EQ(m.tet_count(), static_cast<std::size_t>(GetParam()));
  const MeshQuality q = compute_mesh_quality(m);
  // measured 1.1e-16 (146, 150)
  EXPECT_NEAR(q.volume, 1.0, 1e-15);
  EXPECT_EQ(q.boundary_triangles, 12u);
  EXPECT_NEAR(q.min_edge, 1.0, 1e-14);
  EXPECT_NEAR(q.max_edge, std::sqrt(GetParam() == 6 ? 3.0 : 2.0), 1e-14);
  EXPECT_NEAR(divergence_volume(m), 1.0, 1e-15);
}

TEST_P(CubeSplit, Grid) {
  for (int n : {2, 3, 4}) {
    const TetMesh m = cube_grid(n, GetParam());
    const MeshQuality q = compute_mesh_quality(m);
    // measured 5.8e-15 (157), 1.4e-15 (159), 2.8e-17 (160)
    EXPECT_NEAR(q.volume, 1.0, 5e-14) << n;
    EXPECT_EQ(q.boundary_triangles, static_cast<std::size_t>(12 * n * n)) << n;
    EXPECT_NEAR(divergence_volume(m), 1.0, 1e-14) << n;
    EXPECT_NEAR(q.min_altitude, GetParam() == 6 ? 1.0 / n / std::sqrt(2.0) : 1.0 / n / std::sqrt(3.0), 2.5e-16);
    EXPECT_EQ(q.bbox_max, (Vec3d{1, 1, 1}));
  }
}

INSTANTIATE_TEST_SUITE_P(TetsPerCell, CubeSplit, ::testing::Values(5, 6));

TEST(BoundaryTriangles, OutwardEachFaceAndDeterministicOrder) {
  const TetMesh m = cube_grid(2, 6);
  const auto tris = boundary_triangles(m.tets);
  // Every boundary triangle lies on a cube face and its normal points out of the cube.
  for (const auto& tri : tris) {
    const Vec3d a = m.point(tri[0]), b = m.point(tri[1]), c = m.point(tri[2]);
    const Vec3d ab = sub(b, a), ac = sub(c, a);
    const Vec3d nrm{ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]};
    int axis = -1;
    for (int d = 0; d < 3; ++d)
      if (a[d] == b[d] && b[d] == c[d] && (a[d] == 0 || a[d] == 1)) axis = d;
    ASSERT_GE(axis, 0) << "triangle not on the cube surface";
    EXPECT_GT(nrm[axis] * (a[axis] == 1 ? 1 : -1), 0) << "inward triangle on axis " << axis;
  }
  // Order: by owning tet, then local face; recomputing gives the same list.
  EXPECT_EQ(tris, boundary_triangles(m.tets));
  std::size_t last_tet = 0;
  for (const auto& tri : tris) {
    std::size_t owner = m.tet_count();
    for (std::size_t t = 0; t < m.tet_count() && owner == m.tet_count(); ++t) {
      const std::set<std::int32_t> s(m.tets[t].begin(), m.tets[t].end());
      if (s.count(tri[0]) && s.count(tri[1]) && s.count(tri[2])) owner = t;
    }
    ASSERT_LT(owner, m.tet_count());
    EXPECT_GE(owner, last_tet);
    last_tet = owner;
  }
}

TEST(BoundaryTriangles, TwoTetsShareOneFace) {
  // Two tets glued on face (0,1,2): 6 boundary triangles, the shared face is not one of them.
  const std::vector<Tet> tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  const auto tris = boundary_triangles(tets);
  ASSERT_EQ(tris.size(), 6u);
  for (const auto& tri : tris) {
    std::array<std::int32_t, 3> s = tri;
    std::sort(s.begin(), s.end());
    EXPECT_NE(s, (std::array<std::int32_t, 3>{0, 1, 2}));
  }
  // First tet's faces come first, in local face order 0 (opposite corner 0), 1, 2, 3 minus
  // the shared face 3: (1,2,3), (0,3,2), (0,1,3).
  EXPECT_EQ(tris[0], (std::array<std::int32_t, 3>{1, 2, 3}));
  EXPECT_EQ(tris[1], (std::array<std::int32_t, 3>{0, 3, 2}));
  EXPECT_EQ(tris[2], (std::array<std::int32_t, 3>{0, 1, 3}));
}

}  // namespace
}  // namespace pliant
