// Tests of signed_tet_volume, finalize_tet_mesh and transform_mesh on meshes built in memory:
// what finalization accepts, repairs (inverted tets, unused vertices) and rejects (with a
// message naming the source and the cell).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pliant/error.hpp"
#include "pliant/tet_mesh.hpp"

using namespace pliant;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

// Unit cube, 8 corners, 5 positively oriented tets (four corner tets and the middle one).
TetMesh unit_cube() {
  TetMesh m;
  m.points = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
  m.tets = {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6}, {3, 4, 6, 7}, {1, 3, 4, 6}};
  return m;
}

double volume(const TetMesh& m, const Tet& t) {
  return signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
}

double total_volume(const TetMesh& m) {
  double v = 0;
  for (const Tet& t : m.tets) v += volume(m, t);
  return v;
}

// The message of the InputError that finalize_tet_mesh throws (a test failure if none).
std::string finalize_error(TetMesh m, const std::string& source = "/data/test.msh") {
  MeshLoadReport report;
  try {
    finalize_tet_mesh(m, source, report);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "finalize_tet_mesh accepted an invalid mesh";
  return {};
}

}  // namespace

TEST(SignedTetVolume, RightTetIsOneSixthAndSwapFlipsSign) {
  const Vec3d a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0}, d{0, 0, 1};
  EXPECT_DOUBLE_EQ(signed_tet_volume(a, b, c, d), 1.0 / 6.0);
  EXPECT_DOUBLE_EQ(signed_tet_volume(a, c, b, d), -1.0 / 6.0);
  EXPECT_DOUBLE_EQ(signed_tet_volume(b, a, c, d), -1.0 / 6.0);
  // Translation-invariant, scales with the cube of lengths.
  const Vec3d s{2, -3, 5};
  auto shift = [&](Vec3d p, double k) { return Vec3d{k * p[0] + s[0], k * p[1] + s[1], k * p[2] + s[2]}; };
  EXPECT_NEAR(signed_tet_volume(shift(a, 2), shift(b, 2), shift(c, 2), shift(d, 2)), 8.0 / 6.0, 1e-14);
  EXPECT_EQ(signed_tet_volume(a, b, c, Vec3d{1, 1, 0}), 0.0);
}

TEST(Finalize, GoodMeshIsUnchanged) {
  TetMesh m = unit_cube();
  const TetMesh before = m;
  MeshLoadReport report;
  finalize_tet_mesh(m, "cube", report);
  EXPECT_EQ(m.points, before.points);
  EXPECT_EQ(m.tets, before.tets);
  EXPECT_EQ(report.reoriented_tets, 0u);
  EXPECT_EQ(report.dropped_vertices, 0u);
  EXPECT_EQ(report.skipped_cells, 0u);
  EXPECT_NEAR(total_volume(m), 1.0, 1e-14);
}

TEST(Finalize, InvertedTetsAreReorientedAndCounted) {
  TetMesh m = unit_cube();
  std::swap(m.tets[1][0], m.tets[1][1]);
  std::swap(m.tets[4][2], m.tets[4][3]);
  const TetMesh before = m;
  MeshLoadReport report;
  finalize_tet_mesh(m, "cube", report);
  EXPECT_EQ(report.reoriented_tets, 2u);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    EXPECT_GT(volume(m, m.tets[t]), 0.0) << "tet " << t;
    Tet a = m.tets[t], b = before.tets[t];  // same corners, possibly in another order
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b) << "tet " << t;
  }
  EXPECT_NEAR(total_volume(m), 1.0, 1e-14);
}

TEST(Finalize, UnusedVerticesAreDroppedAndIndicesRemapped) {
  // Unused nodes at the front, in the middle and at the end.
  TetMesh cube = unit_cube();
  TetMesh m;
  std::vector<int> new_index;
  m.points = {9, 9, 9};
  for (int i = 0; i < 8; ++i) {
    if (i == 4) m.points.insert(m.points.end(), {7, 7, 7});
    new_index.push_back(static_cast<int>(m.node_count()));
    const Vec3d p = cube.point(i);
    m.points.insert(m.points.end(), p.begin(), p.end());
  }
  m.points.insert(m.points.end(), {5, 5, 5});
  for (Tet t : cube.tets) {
    for (auto& v : t) v = new_index[v];
    m.tets.push_back(t);
  }
  ASSERT_EQ(m.node_count(), 11u);
  MeshLoadReport report;
  finalize_tet_mesh(m, "cube", report);
  EXPECT_EQ(report.dropped_vertices, 3u);
  EXPECT_EQ(m.points, cube.points);  // the survivors keep their order
  EXPECT_EQ(m.tets, cube.tets);
}

TEST(Finalize, DegenerateTetIsRejectedNamingSourceAndCell) {
  TetMesh m = unit_cube();
  m.tets.insert(m.tets.begin() + 2, Tet{0, 1, 2, 3});  // the bottom face: volume 0
  const std::string msg = finalize_error(m, "/path/x.vtu");
  EXPECT_THAT(msg, StartsWith("/path/x.vtu: cell 2: degenerate tetrahedron (volume 0)"));
}

