// Tests of the volume-mesh readers (Gmsh v1/v2/v4.1, legacy VTK, VTK XML, TetGen):
//  - small good files in tests/data/mesh load with exact counts, report and volume (m^3);
//  - each malformed file gives an InputError starting with the file path and naming the
//    line or element;
//  - binary VTU (base64, UInt32/UInt64 headers, zlib, both byte orders) written by a tiny
//    generator here;
//  - cut or corrupted copies of the good files never crash: they load or throw InputError;
//  - the real SOFA meshes shipped in data/meshes (PLIANT_DATA_MESHES).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

using namespace pliant;
using ::testing::HasSubstr;
using ::testing::StartsWith;
namespace fs = std::filesystem;

namespace {

std::string data(const std::string& name) { return std::string(PLIANT_TEST_DATA) + "/mesh/" + name; }

double tet_volume(const TetMesh& m, const Tet& t) {
  return signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
}

double total_volume(const TetMesh& m) {
  double v = 0;
  for (const Tet& t : m.tets) v += tet_volume(m, t);
  return v;
}

// What finalize promises: indices in range, every node used, every tet positive.
void expect_finalized(const TetMesh& m) {
  std::vector<char> used(m.node_count(), 0);
  for (const Tet& t : m.tets) {
    for (auto v : t) {
      ASSERT_GE(v, 0);
      ASSERT_LT(static_cast<std::size_t>(v), m.node_count());
      used[v] = 1;
    }
    EXPECT_GT(tet_volume(m, t), 0.0);
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
  for (double x : m.points) EXPECT_TRUE(std::isfinite(x));
}

// The InputError message for `path`; a test failure if it loads or throws something else.
std::string load_error(const fs::path& path) {
  try {
    MeshLoadReport report;
    read_tet_mesh(path, &report);
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": not an InputError: " << e.what();
    return {};
  }
  ADD_FAILURE() << path << " loaded but should not have";
  return {};
}

std::string test_name(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

void write_file(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
  ASSERT_TRUE(out.good()) << p;
}

std::string read_whole(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

// ---------------------------------------------------------------- good files: a unit cube, 5 tets

struct GoodCase {
  const char* file;
  std::size_t nodes, tets, skipped, reoriented, dropped;
};

class GoodFile : public ::testing::TestWithParam<GoodCase> {};

TEST_P(GoodFile, LoadsWithExactCountsAndVolume) {
  const GoodCase& c = GetParam();
  MeshLoadReport report;
  report.skipped_cells = 99;  // a reused report is reset by the reader
  const TetMesh m = read_tet_mesh(data(c.file), &report);
  EXPECT_EQ(m.node_count(), c.nodes);
  EXPECT_EQ(m.tet_count(), c.tets);
  EXPECT_EQ(report.skipped_cells, c.skipped);
  EXPECT_EQ(report.reoriented_tets, c.reoriented);
  EXPECT_EQ(report.dropped_vertices, c.dropped);
  EXPECT_NEAR(total_volume(m), 1.0, 1e-12);
  for (double x : m.points) EXPECT_TRUE(x == 0.0 || x == 1.0) << x;  // only the cube corners remain
  expect_finalized(m);
}

INSTANTIATE_TEST_SUITE_P(
    Cube, GoodFile,
    ::testing::Values(
        GoodCase{"cube_v1.msh", 8, 5, 2, 0, 1},        // ids 10..80, a tri, a line, node 99 unused
        GoodCase{"cube_v2.msh", 8, 5, 2, 0, 0},        // CRLF, $PhysicalNames, 2 tris
        GoodCase{"cube_inverted.msh", 8, 5, 2, 2, 0},  // 2 inverted tets
        GoodCase{"cube_v41.msh", 8, 5, 1, 0, 0},       // 2 node blocks, tri block + tet block
        GoodCase{"cube.vtk", 8, 5, 1, 0, 1},           // FIELD, a triangle, 1 unused point
        GoodCase{"cube_inverted.vtk", 8, 5, 1, 2, 1},
        GoodCase{"cube_v51.vtk", 8, 5, 0, 0, 0},       // 5.1 OFFSETS/CONNECTIVITY, METADATA
        GoodCase{"cube.vtu", 8, 5, 1, 0, 1},
        GoodCase{"cube_inverted.vtu", 8, 5, 1, 2, 1},
        GoodCase{"cube_xml.vtk", 8, 5, 1, 0, 1},       // XML content behind a .vtk name
        GoodCase{"cube.node", 8, 5, 0, 0, 0},          // 1-based, attributes, markers, comments
        GoodCase{"cube.ele", 8, 5, 0, 0, 0},           // the same pair, found from the .ele
        GoodCase{"cube0.ele", 8, 5, 0, 2, 1}),         // 0-based, 2 inverted, 1 unused point
    [](const auto& info) { return test_name(info.param.file); });

TEST(MeshReaders, TetGenBaseNameAndDirectReaders) {
  MeshLoadReport report;
  EXPECT_EQ(read_tetgen(data("cube"), report).tet_count(), 5u);  // no extension: cube.node + cube.ele
  EXPECT_EQ(read_gmsh(data("cube_v1.msh"), report).tet_count(), 5u);
  EXPECT_EQ(read_vtk_legacy(data("cube.vtk"), report).tet_count(), 5u);
  EXPECT_EQ(read_vtu(data("cube_xml.vtk"), report).tet_count(), 5u);
  EXPECT_EQ(report.skipped_cells, 1u);
}

TEST(MeshReaders, NodeOrderFollowsTheFile) {
  // Gmsh ids 10, 20, ... map to indices 0, 1, ... in file order; tets keep their corners.
  const TetMesh m = read_tet_mesh(data("cube_v1.msh"));
  EXPECT_EQ(m.point(1), (Vec3d{1, 0, 0}));
  EXPECT_EQ(m.point(6), (Vec3d{1, 1, 1}));
  EXPECT_EQ(m.tets.front(), (Tet{0, 1, 3, 4}));
  EXPECT_EQ(m.tets.back(), (Tet{1, 3, 4, 6}));
}

TEST(MeshReaders, WrongReaderForTheContentIsAnInputError) {
  MeshLoadReport report;
  EXPECT_THAT([&] { read_vtk_legacy(data("cube.vtu"), report); },
              ::testing::ThrowsMessage<InputError>(HasSubstr("cube.vtu:1: not a legacy VTK file")));
  EXPECT_THAT([&] { read_vtu(data("cube.vtk"), report); },
              ::testing::ThrowsMessage<InputError>(HasSubstr("cube.vtk: not a VTK XML file")));
  EXPECT_THAT([&] { read_gmsh(data("cube.vtk"), report); },
              ::testing::ThrowsMessage<InputError>(HasSubstr("cube.vtk:1: expected a section")));
}

// ---------------------------------------------------------------- malformed files

struct BadCase {
  const char* file;   // loaded with read_tet_mesh
  const char* named;  // the file the message must start with
  const char* after;  // what must follow the path
  const char* also;   // and appear somewhere ("" = nothing more)
};

class BadFile : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadFile, IsAnInputErrorNamingFileAndLine) {
  const BadCase& c = GetParam();
  const std::string msg = load_error(data(c.file));
  EXPECT_THAT(msg, StartsWith(data(c.named) + c.after));
  EXPECT_THAT(msg, HasSubstr(c.also));
}

INSTANTIATE_TEST_SUITE_P(
    Gmsh, BadFile,
    ::testing::Values(
        BadCase{"empty.msh", "empty.msh", ": file is empty", ""},
        BadCase{"bad_truncated.msh", "bad_truncated.msh", ":22: unexpected end of file",
                "line 20 declares 7 elements, only 2 present"},
        BadCase{"bad_count.msh", "bad_count.msh", ":12: found '$ENDNOD'",
                "line 2 declares 10 nodes, only 9 present"},
        BadCase{"bad_index.msh", "bad_index.msh", ":26: element 6 refers to node 999, which is not defined", ""},
        BadCase{"bad_nan.msh", "bad_nan.msh", ":12: node 3 has a non-finite coordinate", "nan"},
        BadCase{"bad_degenerate.msh", "bad_degenerate.msh", ":25: element 5: degenerate tetrahedron (volume 0)", ""},
        BadCase{"bad_binary.msh", "bad_binary.msh", ":2: binary .msh not supported, re-save as ASCII", ""},
        BadCase{"bad_v4_count.msh", "bad_v4_count.msh", ":28: the header at line 10 declares 9 nodes",
                "the blocks hold 8"},
        // Gmsh v1 ($NOD/$ELM), copies of cube_v1.msh: cut after 3 of the 7 elements, an element
        // on node 999, a NaN coordinate.
        BadCase{"bad_v1_truncated.msh", "bad_v1_truncated.msh", ":17: unexpected end of file",
                "element 4 (line 14 declares 7 elements, only 3 present)"},
        BadCase{"bad_v1_index.msh", "bad_v1_index.msh", ":19: element 5 refers to node 999, which is not defined", ""},
        BadCase{"bad_v1_nan.msh", "bad_v1_nan.msh", ":5: node 30 has a non-finite coordinate", "(1, nan, 0)"},
        // Gmsh v4.1, copies of cube_v41.msh: cut inside the coordinates of the second node block,
        // a tet on node 999, an infinite coordinate.
        BadCase{"bad_v4_truncated.msh", "bad_v4_truncated.msh", ":26: unexpected end of file",
                "coordinates of node 7"},
        BadCase{"bad_v4_index.msh", "bad_v4_index.msh", ":37: element 4 refers to node 999, which is not defined", ""},
        BadCase{"bad_v4_nan.msh", "bad_v4_nan.msh", ":27: node 7 has a non-finite coordinate", "(1, inf, 1)"}),
    [](const auto& info) { return test_name(info.param.file); });

INSTANTIATE_TEST_SUITE_P(
    LegacyVtk, BadFile,
    ::testing::Values(
        BadCase{"empty.vtk", "empty.vtk", ": file is empty", ""},
        BadCase{"bad_truncated.vtk", "bad_truncated.vtk", ":22: unexpected end of file",
                "CELLS (line 19) needs 29 values"},
        BadCase{"bad_count.vtk", "bad_count.vtk", ":19: expected value 28 of the 30 of POINTS (line 8)",
                "found 'CELLS'"},
        BadCase{"bad_index.vtk", "bad_index.vtk", ":24: cell 4 refers to point 999, which is not defined", ""},
        BadCase{"bad_nan.vtk", "bad_nan.vtk", ":11: point 2 has a non-finite coordinate", "inf"},
        BadCase{"bad_degenerate.vtk", "bad_degenerate.vtk", ":25: cell 5: degenerate tetrahedron (volume 0)", ""},
        BadCase{"bad_binary.vtk", "bad_binary.vtk", ":3: BINARY legacy VTK is not supported", ""}),
    [](const auto& info) { return test_name(info.param.file); });

INSTANTIATE_TEST_SUITE_P(
    Vtu, BadFile,
    ::testing::Values(
        BadCase{"empty.vtu", "empty.vtu", ": file is empty", ""},
        BadCase{"bad_truncated.vtu", "bad_truncated.vtu", ":23: <DataArray is cut short", "truncated"},
        BadCase{"bad_count.vtu", "bad_count.vtu", ":10: DataArray \"Points\" has 27 values, expected 30", ""},
        BadCase{"bad_index.vtu", "bad_index.vtu", ": cell 4: refers to point 999, which is not defined", ""},
        BadCase{"bad_nan.vtu", "bad_nan.vtu", ":13: point 2 has a non-finite coordinate", "NaN"},
        BadCase{"bad_degenerate.vtu", "bad_degenerate.vtu", ": cell 3: degenerate tetrahedron (volume 0)", ""},
        BadCase{"bad_appended.vtu", "bad_appended.vtu", ":10: DataArray \"Points\" uses format=\"appended\"",
                "not supported"}),
    [](const auto& info) { return test_name(info.param.file); });

INSTANTIATE_TEST_SUITE_P(
    TetGen, BadFile,
    ::testing::Values(
        BadCase{"bad_count.ele", "bad_count.node", ":10: unexpected end of file",
                "the header (line 1) declares 10 points, only 9 present"},
        BadCase{"bad_index.node", "bad_index.ele", ":4: tetrahedron 2 refers to node 999, which is not defined", ""},
        BadCase{"bad_nan.ele", "bad_nan.node", ":7: point 5 has a non-finite coordinate", "nan"},
        BadCase{"bad_degenerate.node", "bad_degenerate.ele", ":6: tetrahedron 4: degenerate tetrahedron (volume 0)", ""},
        BadCase{"lonely.node", "lonely.ele", ": cannot open file", "lonely.node"},
        // An empty .node next to a good .ele.
        BadCase{"empty.ele", "empty.node", ": file is empty", ""},
        // cube.node cut inside the line of point 8; cube.ele cut inside the line of tet 4, or
        // ending cleanly after 3 of its 5 tets.
        BadCase{"bad_truncated_node.ele", "bad_truncated_node.node", ":10: expected '<id> <x> <y> <z>'", ""},
        BadCase{"bad_truncated_ele.node", "bad_truncated_ele.ele", ":5: expected an id and 4 node ids", ""},
        BadCase{"bad_short.node", "bad_short.ele", ":4: unexpected end of file",
                "the header (line 1) declares 5 tetrahedra, only 3 present"},
        // 1-based points, a tet on node 0 (the off-by-one of a 0-based .ele).
        BadCase{"bad_index0.node", "bad_index0.ele", ":6: tetrahedron 5 refers to node 0, which is not defined",
                "bad_index0.node"}),
    [](const auto& info) { return test_name(info.param.file); });

INSTANTIATE_TEST_SUITE_P(
    Dispatch, BadFile,
    ::testing::Values(
        BadCase{"cube.stl", "cube.stl", ": unknown mesh file extension '.stl'", ".msh"},
        BadCase{"missing.msh", "missing.msh", ": cannot open mesh file", "No such file"},
        BadCase{"missing.vtk", "missing.vtk", ": cannot open mesh file", ""},
        BadCase{"missing.vtu", "missing.vtu", ": cannot open mesh file", ""},
        BadCase{"missing.ele", "missing.node", ": cannot open file", ""}),
    [](const auto& info) { return test_name(info.param.file); });

// ---------------------------------------------------------------- binary VTU, generated here

namespace {

struct VtuOptions {
  bool zlib = false;
  bool header64 = false;
  bool big_endian = false;
  bool points64 = false;               // Float64 (else Float32) points
  bool conn64 = false;                 // Int64 (else Int32) connectivity and offsets
  bool separate_header = true;         // base64 of the header, then of the data (as VTK does)
  std::size_t block = 32768;           // zlib block size (bytes)
  const char* quote = "\"";            // attribute quote character
};

std::string base64(const std::vector<unsigned char>& in) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < in.size(); i += 3) {
    const unsigned n = std::min<std::size_t>(3, in.size() - i);
    unsigned w = in[i] << 16;
    if (n > 1) w |= in[i + 1] << 8;
    if (n > 2) w |= in[i + 2];
    out += abc[(w >> 18) & 63];
    out += abc[(w >> 12) & 63];
    out += n > 1 ? abc[(w >> 6) & 63] : '=';
    out += n > 2 ? abc[w & 63] : '=';
  }
  return out;
}

template <class S>
void put(std::vector<unsigned char>& out, S v, bool big) {
  unsigned char b[sizeof(S)];
  std::memcpy(b, &v, sizeof(S));
  if (big != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(S));
  out.insert(out.end(), b, b + sizeof(S));
}

// The text of a binary DataArray holding `raw` (already in the file's byte order).
std::string encode(const std::vector<unsigned char>& raw, const VtuOptions& o) {
  std::vector<std::uint64_t> header;
  std::vector<unsigned char> body;
  if (!o.zlib) {
    header = {raw.size()};
    body = raw;
  } else {
    const std::size_t blocks = (raw.size() + o.block - 1) / o.block;
    header = {blocks, o.block, raw.size() % o.block};
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t n = std::min(o.block, raw.size() - b * o.block);
      std::vector<unsigned char> z(compressBound(n));
      uLongf zn = z.size();
      EXPECT_EQ(compress2(z.data(), &zn, raw.data() + b * o.block, n, 6), Z_OK);
      header.push_back(zn);
      body.insert(body.end(), z.begin(), z.begin() + zn);
    }
  }
  std::vector<unsigned char> h;
  for (auto w : header) o.header64 ? put<std::uint64_t>(h, w, o.big_endian) : put<std::uint32_t>(h, static_cast<std::uint32_t>(w), o.big_endian);
  if (o.separate_header) return base64(h) + base64(body);
  h.insert(h.end(), body.begin(), body.end());
  return base64(h);
}

// Unit cube with an unused 9th point and a triangle as cell 0, like tests/data/mesh/cube.vtu.
std::string binary_vtu(const VtuOptions& o, double poison = 0.0) {
  const std::vector<double> pts = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1,
                                   1, 0, 1, 1, 1, 1, 0, 1, 1, 9, 9, 9};
  const std::vector<std::vector<int>> cells = {{0, 1, 2},    {0, 1, 3, 4}, {1, 2, 3, 6},
                                               {1, 4, 5, 6}, {3, 4, 6, 7}, {1, 3, 4, 6}};
  std::vector<unsigned char> p, conn, offs, types;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double x = i == 7 && poison != 0.0 ? poison : pts[i];
    o.points64 ? put<double>(p, x, o.big_endian) : put<float>(p, static_cast<float>(x), o.big_endian);
  }
  std::int64_t off = 0;
  for (const auto& c : cells) {
    for (int v : c) o.conn64 ? put<std::int64_t>(conn, v, o.big_endian) : put<std::int32_t>(conn, v, o.big_endian);
    off += static_cast<std::int64_t>(c.size());
    o.conn64 ? put<std::int64_t>(offs, off, o.big_endian) : put<std::int32_t>(offs, static_cast<std::int32_t>(off), o.big_endian);
    types.push_back(c.size() == 3 ? 5 : 10);
  }
  const std::string q = o.quote;
  auto attr = [&](const char* k, const std::string& v) { return std::string(" ") + k + "=" + q + v + q; };
  const std::string it = o.conn64 ? "Int64" : "Int32";
  std::string s = "<?xml version=\"1.0\"?>\n<VTKFile" + attr("type", "UnstructuredGrid") + attr("version", "1.0") +
                  attr("byte_order", o.big_endian ? "BigEndian" : "LittleEndian") +
                  attr("header_type", o.header64 ? "UInt64" : "UInt32") +
                  (o.zlib ? attr("compressor", "vtkZLibDataCompressor") : "") + ">\n";
  s += "<UnstructuredGrid>\n  <!-- generated by test_mesh_readers -->\n  <Piece" + attr("NumberOfPoints", "9") +
       attr("NumberOfCells", "6") + ">\n    <PointData/>\n    <CellData></CellData>\n";
  s += "    <Points>\n      <DataArray" + attr("type", o.points64 ? "Float64" : "Float32") +
       attr("NumberOfComponents", "3") + attr("format", "binary") + ">\n        " + encode(p, o) +
       "\n      </DataArray>\n    </Points>\n    <Cells>\n";
  s += "      <DataArray" + attr("type", it) + attr("Name", "connectivity") + attr("format", "binary") + ">" +
       encode(conn, o) + "</DataArray>\n";
  s += "      <DataArray" + attr("type", it) + attr("Name", "offsets") + attr("format", "binary") + ">" +
       encode(offs, o) + "</DataArray>\n";
  s += "      <DataArray" + attr("type", "UInt8") + attr("Name", "types") + attr("format", "binary") + ">" +
       encode(types, o) + "</DataArray>\n";
  s += "    </Cells>\n  </Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  return s;
}

