// Meshing (pliant_meshing): the implicit shapes in every build; with CGAL, tetrahedralisation
// of shapes and surface files (validity, volume, reproducibility, errors); without CGAL, the
// InputError saying so.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <thread>
#include <unistd.h>

#include "../support/special_files.hpp"
#include "pliant/error.hpp"
#include "pliant/meshing.hpp"

namespace fs = std::filesystem;
using namespace pliant;

namespace {

// Message of the InputError thrown by f ("" if it throws nothing; other exceptions fail).
template <class F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// Volume of {f < 0} by counting cell centres of a grid of spacing h over the cube of half-side r.
double grid_volume(const std::string& shape, double r, double h) {
  const int n = static_cast<int>(std::ceil(2 * r / h));
  std::size_t inside = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        inside += implicit_shape_value(shape, {-r + (i + 0.5) * h, -r + (j + 0.5) * h,
                                               -r + (k + 0.5) * h}) < 0;
  return static_cast<double>(inside) * h * h * h;
}

// Sum of tet volumes; fails the test if any tet is not positively oriented, or (given a cell
// size s) if a tet is smaller than 1e-3 s^3: a sliver or a speck that would cripple an explicit
// time step. Exuded Mesh_3 meshes have a smallest tet of 1e-3 to 5e-2 s^3.
[[maybe_unused]] double checked_volume(const TetMesh& m, double s = 0) {  // used with CGAL only
  double total = 0, smallest = INFINITY;
  std::size_t bad = 0;
  for (const Tet& t : m.tets) {
    const double v = signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
    bad += !(v > 0);
    total += v;
    smallest = std::min(smallest, v);
  }
  EXPECT_EQ(bad, 0u) << "non-positive tets";
  if (s > 0) {
    EXPECT_GE(smallest, 1e-3 * s * s * s) << "sliver";
  }
  return total;
}

// A temporary folder for the surface files written by the tests, removed at exit.
struct TempDir {
  fs::path path = fs::temp_directory_path() / ("pliant_test_meshing_" + std::to_string(getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
};

// Cube [0, a]^3 as an OFF file of 12 outward triangles; drop_top leaves out the z = a face.
[[maybe_unused]] fs::path write_cube_off(const fs::path& file, double a, bool drop_top) {
  std::ofstream out(file);
  const int faces = drop_top ? 10 : 12;
  out << "OFF\n8 " << faces << " 0\n";
  for (int i = 0; i < 8; ++i) out << a * (i & 1) << ' ' << a * ((i >> 1) & 1) << ' ' << a * ((i >> 2) & 1) << '\n';
  const int tris[12][3] = {{0, 2, 1}, {1, 2, 3},   // z = 0
                           {0, 1, 4}, {1, 5, 4},   // y = 0
                           {0, 4, 2}, {2, 4, 6},   // x = 0
                           {1, 3, 5}, {3, 7, 5},   // x = a
                           {2, 6, 3}, {3, 6, 7},   // y = a
                           {4, 5, 6}, {5, 7, 6}};  // z = a (last)
  for (int f = 0; f < faces; ++f) out << "3 " << tris[f][0] << ' ' << tris[f][1] << ' ' << tris[f][2] << '\n';
  return file;
}

// Regular octahedron |x| + |y| + |z| <= r as an OBJ file of 8 triangles.
[[maybe_unused]] fs::path write_octahedron_obj(const fs::path& file, double r) {
  std::ofstream out(file);
  out << "v " << r << " 0 0\nv " << -r << " 0 0\nv 0 " << r << " 0\nv 0 " << -r << " 0\n"
      << "v 0 0 " << r << "\nv 0 0 " << -r << "\n";
  // vertices 1..6: +x -x +y -y +z -z
  out << "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
  return file;
}

}  // namespace

// ---- implicit shapes: every build -----------------------------------------------------------

TEST(ImplicitShapes, NamesAndSigns) {
  const auto names = implicit_shape_names();
  for (const char* n : {"organ", "sphere", "capsule"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  for (const auto& n : names) {
    EXPECT_LT(implicit_shape_value(n, {0, 0, 0}), 0) << n;
    const double r = implicit_shape_bounding_radius(n);
    for (const Vec3d& p : {Vec3d{r, 0, 0}, Vec3d{0, -r, 0}, Vec3d{0, 0, r}, Vec3d{-r, 0, 0}})
      EXPECT_GT(implicit_shape_value(n, p), 0) << n;
  }
  EXPECT_NEAR(implicit_shape_value("sphere", {0.05, 0, 0}), 0, 1e-15);
  EXPECT_NEAR(implicit_shape_value("capsule", {0.1, 0, 0}), 0, 1e-15);
  EXPECT_NEAR(implicit_shape_value("capsule", {0, 0.03, 0}), 0, 1e-15);
}

TEST(ImplicitShapes, UnknownNameListsKnownOnes) {
  const std::string msg = input_error([] { implicit_shape_value("kidney", {0, 0, 0}); });
  EXPECT_TRUE(contains(msg, "kidney")) << msg;
  EXPECT_TRUE(contains(msg, "organ") && contains(msg, "sphere") && contains(msg, "capsule")) << msg;
}

TEST(ImplicitShapes, OrganDimensions) {
  // Extent of the inside on a 1 mm grid: about 0.20 x 0.12 x 0.08 m around the origin.
  const double h = 0.001, r = implicit_shape_bounding_radius("organ");
  Vec3d lo{1, 1, 1}, hi{-1, -1, -1};
  const int n = static_cast<int>(2 * r / h);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      for (int k = 0; k <= n; ++k) {
        const Vec3d p{-r + i * h, -r + j * h, -r + k * h};
        if (implicit_shape_value("organ", p) < 0)
          for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], p[d]), hi[d] = std::max(hi[d], p[d]);
      }
  const Vec3d size{0.20, 0.12, 0.08};
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(hi[d] - lo[d], size[d], 0.01) << "axis " << d;
    // measured 1.0e-3 m
    EXPECT_NEAR(hi[d] + lo[d], 0.0, 0.01) << "axis " << d;  // centred near the origin
  }
  const double v = grid_volume("organ", r, 0.002);
  std::printf("organ: extent %.3f x %.3f x %.3f m, volume %.4g m^3\n", hi[0] - lo[0], hi[1] - lo[1],
              hi[2] - lo[2], v);
}

// ---- without CGAL ---------------------------------------------------------------------------

#ifndef PLIANT_HAS_CGAL
TEST(Meshing, WithoutCgalSaysSo) {
  ASSERT_FALSE(meshing_available());
  EXPECT_TRUE(contains(input_error([] { mesh_implicit_shape("organ", 0.01); }), "without CGAL"));
  EXPECT_TRUE(contains(input_error([] { mesh_surface_file("x.off", 0.01); }), "without CGAL"));
}

// ---- with CGAL ------------------------------------------------------------------------------

#else  // the CGAL tests exist only in builds with CGAL
class CgalMeshing : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(meshing_available());
  }
};

