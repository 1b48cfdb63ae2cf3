// Counts read from a file (NumberOfPoints, POINTS n, $Nodes n, a TetGen header, ...) are checked
// against the file's size before anything is multiplied or allocated from them: a VTU declaring
// 2^62 points overflowed 3 n and reported "expected -4611686018427387904 values", and a legacy VTK
// FIELD array of 2^62 x 4 values overflowed to 0 values and was silently skipped. Every reader now
// says that the count is more than the file can hold, naming the file, line and count.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

using namespace pliant;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

const std::string kHuge = "4611686018427387904";  // 2^62: 3 x it overflows int64

std::string read(const std::string& name) {
  std::ifstream in(std::string(PLIANT_TEST_DATA) + "/mesh/" + name, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The good file `name` with the first `from` replaced by `to`, written under a new name.
fs::path edited(const std::string& name, const std::string& from, const std::string& to,
                const std::string& out_name = "") {
  std::string text = read(name);
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from << " not in " << name;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  const fs::path dir = fs::temp_directory_path() / ("pliant_test_counts_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path p = dir / (out_name.empty() ? name : out_name);
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

std::string error_reading(const fs::path& p, VtuData* data = nullptr) {
  try {
    MeshLoadReport report;
    if (data) read_vtu(p, report, data);
    else read_tet_mesh(p, &report);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ReaderCounts, VtuPointAndCellCountsBeyondTheFile) {
  EXPECT_THAT(error_reading(edited("cube.vtu", "NumberOfPoints=\"9\"", "NumberOfPoints=\"" + kHuge + "\"")),
              HasSubstr("cube.vtu:5: NumberOfPoints=\"" + kHuge + "\" is more than the file ("));
  EXPECT_THAT(error_reading(edited("cube.vtu", "NumberOfCells=\"6\"", "NumberOfCells=\"" + kHuge + "\"")),
              HasSubstr("cube.vtu:5: NumberOfCells=\"" + kHuge + "\" is more than the file ("));
}

TEST(ReaderCounts, VtuComponentCountBeyondTheFileDropsTheArrayWithANote) {
  // The point data array "t" declares 2^62 components: tuples x components overflowed.
  VtuData data;
  const fs::path p = edited("cube.vtu", "Name=\"t\"", "Name=\"t\" NumberOfComponents=\"" + kHuge + "\"");
  EXPECT_EQ(error_reading(p, &data), "no error");  // the mesh still loads
  EXPECT_EQ(data.point.count("t"), 0u);
  ASSERT_FALSE(data.notes.empty());
  EXPECT_THAT(data.notes.front(), HasSubstr("NumberOfComponents=\"" + kHuge + "\" is more than the file ("));
}

TEST(ReaderCounts, LegacyVtkCountsBeyondTheFile) {
  EXPECT_THAT(error_reading(edited("cube.vtk", "CELLS 6 29", "CELLS " + kHuge + " 29")),
              HasSubstr("cube.vtk:19: the number of cells " + kHuge + " is more than the file ("));
  // FIELD arrays are skipped value by value: 2^62 x 4 overflowed to 0 values skipped, and the
  // values were then read as section names.
  EXPECT_THAT(error_reading(edited("cube.vtk", "TIME 1 1 double", "TIME " + kHuge + " 4 double")),
              HasSubstr("cube.vtk:6: the number of components " + kHuge + " is more than the file ("));
  EXPECT_THAT(error_reading(edited("cube.vtk", "TIME 1 1 double", "TIME 4 " + kHuge + " double")),
              HasSubstr("cube.vtk:6: the number of tuples " + kHuge + " is more than the file ("));
}

TEST(ReaderCounts, GmshCountsBeyondTheFile) {
  EXPECT_THAT(error_reading(edited("cube_v2.msh", "$Nodes\r\n8\r\n", "$Nodes\r\n" + kHuge + "\r\n")),
              HasSubstr("cube_v2.msh:9: the number of nodes " + kHuge + " is more than the file ("));
  EXPECT_THAT(error_reading(edited("cube_v41.msh", "$Nodes\n2 8 1 8\n", "$Nodes\n2 " + kHuge + " 1 8\n")),
              HasSubstr("cube_v41.msh:10: numNodes " + kHuge + " is more than the file ("));
}

TEST(ReaderCounts, TetGenCountsBeyondTheFile) {
  edited("cube.ele", "", "", "huge.ele");
  EXPECT_THAT(error_reading(edited("cube.node", "8 3 1 1", kHuge + " 3 1 1", "huge.node")),
              HasSubstr("huge.node:2: the number of points " + kHuge + " is more than the file ("));
  edited("cube.node", "", "", "huge2.node");
  EXPECT_THAT(error_reading(edited("cube.ele", "5 4 1", kHuge + " 4 1", "huge2.ele")),
              HasSubstr("huge2.ele:1: the number of tetrahedra " + kHuge + " is more than the file ("));
}

}  // namespace