fs::path temp_file(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / "pliant_mesh_readers";
  fs::create_directories(dir);
  return dir / name;
}

}  // namespace

class BinaryVtu : public ::testing::TestWithParam<VtuOptions> {};

TEST_P(BinaryVtu, LoadsTheCube) {
  const fs::path path = temp_file(
      test_name(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".vtu");
  write_file(path, binary_vtu(GetParam()));
  MeshLoadReport report;
  const TetMesh m = read_tet_mesh(path, &report);
  EXPECT_EQ(m.node_count(), 8u);
  EXPECT_EQ(m.tet_count(), 5u);
  EXPECT_EQ(report.skipped_cells, 1u);
  EXPECT_EQ(report.dropped_vertices, 1u);
  EXPECT_EQ(report.reoriented_tets, 0u);
  EXPECT_NEAR(total_volume(m), 1.0, 1e-12);
  EXPECT_EQ(m.point(6), (Vec3d{1, 1, 1}));
  expect_finalized(m);
}

INSTANTIATE_TEST_SUITE_P(
    Encodings, BinaryVtu,
    ::testing::Values(VtuOptions{},                                                  // raw, UInt32 header
                      VtuOptions{.separate_header = false},                          // one base64 stream
                      VtuOptions{.header64 = true, .points64 = true, .conn64 = true},
                      VtuOptions{.big_endian = true, .points64 = true},
                      VtuOptions{.zlib = true},
                      VtuOptions{.zlib = true, .header64 = true, .conn64 = true},
                      VtuOptions{.zlib = true, .big_endian = true, .quote = "'"},
                      VtuOptions{.zlib = true, .header64 = true, .big_endian = true, .points64 = true,
                                 .separate_header = false},
                      VtuOptions{.zlib = true, .block = 16},                         // many blocks, partial last
                      VtuOptions{.zlib = true, .block = 12}));                       // exact multiple for 12-byte arrays

TEST(BinaryVtuErrors, NonFiniteBinaryCoordinateIsNamed) {
  const fs::path path = temp_file("binary_nan.vtu");
  write_file(path, binary_vtu(VtuOptions{.zlib = true}, std::nan("")));
  EXPECT_THAT(load_error(path), ::testing::AllOf(StartsWith(path.string() + ":"), HasSubstr("point 2 has a non-finite coordinate")));
}

TEST(BinaryVtuErrors, CorruptZlibDataIsAnInputError) {
  const fs::path path = temp_file("binary_corrupt.vtu");
  std::string s = binary_vtu(VtuOptions{.zlib = true});
  // Change characters at the start of the Points zlib stream (after its 24-char header).
  const std::size_t at = s.find(">\n        ") + 10 + 24;
  for (std::size_t i = at; i < at + 12; ++i) s[i] = s[i] == 'A' ? 'B' : 'A';
  write_file(path, s);
  EXPECT_THAT(load_error(path), StartsWith(path.string() + ":"));
}

TEST(BinaryVtuErrors, TruncatedBase64AndBadCharacters) {
  const std::string good = binary_vtu(VtuOptions{});
  const std::size_t end = good.find("</DataArray>\n    </Points>");
  std::string cut = good;
  cut.erase(end - 10, 1);  // one base64 character short ("\n      " precedes the end tag)
  const fs::path p1 = temp_file("binary_cut.vtu");
  write_file(p1, cut);
  EXPECT_THAT(load_error(p1), HasSubstr("base64 data is cut short"));
  std::string bad = good;
  bad[end - 12] = '*';
  const fs::path p2 = temp_file("binary_badchar.vtu");
  write_file(p2, bad);
  EXPECT_THAT(load_error(p2), HasSubstr("invalid base64 character '*'"));
}

TEST(BinaryVtuErrors, UnsupportedCompressorIsNamed) {
  std::string s = binary_vtu(VtuOptions{.zlib = true});
  s.replace(s.find("vtkZLibDataCompressor"), 21, "vtkLZ4DataCompressor");
  const fs::path path = temp_file("binary_lz4.vtu");
  write_file(path, s);
  EXPECT_THAT(load_error(path), ::testing::AllOf(StartsWith(path.string() + ":2: "), HasSubstr("vtkLZ4DataCompressor")));
}

TEST(VtuData, PointCellAndFieldArraysComeWithTheMesh) {
  // Two pieces of one tet each, with a point vector, a cell scalar and the time; an array in
  // appended format is left out with a note, and one present in only the first piece is dropped.
  const fs::path dir = fs::temp_directory_path() / "pliant_vtu_data";
  fs::create_directories(dir);
  const std::string piece_a = R"(<Piece NumberOfPoints="4" NumberOfCells="1">
  <PointData><DataArray type="Float64" Name="displacement" NumberOfComponents="3" format="ascii">
    0 0 0  1 0 0  0 2 0  0 0 3</DataArray>
    <DataArray type="Float32" Name="only_here" format="ascii">1 2 3 4</DataArray></PointData>
  <CellData><DataArray type="Float64" Name="von_mises" format="ascii">5.5</DataArray>
    <DataArray type="Float64" Name="packed" format="appended" offset="0"/></CellData>
  <Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>
  <Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
    <DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
    <DataArray type="UInt8" Name="types" format="ascii">10</DataArray></Cells></Piece>)";
  const std::string piece_b = R"(<Piece NumberOfPoints="4" NumberOfCells="1">
  <PointData><DataArray type="Float64" Name="displacement" NumberOfComponents="3" format="ascii">
    4 0 0  0 5 0  0 0 6  7 7 7</DataArray></PointData>
  <CellData><DataArray type="Float64" Name="von_mises" format="ascii">6.5</DataArray></CellData>
  <Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">2 0 0 3 0 0 2 1 0 2 0 1</DataArray></Points>
  <Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
    <DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
    <DataArray type="UInt8" Name="types" format="ascii">10</DataArray></Cells></Piece>)";
  write_file(dir / "two.vtu", std::string(R"(<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian"><UnstructuredGrid>
<FieldData><DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">0.25</DataArray></FieldData>
)") + piece_a + piece_b + "</UnstructuredGrid></VTKFile>\n");
  MeshLoadReport report;
  VtuData data;
  const TetMesh mesh = read_vtu(dir / "two.vtu", report, &data);
  EXPECT_EQ(mesh.node_count(), 8u);
  EXPECT_EQ(mesh.tet_count(), 2u);
  EXPECT_EQ(data.points, 8u);
  EXPECT_EQ(data.cells, 2u);
  ASSERT_TRUE(data.point.count("displacement"));
  EXPECT_EQ(data.point.at("displacement").components, 3);
  ASSERT_EQ(data.point.at("displacement").values.size(), 24u);
  EXPECT_EQ(data.point.at("displacement").values[23], 7.0);
  ASSERT_TRUE(data.cell.count("von_mises"));
  EXPECT_THAT(data.cell.at("von_mises").values, ::testing::ElementsAre(5.5, 6.5));
  ASSERT_TRUE(data.field.count("TimeValue"));
  EXPECT_EQ(data.field.at("TimeValue").values.at(0), 0.25);
  EXPECT_FALSE(data.cell.count("packed"));      // appended: not supported, noted
  EXPECT_FALSE(data.point.count("only_here"));  // absent from the second piece
  ASSERT_EQ(data.notes.size(), 2u);
  EXPECT_THAT(data.notes[0], ::testing::HasSubstr("appended"));
  EXPECT_THAT(data.notes[1], ::testing::HasSubstr("\"only_here\" is missing from some <Piece>"));
  // Without VtuData the same file reads as a plain mesh.
  EXPECT_EQ(read_vtu(dir / "two.vtu", report).tet_count(), 2u);
  fs::remove_all(dir);
}

