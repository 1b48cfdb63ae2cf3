// Lengths in a scene are in metres of the body as simulated, after `scale` (docs/scene-format.md):
// a surface drawn in millimetres with "scale": 0.001 and "cell_size": 0.004 is meshed with 4 mm
// cells, not 4 um ones (the mesher was asked for 0.004 in the file's units, then the mesh was
// scaled: a million times more tets, or a refusal). The same surface in mm and in m gives the
// same mesh; an implicit shape scaled by 2 is the shape's mesh at half the cell size, scaled.
// Needs CGAL: without it meshing says so (tests/meshing).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "pliant/meshing.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

namespace fs = std::filesystem;

#ifdef PLIANT_HAS_CGAL

// A closed box surface [0, a] x [0, b] x [0, c] in OFF, in the units of `unit` (the file says
// 0.1 or 100 for 0.1 m).
fs::path write_box_off(const std::string& name, double unit) {
  const fs::path dir = fs::temp_directory_path() / ("pliant_test_scaled_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const double a = 0.1 / unit, b = 0.06 / unit, c = 0.04 / unit;
  const double v[8][3] = {{0, 0, 0}, {a, 0, 0}, {a, b, 0}, {0, b, 0}, {0, 0, c}, {a, 0, c}, {a, b, c}, {0, b, c}};
  const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                        {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  std::ofstream out(dir / name);
  out.precision(17);
  out << "OFF\n8 12 0\n";
  for (const auto& p : v) out << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
  for (const auto& t : f) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  return dir / name;
}

MeshSourceDef surface(const fs::path& file, double cell_size, double scale) {
  MeshSourceDef m;
  m.kind = MeshSourceDef::Kind::surface;
  m.path = file;
  m.cell_size = cell_size;
  m.scale = scale;
  return m;
}

double volume_of(const TetMesh& m) {
  double v = 0;
  for (const Tet& t : m.tets) v += signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
  return v;
}

TEST(ScaledMeshing, TheSameSurfaceInMillimetresAndInMetresGivesTheSameMesh) {
  const double cell = 0.01;  // m
  const TetMesh in_m = build_mesh(surface(write_box_off("box_m.off", 1.0), cell, 1.0));
  const TetMesh in_mm = build_mesh(surface(write_box_off("box_mm.off", 1e-3), cell, 1e-3));
  std::printf("box 0.1 x 0.06 x 0.04 m at cell_size %g m: %zu tets, %zu nodes from metres; %zu tets, %zu nodes from "
              "millimetres\n", cell, in_m.tet_count(), in_m.node_count(), in_mm.tet_count(), in_mm.node_count());
  ASSERT_GT(in_m.tet_count(), 100u);
  // measured 5.4e-20 m^3 (2 ulp of the volume, summed over 1184 tets)
  EXPECT_NEAR(volume_of(in_m), 0.1 * 0.06 * 0.04, 5e-19);
  // measured 1.9e-19 m^3 (the box is meshed exactly)
  EXPECT_NEAR(volume_of(in_mm), 0.1 * 0.06 * 0.04, 1e-18);
  // The same resolution: CGAL's refinement is scale-invariant up to floating point, so the two
  // meshes differ in a few tets (measured: 1184 and 1198 tets, +1.2%; mean edge lengths -0.8%).
  // With cell_size applied before scale, the mm mesh was refused (about 1e12 tets). Tolerances:
  // 2.5x to 5x what was measured.
  auto mean_edge = [](const TetMesh& m) {
    double sum = 0;
    for (const Tet& t : m.tets)
      for (int a = 0; a < 4; ++a)
        for (int c = a + 1; c < 4; ++c) {
          const Vec3d p = m.point(t[a]), q = m.point(t[c]);
          sum += std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
        }
    return sum / (6.0 * double(m.tet_count()));
  };
  const double count_ratio = double(in_mm.tet_count()) / double(in_m.tet_count());
  const double edge_ratio = mean_edge(in_mm) / mean_edge(in_m);
  std::printf("tets mm / m %.4f, mean edge mm / m %.4f (%.4g m)\n", count_ratio, edge_ratio, mean_edge(in_m));
  EXPECT_NEAR(count_ratio, 1.0, 0.06);
  EXPECT_NEAR(edge_ratio, 1.0, 0.02);
  EXPECT_GT(mean_edge(in_m), 0.5 * cell);
  EXPECT_LT(mean_edge(in_m), 2 * cell);
}

TEST(ScaledMeshing, AnImplicitShapeScaledIsItsMeshAtTheScaledCellSize) {
  MeshSourceDef twice;
  twice.kind = MeshSourceDef::Kind::implicit;
  twice.shape = "sphere";
  twice.cell_size = 0.04;  // m, of the sphere of radius 0.1 m
  twice.scale = 2;
  const TetMesh a = build_mesh(twice);
  TetMesh b = mesh_implicit_shape("sphere", 0.02);  // the mesher's own size, then as build_mesh does
  transform_mesh(b, 2, {0, 0, 0});
  renumber_for_locality(b);
  ASSERT_EQ(a.tet_count(), b.tet_count());
  EXPECT_EQ(a.points, b.points);  // bit for bit: scaling by 2 is exact
  EXPECT_EQ(a.tets, b.tets);
}

TEST(ScaledMeshing, ACellSizeTooSmallIsReportedInTheScenesUnits) {
  // 1 um cells in a 0.1 m box: refused, saying which cell_size and scale the user gave.
  try {
    build_mesh(surface(write_box_off("box_small.off", 1e-3), 1e-6, 1e-3));
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cell_size 1e-06 m"), std::string::npos) << msg;
    EXPECT_NE(msg.find("scale 0.001"), std::string::npos) << msg;
  }
}

#else
TEST(ScaledMeshing, NeedsCgal) { EXPECT_FALSE(meshing_available()); }
#endif

}  // namespace
}  // namespace pliant