TEST_F(CgalMeshing, OrganIsValidWithTheRightVolume) {
  const TetMesh m = mesh_implicit_shape("organ", 0.01);
  ASSERT_GT(m.tet_count(), 1000u);
  const double v = checked_volume(m, 0.01);
  const double exact = grid_volume("organ", implicit_shape_bounding_radius("organ"), 0.001);
  std::printf("organ s=0.01: %zu tets, %zu nodes, volume %.5g (grid %.5g, %+.2f %%)\n",
              m.tet_count(), m.node_count(), v, exact, 100 * (v / exact - 1));
  EXPECT_NEAR(v / exact, 1.0, 0.03);
}

TEST_F(CgalMeshing, SphereAndCapsuleVolumes) {
  const double pi = std::numbers::pi;
  const struct { const char* name; double exact; } cases[] = {
      {"sphere", 4.0 / 3 * pi * std::pow(0.05, 3)},
      {"capsule", pi * 0.03 * 0.03 * 0.14 + 4.0 / 3 * pi * std::pow(0.03, 3)}};
  for (const auto& c : cases) {
    const TetMesh m = mesh_implicit_shape(c.name, 0.01);
    const double v = checked_volume(m, 0.01);
    std::printf("%s s=0.01: %zu tets, volume %+.2f %% off\n", c.name, m.tet_count(), 100 * (v / c.exact - 1));
    EXPECT_NEAR(v / c.exact, 1.0, 0.04) << c.name;
  }
}