TEST(BinaryVtuErrors, BadHeaderCountsAreCaught) {
  // Raw header says 1 MB for a 108-byte array; zlib header claims 2^20 blocks.
  VtuOptions o;
  std::string s = binary_vtu(o);
  std::vector<unsigned char> h;
  put<std::uint32_t>(h, 1u << 20, false);
  const std::size_t at = s.find(">\n        ") + 10;
  s.replace(at, 8, base64(h));
  const fs::path p1 = temp_file("binary_bigheader.vtu");
  write_file(p1, s);
  EXPECT_THAT(load_error(p1), HasSubstr("binary data is cut short"));

  o.zlib = true;
  s = binary_vtu(o);
  h.clear();
  for (std::uint32_t w : {1u << 20, 32768u, 108u}) put<std::uint32_t>(h, w, false);
  s.replace(at, 16, base64(h));
  const fs::path p2 = temp_file("binary_bigzheader.vtu");
  write_file(p2, s);
  EXPECT_THAT(load_error(p2), StartsWith(p2.string() + ":"));
}

// ---------------------------------------------------------------- robustness: cut and corrupted copies

TEST(MeshReaders, CutOrCorruptedFilesLoadCleanlyOrThrowInputError) {
  const char* files[] = {"cube_v1.msh", "cube_v2.msh", "cube_v41.msh", "cube.vtk", "cube_v51.vtk",
                         "cube.vtu",    "cube.node",   "cube.ele"};
  const fs::path dir = temp_file("fuzz");
  fs::create_directories(dir);
  std::size_t loaded = 0, rejected = 0;
  for (const char* f : files) {
    const std::string good = read_whole(data(f));
    ASSERT_FALSE(good.empty()) << f;
    const std::string ext = fs::path(f).extension().string();
    const bool tetgen = ext == ".node" || ext == ".ele";
    std::vector<std::string> variants;
    for (std::size_t n = 0; n < good.size(); ++n) variants.push_back(good.substr(0, n));
    for (std::size_t i = 0; i < good.size(); i += 3)
      for (char c : {'9', '-', 'x', '\0', ' ', '\n', '<', '$'}) {
        std::string v = good;
        v[i] = c;
        variants.push_back(std::move(v));
      }
    for (const std::string& v : variants) {
      // TetGen: corrupt one file of the pair, keep the other intact.
      const fs::path p = dir / (std::string("case") + ext);
      write_file(p, v);
      if (tetgen) write_file(dir / (std::string("case") + (ext == ".node" ? ".ele" : ".node")),
                             read_whole(data(std::string("cube") + (ext == ".node" ? ".ele" : ".node"))));
      try {
        MeshLoadReport report;
        const TetMesh m = read_tet_mesh(p, &report);
        expect_finalized(m);
        ++loaded;
      } catch (const InputError& e) {
        EXPECT_THAT(e.what(), StartsWith(dir.string())) << f;
        ++rejected;
      } catch (const std::exception& e) {
        ADD_FAILURE() << f << ": " << e.what();
      }
      if (HasFailure()) return;  // one detailed failure is enough
    }
  }
  EXPECT_GT(rejected, 1000u);
  EXPECT_GT(loaded, 0u);
}

