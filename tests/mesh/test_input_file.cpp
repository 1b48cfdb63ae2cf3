// Every mesh reader opens only regular files (pliant/input_file.hpp): a FIFO named .msh made
// `pliant info` wait forever, a link to /dev/zero was read until memory ran out. Here: the helper
// itself, then each reader entry point on a FIFO, a link to /dev/zero and a directory, all with
// the extension the reader expects; a link to a regular file is still read.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "../support/special_files.hpp"
#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/mesh_io.hpp"

using namespace pliant;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

fs::path scratch() {
  const fs::path p = fs::temp_directory_path() / ("pliant_test_input_file_" + std::to_string(::getpid()));
  fs::create_directories(p);
  return p;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not an InputError: ") + e.what();
  }
  return "no error";
}

TEST(InputFile, ReadsARegularFileAndALinkToOne) {
  const fs::path dir = scratch();
  { std::ofstream(dir / "a.txt") << "hello\n"; }
  fs::remove(dir / "link.txt");
  fs::create_symlink(dir / "a.txt", dir / "link.txt");
  EXPECT_EQ(read_input_file(dir / "a.txt", "test file"), "hello\n");
  EXPECT_EQ(read_input_file(dir / "link.txt", "test file"), "hello\n");
  EXPECT_EQ(check_input_file(dir / "a.txt", "test file"), 6u);
}

TEST(InputFile, RefusesWhatIsNotARegularFileNamingIt) {
  const fs::path dir = scratch();
  const special::Fifo fifo(dir / "f.msh");
  EXPECT_THAT(error_of([&] { read_input_file(fifo.path(), "mesh file"); }),
              HasSubstr(fifo.path().string() + ": is a FIFO (named pipe), not a regular file"));
  EXPECT_FALSE(fifo.opened());  // refused without being opened
  const fs::path zero = special::link_to_dev_zero(dir / "zero.msh");
  EXPECT_THAT(error_of([&] { read_input_file(zero, "mesh file"); }),
              HasSubstr(zero.string() + ": is a character device, not a regular file"));
  EXPECT_THAT(error_of([&] { check_input_file(zero, "mesh file"); }), HasSubstr("character device"));
  EXPECT_THAT(error_of([&] { read_input_file(dir, "mesh file"); }), HasSubstr(": is a directory, not a mesh file"));
  EXPECT_THAT(error_of([&] { read_input_file(dir / "absent.msh", "mesh file"); }),
              HasSubstr("absent.msh: cannot open mesh file (No such file or directory)"));
}

// Each reader entry point, on a FIFO, a link to /dev/zero and a directory named like its files.
TEST(InputFile, EveryMeshReaderRefusesFifosDevicesAndDirectories) {
  const fs::path dir = scratch();
  // TetGen reads a pair: the partner of the special file is a good one.
  const char* node_text = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
  const char* ele_text = "1 4 0\n0 0 1 2 3\n";
  for (const std::string ext : {".msh", ".vtk", ".vtu", ".node", ".ele"}) {
    if (ext == ".node" || ext == ".ele")
      for (const char* stem : {"fifo", "zero", "folder"}) {
        fs::remove_all(dir / (std::string(stem) + ".node"));
        fs::remove_all(dir / (std::string(stem) + ".ele"));
        std::ofstream(dir / (std::string(stem) + (ext == ".node" ? ".ele" : ".node"))) << (ext == ".node" ? ele_text : node_text);
      }
    {
      const special::Fifo fifo(dir / ("fifo" + ext));
      EXPECT_THAT(error_of([&] { read_tet_mesh(fifo.path()); }), HasSubstr("FIFO")) << ext;
      EXPECT_FALSE(fifo.opened()) << ext;
    }
    const fs::path zero = special::link_to_dev_zero(dir / ("zero" + ext));
    EXPECT_THAT(error_of([&] { read_tet_mesh(zero); }), HasSubstr("character device")) << ext;
    fs::create_directories(dir / ("folder" + ext));
    EXPECT_THAT(error_of([&] { read_tet_mesh(dir / ("folder" + ext)); }), HasSubstr("is a directory")) << ext;
  }
  // TetGen: the partner file (.ele of a good .node, named by the .node) as a FIFO.
  std::ofstream(dir / "pair.node") << node_text;
  {
    const special::Fifo fifo(dir / "pair.ele");
    EXPECT_THAT(error_of([&] { read_tet_mesh(dir / "pair.node"); }), HasSubstr("FIFO"));
    EXPECT_FALSE(fifo.opened());
  }
  // read_vtu with its data arrays (what `pliant render` uses).
  const fs::path zero = special::link_to_dev_zero(dir / "zero.vtu");
  VtuData data;
  MeshLoadReport report;
  EXPECT_THAT(error_of([&] { read_vtu(zero, report, &data); }), HasSubstr("character device"));
}

}  // namespace