TEST_F(CgalMeshing, Reproducible) {
  const TetMesh a = mesh_implicit_shape("organ", 0.01);
  const TetMesh b = mesh_implicit_shape("organ", 0.01);
  EXPECT_EQ(a.points, b.points);  // bit-identical doubles
  EXPECT_EQ(a.tets, b.tets);
  TetMesh from_thread;  // another thread: another malloc arena, other addresses
  std::thread([&] { from_thread = mesh_implicit_shape("organ", 0.01); }).join();
  EXPECT_EQ(a.points, from_thread.points);
  EXPECT_EQ(a.tets, from_thread.tets);
  TempDir dir;
  const fs::path cube = write_cube_off(dir.path / "cube.off", 0.1, false);
  const TetMesh c = mesh_surface_file(cube, 0.02);
  const TetMesh d = mesh_surface_file(cube, 0.02);
  EXPECT_EQ(c.points, d.points);
  EXPECT_EQ(c.tets, d.tets);
  // A fingerprint to compare between runs of this program (separate processes).
  std::uint64_t hash = 1469598103934665603ull;
  auto mix = [&](const void* data, std::size_t bytes) {
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ static_cast<const unsigned char*>(data)[i]) * 1099511628211ull;
  };
  for (const TetMesh* m : {&a, &c}) {
    mix(m->points.data(), m->points.size() * sizeof(double));
    mix(m->tets.data(), m->tets.size() * sizeof(Tet));
  }
  std::printf("fingerprint of the organ (0.01) and cube (0.02) meshes: %016llx\n",
              static_cast<unsigned long long>(hash));
}

TEST_F(CgalMeshing, ClosedSurfaceFiles) {
  TempDir dir;
  {  // cube of side 0.1 m, 12 triangles, sharp edges protected: volume nearly exact
    const TetMesh m = mesh_surface_file(write_cube_off(dir.path / "cube.off", 0.1, false), 0.02);
    const double v = checked_volume(m, 0.02);
    std::printf("cube.off s=0.02: %zu tets, volume %+.3f %% off\n", m.tet_count(), 100 * (v / 1e-3 - 1));
    // measured 6.7e-16: a polyhedron is meshed exactly
    EXPECT_NEAR(v / 1e-3, 1.0, 5e-15);
  }
  {  // octahedron |x|+|y|+|z| <= 0.08: volume 4 r^3 / 3
    const double r = 0.08, exact = 4 * r * r * r / 3;
    const TetMesh m = mesh_surface_file(write_octahedron_obj(dir.path / "octa.obj", r), 0.015);
    const double v = checked_volume(m, 0.015);
    std::printf("octa.obj s=0.015: %zu tets, volume %+.3f %% off\n", m.tet_count(), 100 * (v / exact - 1));
    EXPECT_NEAR(v / exact, 1.0, 5e-15);  // measured 0: a polyhedron is meshed exactly
  }
  {  // cube of quads (OBJ), triangulated on reading
    const fs::path file = dir.path / "quads.obj";
    std::ofstream out(file);
    for (int i = 0; i < 8; ++i) out << "v " << 0.1 * (i & 1) << ' ' << 0.1 * ((i >> 1) & 1) << ' ' << 0.1 * ((i >> 2) & 1) << '\n';
    out << "f 1 3 4 2\nf 1 2 6 5\nf 1 5 7 3\nf 2 4 8 6\nf 3 7 8 4\nf 5 6 8 7\n";
    out.close();
    const double v = checked_volume(mesh_surface_file(file, 0.025));
    // measured 6.7e-16: a polyhedron is meshed exactly
    EXPECT_NEAR(v / 1e-3, 1.0, 5e-15);
  }
}

// Real organic surfaces from the SOFA data (coordinates in their own units, taken as metres):
// the liver has 7 pairs of self-intersecting faces (repaired), the raptor is an OBJ of quads
// that ends with a NUL byte (read leniently); on both, feature protection leaves specks and the
// mesher falls back to a smooth domain.
TEST_F(CgalMeshing, SharedSurfaces) {
  const fs::path dir = PLIANT_DATA_MESHES;
  const struct { const char* file; double s, volume; } cases[] = {
      // reference: the surface's own volume (pliant info); measured -1.04% (liver), -2.6% (raptor)
      {"liver-smooth.obj", 0.3, 39.2674}, {"raptor_8kp.obj", 0.3, 27.7636}};
  for (const auto& c : cases) {
    ASSERT_TRUE(fs::is_regular_file(dir / c.file)) << c.file << " is missing: the repository ships it";
    const auto t0 = std::chrono::steady_clock::now();
    const TetMesh m = mesh_surface_file(dir / c.file, c.s);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double v = checked_volume(m, c.s);
    std::printf("%s s=%.2f: %zu tets, volume %.4g, %.2f s\n", c.file, c.s, m.tet_count(), v, seconds);
    EXPECT_NEAR(v / c.volume, 1.0, 0.03) << c.file;  // the raptor's volume went unchecked before
  }
}