// ---------------------------------------------------------------- real meshes (SOFA, data/meshes)

struct RealMesh {
  const char* file;
  std::size_t nodes, tets, skipped;
  double volume;  // m^3 (scene units), sum of tet volumes
};

TEST(RealMeshes, ShippedFilesLoadWithTheDocumentedCounts) {
  // Tet counts and skipped cells as in data/meshes/README.md. Node counts are after
  // dropping unused vertices: the raptors have 3 and 2 unused ones (README: 2996 and 5992).
  // Cube volumes are exact (7^3 and 1); the others are this reader's sums, as regression values.
  const RealMesh table[] = {
      {"liver.msh", 181, 596, 0, 36.5608511},
      {"liver2.msh", 507, 1493, 860 + 71, 1.12509215},  // node ids start at 2
      {"cylinder_8x30x6.msh", 1446, 6750, 0, 1.24747034e-06},
      {"torus_low_res.msh", 264, 862, 408 + 200, 8.21691288},
      {"cube_low_res.msh", 26, 44, 0, 343.0},           // Gmsh 2.2
      {"msh4_cube.msh", 14, 24, 24 + 12 + 8, 1.0},      // Gmsh 4.1
      {"raptorTetra_8418.vtu", 2993, 8418, 0, 27.251767},
      {"raptorTetra_19409.vtu", 5990, 19409, 0, 27.4890635},
      {"Armadillo_Tetra_4406.vtu", 1446, 4406, 0, 231.214307},
      {"Bunny.vtk", 1911, 5897, 0, 152.453392},         // VTK XML despite the name
  };
  const fs::path dir = PLIANT_DATA_MESHES;
  for (const RealMesh& r : table) {
    const fs::path path = dir / r.file;
    SCOPED_TRACE(r.file);
    ASSERT_TRUE(fs::is_regular_file(path)) << path << " is missing: the repository ships it";
    MeshLoadReport report;
    const TetMesh m = read_tet_mesh(path, &report);
    EXPECT_EQ(m.tet_count(), r.tets);
    EXPECT_EQ(m.node_count(), r.nodes);
    EXPECT_EQ(report.skipped_cells, r.skipped);
    EXPECT_EQ(report.reoriented_tets, 0u);  // SOFA's meshes are all positively oriented
    EXPECT_NEAR(total_volume(m), r.volume, 1e-8 * r.volume);
    expect_finalized(m);
  }
}
