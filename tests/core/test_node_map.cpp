// The file's node numbers and the engine's: World::node_map gives, for a body read from a volume
// mesh file, the engine node of each of the file's nodes (the engine renumbers for locality and
// drops nodes no tet uses), and pliant run writes it as node_map.csv. A probe placed outside its
// body is refused with the nearest node (in both numberings) and how far it is.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/run.hpp"
#include "pliant/world.hpp"

namespace pliant {
namespace {

using ::testing::HasSubstr;

BodyDef file_body(const std::string& path, double scale = 1) {
  BodyDef b;
  b.name = "part";
  b.mesh.kind = MeshSourceDef::Kind::file;
  b.mesh.path = path;
  b.mesh.scale = scale;
  return b;
}

// The points of a legacy VTK file as written (no reader involved): the lines after POINTS.
std::vector<Vec3d> raw_vtk_points(const std::string& path) {
  std::ifstream in(path);
  std::string word;
  std::size_t n = 0;
  while (in >> word)
    if (word == "POINTS") {
      in >> n >> word;
      break;
    }
  std::vector<Vec3d> p(n);
  for (auto& x : p) in >> x[0] >> x[1] >> x[2];
  return p;
}

TEST(NodeMap, MapsEveryFileNodeToTheEngineNodeAtItsPositionAndMarksUnusedOnes) {
  // cube.vtk lists 9 points; the 9th (9, 9, 9) is in no tet.
  const std::string path = std::string(PLIANT_TEST_DATA) + "/mesh/cube.vtk";
  const std::vector<Vec3d> raw = raw_vtk_points(path);
  ASSERT_EQ(raw.size(), 9u);
  World w;
  w.add_body(file_body(path, 0.1));
  const auto& map = w.node_map(0);
  ASSERT_EQ(map.size(), 9u);
  EXPECT_EQ(map[8], -1);
  std::vector<std::int32_t> used(map.begin(), map.begin() + 8);
  std::sort(used.begin(), used.end());
  for (std::int32_t i = 0; i < 8; ++i) EXPECT_EQ(used[std::size_t(i)], i);  // a permutation of the engine's nodes
  for (std::size_t i = 0; i < 8; ++i) {
    const Vec3d x = w.node_rest_position(0, std::size_t(map[i]));
    for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(x[k], 0.1 * raw[i][k]) << "file node " << i;
  }
}

TEST(NodeMap, TheRenumberingIsNotTheIdentityOnARealMesh) {
  // The shipped liver (Gmsh, 181 nodes): the map is a permutation, and not the identity, so that
  // reading file node i as engine node i would be wrong.
  World w;
  w.add_body(file_body(std::string(PLIANT_DATA_MESHES) + "/liver.msh"));
  const auto& map = w.node_map(0);
  ASSERT_EQ(map.size(), 181u);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < map.size(); ++i) moved += map[i] != std::int32_t(i);
  EXPECT_GT(moved, 100u);
  std::vector<std::int32_t> sorted = map;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], std::int32_t(i));
}

TEST(NodeMap, NodeRegionsCountInTheFilesNumberingEvenWhenUnusedNodesAreDropped) {
  // A file whose first point is in no tet: after it is dropped, the file's node i is the loaded
  // mesh's node i - 1, and then renumbered. A region listing file nodes must get those points.
  const std::string path = std::string(::testing::TempDir()) + "/pliant_unused_first.vtk";
  std::ofstream(path) << "# vtk DataFile Version 3.0\nunused first point\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                         "POINTS 5 double\n9 9 9\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                         "CELLS 1 5\n4 1 2 3 4\nCELL_TYPES 1\n10\n";
  BodyDef b = file_body(path);
  RegionDef fixed;
  fixed.kind = RegionDef::Kind::nodes;
  fixed.nodes = {1, 2, 3};  // the file's (0,0,0), (1,0,0), (0,1,0): the bottom face
  b.fixed.push_back(fixed);
  World w;
  w.add_body(b);
  const auto& map = w.node_map(0);
  ASSERT_EQ(map.size(), 5u);
  EXPECT_EQ(map[0], -1);
  const Level<double>& L = w.level<double>(0);
  for (std::size_t i = 1; i < 5; ++i) {
    const std::size_t n = std::size_t(map[i]);
    EXPECT_EQ(L.state[n], i <= 3 ? kNodeFixed : kNodeFree) << "file node " << i;
  }
  // Listing the unused node is an error that says so.
  b.fixed[0].nodes = {0, 1};
  World w2;
  try {
    w2.add_body(b);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("body 'part': fixed[0]: node 0 of the file is used by no tetrahedron"));
  }
}

TEST(NodeMap, OnlyFileMeshesHaveOne) {
  World w;
  BodyDef b;
  b.name = "box";
  w.add_body(b);
  EXPECT_TRUE(w.node_map(0).empty());
  EXPECT_THROW(w.node_map(1), InputError);
}

TEST(NodeMap, RunWritesNodeMapCsvForFileMeshes) {
  SceneDef s;
  s.duration = 1e-4;
  s.bodies.push_back(file_body(std::string(PLIANT_TEST_DATA) + "/mesh/cube.vtk", 0.1));
  RunOptions o;
  o.out_dir = std::string(::testing::TempDir()) + "/pliant_node_map";
  const RunSummary r = run_scene(s, o);
  EXPECT_NE(std::find(r.files.begin(), r.files.end(), "node_map.csv"), r.files.end());
  std::ifstream in(o.out_dir / "node_map.csv");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 10u);
  EXPECT_EQ(lines[0], "body,file_node,node");
  EXPECT_EQ(lines[9], "part,8,-1");
  World w = make_world(s);
  EXPECT_EQ(lines[1], "part,0," + std::to_string(w.node_map(0)[0]));
}

TEST(Probes, AProbeOutsideItsBodyNamesTheNearestNodeAndItsDistance) {
  World w;
  w.add_body(file_body(std::string(PLIANT_TEST_DATA) + "/mesh/cube.vtk", 0.1));  // [0, 0.1]^3
  ProbeDef p;
  p.name = "tip";
  p.body = "part";
  p.point = {0.13, 0.1, 0.14};  // 0.05 m from the corner (0.1, 0.1, 0.1), file node 6
  try {
    w.add_probe(p);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_THAT(msg, HasSubstr("probe 'tip': point [0.13, 0.1, 0.14] is not inside body 'part'"));
    EXPECT_THAT(msg, HasSubstr(fmt::format("nearest node is node {} (the file's node 6, counted from 0) at [0.1, 0.1, 0.1], 0.05 m away",
                                           w.node_map(0)[6])));
    EXPECT_THAT(msg, HasSubstr("the body spans [0, 0, 0]..[0.1, 0.1, 0.1] m"));
  }
}

}  // namespace
}  // namespace pliant