TEST(Finalize, DegeneracyIsJudgedByEachTetsOwnSize) {
  // A millimetre cube is fine...
  TetMesh small = unit_cube();
  for (double& x : small.points) x *= 1e-3;
  MeshLoadReport report;
  EXPECT_NO_THROW(finalize_tet_mesh(small, "mm", report));
  EXPECT_NEAR(total_volume(small), 1e-9, 1e-22);
  // ...but a sliver whose apex is 1e-13 above its base, in a unit-size mesh, is not...
  TetMesh m = unit_cube();
  m.points.insert(m.points.end(), {0.5, 0.5, 1e-13});
  m.tets.push_back(Tet{0, 1, 2, 8});
  EXPECT_THAT(finalize_error(m), HasSubstr(": cell 5: degenerate tetrahedron"));
  // ...and neither is the same sliver shrunk a million times inside a micrometre mesh: the
  // threshold follows the tet's own edges, not the units.
  for (double& x : m.points) x *= 1e-6;
  EXPECT_THAT(finalize_error(m), HasSubstr(": cell 5: degenerate tetrahedron"));
}

// A valid 10 m x 1 mm x 1 mm bar of 2000 x 1 x 1 cells: every tet has a volume of about
// 1e-9 m^3, below 1e-12 x (diagonal of the whole mesh)^3 = 1e-9 m^3, which refused it. Each tet
// is judged by its own edges now.
TEST(Finalize, AThinValidBarIsAccepted) {
  for (int tets_per_cell : {5, 6}) {
    TetMesh bar = make_box_mesh({0, 0, 0}, {10, 0.001, 0.001}, {2000, 1, 1}, tets_per_cell);
    MeshLoadReport report;
    ASSERT_NO_THROW(finalize_tet_mesh(bar, "bar", report)) << tets_per_cell << " tets per cell";
    EXPECT_NEAR(total_volume(bar), 1e-5, 1e-17);
    EXPECT_EQ(report.reoriented_tets, 0u);
  }
}

// One big tet far away made every small healthy tet "degenerate" (the threshold followed the
// bounding box), and the message blamed cell 0, a healthy tet.
TEST(Finalize, AFarAwayTetDoesNotMakeHealthyTetsDegenerate) {
  TetMesh m = unit_cube();
  for (double& x : m.points) x *= 1e-3;  // a millimetre cube...
  const std::int32_t n = std::int32_t(m.node_count());
  m.points.insert(m.points.end(), {1000, 0, 0, 1001, 0, 0, 1000, 1, 0, 1000, 0, 1});  // ...and a 1 m tet 1 km away
  m.tets.push_back(Tet{n, n + 1, n + 2, n + 3});
  MeshLoadReport report;
  ASSERT_NO_THROW(finalize_tet_mesh(m, "two parts", report));
  EXPECT_NEAR(total_volume(m), 1e-9 + 1.0 / 6, 1e-12);
  // A genuinely flat tet among them is still the one named.
  m.points.insert(m.points.end(), {2e-3, 0, 0, 3e-3, 0, 0, 2e-3, 1e-3, 0, 2.5e-3, 0.5e-3, 0});
  m.tets.push_back(Tet{n + 4, n + 5, n + 6, n + 7});
  EXPECT_THAT(finalize_error(m), HasSubstr(": cell 6: degenerate tetrahedron (volume 0)"));
}

TEST(Finalize, OutOfRangeIndicesAreRejected) {
  TetMesh m = unit_cube();
  m.tets[3][2] = 8;
  EXPECT_THAT(finalize_error(m), StartsWith("/data/test.msh: cell 3: refers to node 8, which is not defined"));
  m = unit_cube();
  m.tets[0][0] = -1;
  EXPECT_THAT(finalize_error(m), StartsWith("/data/test.msh: cell 0: refers to node -1"));
}

TEST(Finalize, RepeatedCornerIsRejected) {
  TetMesh m = unit_cube();
  m.tets[4] = {1, 3, 1, 6};
  EXPECT_THAT(finalize_error(m), StartsWith("/data/test.msh: cell 4: degenerate tetrahedron (node 1 appears twice)"));
}

TEST(Finalize, NonFiniteCoordinatesAreRejected) {
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()}) {
    TetMesh m = unit_cube();
    m.points[3 * 5 + 1] = bad;
    EXPECT_THAT(finalize_error(m), StartsWith("/data/test.msh: node 5 has a non-finite coordinate"));
  }
}

TEST(Finalize, EmptyOrMalformedArraysAreRejected) {
  TetMesh no_tets = unit_cube();
  no_tets.tets.clear();
  EXPECT_THAT(finalize_error(no_tets), StartsWith("/data/test.msh: the mesh has no tetrahedra"));
  EXPECT_THAT(finalize_error(TetMesh{}), StartsWith("/data/test.msh: the mesh has no nodes"));
  TetMesh ragged = unit_cube();
  ragged.points.push_back(1.0);
  EXPECT_THAT(finalize_error(ragged), HasSubstr("not a multiple of 3"));
}

TEST(TransformMesh, ScalesAboutOriginThenTranslates) {
  TetMesh m = unit_cube();
  transform_mesh(m, 2.0, {1, -1, 0.5});
  EXPECT_EQ(m.point(0), (Vec3d{1, -1, 0.5}));
  EXPECT_EQ(m.point(6), (Vec3d{3, 1, 2.5}));
  EXPECT_NEAR(total_volume(m), 8.0, 1e-13);
  EXPECT_EQ(m.tets, unit_cube().tets);
}

TEST(TransformMesh, RejectsNonPositiveOrNonFiniteParameters) {
  TetMesh m = unit_cube();
  EXPECT_THROW(transform_mesh(m, 0.0, {0, 0, 0}), InputError);
  EXPECT_THROW(transform_mesh(m, -1.0, {0, 0, 0}), InputError);
  EXPECT_THROW(transform_mesh(m, std::nan(""), {0, 0, 0}), InputError);
  EXPECT_THROW(transform_mesh(m, 1.0, {0, std::numeric_limits<double>::infinity(), 0}), InputError);
  EXPECT_EQ(m.points, unit_cube().points);  // untouched by the failed calls
}