TEST_F(CgalMeshing, BadSurfaceFiles) {
  TempDir dir;
  const fs::path open = write_cube_off(dir.path / "open_cube.off", 0.1, true);
  std::string msg = input_error([&] { mesh_surface_file(open, 0.02); });
  EXPECT_TRUE(contains(msg, open.string()) && contains(msg, "open")) << msg;
  EXPECT_TRUE(contains(msg, "4 border edges")) << msg;

  const fs::path missing = dir.path / "missing.stl";
  msg = input_error([&] { mesh_surface_file(missing, 0.02); });
  EXPECT_TRUE(contains(msg, missing.string())) << msg;

  const fs::path garbage = dir.path / "garbage.off";
  std::ofstream(garbage) << "this is not an OFF file\n";
  msg = input_error([&] { mesh_surface_file(garbage, 0.02); });
  EXPECT_TRUE(contains(msg, garbage.string())) << msg;

  const fs::path msh = dir.path / "volume.msh";
  std::ofstream(msh) << "$MeshFormat\n";
  msg = input_error([&] { mesh_surface_file(msh, 0.02); });
  EXPECT_TRUE(contains(msg, msh.string()) && contains(msg, "extension")) << msg;

  // Two tetrahedra glued along one edge: that edge has four faces.
  const fs::path nonmanifold = dir.path / "bowtie.off";
  std::ofstream(nonmanifold) << "OFF\n6 8 0\n0 0 0\n0 0 1\n1 0 0.5\n0 1 0.5\n-1 0 0.5\n0 -1 0.5\n"
                                "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
                                "3 0 1 4\n3 0 5 1\n3 0 4 5\n3 1 5 4\n";
  msg = input_error([&] { mesh_surface_file(nonmanifold, 0.2); });
  EXPECT_TRUE(contains(msg, nonmanifold.string()) && contains(msg, "manifold")) << msg;

  const fs::path cube = write_cube_off(dir.path / "cube.off", 0.1, false);
  EXPECT_TRUE(contains(input_error([&] { mesh_surface_file(cube, 0.0); }), "cell_size"));
  EXPECT_TRUE(contains(input_error([&] { mesh_surface_file(cube, 1e-4); }), "too small"));
}

TEST_F(CgalMeshing, BadShapeArguments) {
  std::string msg = input_error([] { mesh_implicit_shape("kidney", 0.01); });
  EXPECT_TRUE(contains(msg, "kidney") && contains(msg, "organ")) << msg;
  for (double s : {0.0, -0.01, std::nan(""), double(INFINITY)}) {
    msg = input_error([&] { mesh_implicit_shape("organ", s); });
    EXPECT_TRUE(contains(msg, "cell_size")) << s << ": " << msg;
  }
  msg = input_error([] { mesh_implicit_shape("organ", 0.0002); });  // ~1e8 tets
  EXPECT_TRUE(contains(msg, "too small")) << msg;
}

// A surface that is a FIFO (CGAL's reader waited on it) or a link to /dev/zero: refused, naming
// the path and what it is, without opening the FIFO.
TEST_F(CgalMeshing, SurfaceFilesMustBeRegularFiles) {
  const fs::path dir = fs::temp_directory_path() / ("pliant_test_meshing_special_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    const special::Fifo fifo(dir / "fifo.stl");
    const std::string msg = input_error([&] { mesh_surface_file(fifo.path(), 0.1); });
    EXPECT_TRUE(contains(msg, "fifo.stl: is a FIFO (named pipe), not a regular file")) << msg;
    EXPECT_FALSE(fifo.opened());
  }
  const fs::path zero = special::link_to_dev_zero(dir / "zero.obj");
  const std::string msg = input_error([&] { mesh_surface_file(zero, 0.1); });
  EXPECT_TRUE(contains(msg, "zero.obj: is a character device")) << msg;
  fs::remove_all(dir);
}

TEST_F(CgalMeshing, OrganSizesAndTimes) {
  for (double s : {0.02, 0.01, 0.007}) {
    const auto t0 = std::chrono::steady_clock::now();
    const TetMesh m = mesh_implicit_shape("organ", s);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("organ s=%.3f m: %7zu tets %6zu nodes  %.3f s\n", s, m.tet_count(), m.node_count(), seconds);
    EXPECT_GT(m.tet_count(), 0u);
  }
}
#endif  // PLIANT_HAS_CGAL
