// Meshes read from files are renumbered for locality when a body is built (build_mesh). A
// "nodes" region counts in the file's numbering, so it must still select the same material
// points, and the body must move as the same body in the file's order would.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <vector>

#include "pliant/mesh_io.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

namespace fs = std::filesystem;

// A beam meshed as a box, nodes and tets shuffled, written as TetGen .node/.ele (0-based).
fs::path write_scrambled_beam(const fs::path& dir) {
  TetMesh grid = make_box_mesh({0, 0, 0}, {0.4, 0.1, 0.1}, {12, 3, 3}, 6);
  std::mt19937 rng(11);
  std::vector<std::int32_t> perm(grid.node_count());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<double> points(grid.points.size());
  for (std::size_t i = 0; i < grid.node_count(); ++i)
    for (int k = 0; k < 3; ++k) points[3 * std::size_t(perm[i]) + k] = grid.points[3 * i + k];
  std::vector<Tet> tets = grid.tets;
  for (auto& t : tets)
    for (auto& c : t) c = perm[std::size_t(c)];
  std::shuffle(tets.begin(), tets.end(), rng);
  fs::create_directories(dir);
  std::ofstream node(dir / "beam.node"), ele(dir / "beam.ele");
  node.precision(17);
  node << grid.node_count() << " 3 0 0\n";
  for (std::size_t i = 0; i < grid.node_count(); ++i)
    node << i << ' ' << points[3 * i] << ' ' << points[3 * i + 1] << ' ' << points[3 * i + 2] << '\n';
  ele << tets.size() << " 4 0\n";
  for (std::size_t t = 0; t < tets.size(); ++t)
    ele << t << ' ' << tets[t][0] << ' ' << tets[t][1] << ' ' << tets[t][2] << ' ' << tets[t][3] << '\n';
  return dir / "beam.node";
}

TEST(RenumberedFileMesh, NodeRegionsSelectTheSameMaterialPoints) {
  const fs::path file = write_scrambled_beam(fs::temp_directory_path() / "pliant_test_renumber_world");
  const TetMesh as_read = read_tet_mesh(file);

  // Fix the nodes at x = 0 and load the nodes at x = 0.4, both listed by their file index.
  RegionDef fixed, loaded;
  fixed.kind = loaded.kind = RegionDef::Kind::nodes;
  for (std::size_t i = 0; i < as_read.node_count(); ++i) {
    if (as_read.point(i)[0] < 1e-9) fixed.nodes.push_back(std::int32_t(i));
    if (as_read.point(i)[0] > 0.4 - 1e-9) loaded.nodes.push_back(std::int32_t(i));
  }
  ASSERT_EQ(fixed.nodes.size(), 16u);
  BodyDef def;
  def.name = "beam";
  def.mesh.kind = MeshSourceDef::Kind::file;
  def.mesh.path = file;
  def.material.young = 2e5;
  def.fixed.push_back(fixed);
  NodalLoadDef load;
  load.region = loaded;
  load.total_force = {0, 0, -0.2};
  def.loads.push_back(load);

  WorldDef wd;
  wd.gravity = {0, 0, 0};
  World w(wd);
  w.add_body(def);
  EXPECT_EQ(w.body_def(0).fixed[0].nodes, fixed.nodes);  // the definition is kept as given

  const auto& L = w.level<double>(0);
  std::size_t fixed_count = 0, loaded_count = 0;
  for (std::size_t n = 0; n < L.node_count; ++n) {
    const double X = w.node_rest_position(0, n)[0];  // world frame
    const bool at_root = X < 1e-9, at_tip = X > 0.4 - 1e-9;
    EXPECT_EQ(L.state[n] == kNodeFixed, at_root) << "node " << n;
    if (L.state[n] == kNodeFixed) ++fixed_count;
    if (at_tip) {
      EXPECT_NEAR(L.external[2][n], -0.2 / 16, 1e-15);
      ++loaded_count;
    } else {
      EXPECT_EQ(L.external[2][n], 0.0);
    }
  }
  EXPECT_EQ(fixed_count, 16u);
  EXPECT_EQ(loaded_count, 16u);

  // The same body from the same file without renumbering (the host passes the mesh as read)
  // bends the same way: the tip moves identically up to round-off of the summation order.
  World ref(wd);
  ref.add_body(def, as_read);
  for (int i = 0; i < 200; ++i) {
    w.step();
    ref.step();
  }
  EXPECT_GT(w.max_displacement(), 1e-6);
  // measured 2.7e-14 of it
  EXPECT_NEAR(w.max_displacement(), ref.max_displacement(), 2e-13 * ref.max_displacement());

  // An index that does not exist is reported as the user wrote it.
  BodyDef bad = def;
  bad.name = "bad";
  bad.fixed[0].nodes.push_back(100000);
  try {
    w.add_body(bad);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node 100000 does not exist"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pliant
