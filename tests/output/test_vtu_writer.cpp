// The VTU/PVD writer, checked by reading its files back: a minimal XML scan, a base64 decoder
// and zlib's uncompress recover every array, which must equal the input bit for bit.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <regex>
#include <sstream>

#include "pliant/error.hpp"
#include "pliant/vtu_writer.hpp"

namespace pliant {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<unsigned char>;

std::string slurp(const fs::path& p) {
  std::ifstream is(p, std::ios::binary);
  std::ostringstream ss;
  ss << is.rdbuf();
  return ss.str();
}

Bytes base64_decode(std::string_view s) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  Bytes out;
  std::uint32_t acc = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    const int v = value(c);
    if (v < 0) {
      ADD_FAILURE() << "bad base64 character '" << c << "'";
      return out;
    }
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>(acc >> bits));
    }
  }
  return out;
}

std::uint64_t u64_at(const Bytes& b, std::size_t word) {
  std::uint64_t v;
  std::memcpy(&v, b.data() + 8 * word, 8);
  return v;
}

std::string strip(std::string_view s) {
  std::string out;
  for (char c : s)
    if (!std::isspace(static_cast<unsigned char>(c))) out += c;
  return out;
}

// One <DataArray> of the file: its attributes and its text.
struct Array {
  std::string type, components, format, text;
};

std::string attribute(const std::string& tag, const std::string& name) {
  std::smatch m;
  if (std::regex_search(tag, m, std::regex("\\s" + name + "=\"([^\"]*)\""))) return m[1];
  return "";
}

Array find_array(const std::string& xml, const std::string& name) {
  const std::size_t at = xml.find("Name=\"" + name + "\"");
  if (at == std::string::npos) {
    ADD_FAILURE() << "no DataArray named " << name;
    return {};
  }
  const std::size_t open = xml.rfind("<DataArray", at);
  const std::size_t close = xml.find('>', at);
  const std::size_t end = xml.find("</DataArray>", close);
  const std::string tag = xml.substr(open, close - open);
  return {attribute(tag, "type"), attribute(tag, "NumberOfComponents"), attribute(tag, "format"),
          xml.substr(close + 1, end - close - 1)};
}

// Decodes a "binary" array: [UInt64 size][data] in one base64 stream, or the zlib layout.
Bytes decode_binary(const std::string& text, bool zlib, std::uint64_t* blocks_out = nullptr) {
  const std::string s = strip(text);
  if (!zlib) {
    const Bytes all = base64_decode(s);
    EXPECT_GE(all.size(), 8u);
    const std::uint64_t n = u64_at(all, 0);
    EXPECT_EQ(all.size(), 8 + n);
    return Bytes(all.begin() + 8, all.end());
  }
  // Header: [nblocks, block size, last block size, compressed sizes...], base64'd on its own.
  const std::uint64_t nblocks = u64_at(base64_decode(s.substr(0, 32)), 0);
  const std::size_t header_bytes = 8 * (3 + nblocks);
  const std::size_t header_chars = 4 * ((header_bytes + 2) / 3);
  const Bytes header = base64_decode(s.substr(0, header_chars));
  const Bytes packed = base64_decode(s.substr(header_chars));
  const std::uint64_t block = u64_at(header, 1), last = u64_at(header, 2);
  if (blocks_out) *blocks_out = nblocks;
  Bytes out;
  std::size_t at = 0;
  for (std::uint64_t b = 0; b < nblocks; ++b) {
    const std::uint64_t csize = u64_at(header, 3 + b);
    uLongf size = (b + 1 == nblocks && last != 0) ? last : block;
    const std::size_t start = out.size();
    out.resize(start + size);
    EXPECT_EQ(uncompress(out.data() + start, &size, packed.data() + at, csize), Z_OK);
    EXPECT_EQ(size, (b + 1 == nblocks && last != 0) ? last : block);
    at += csize;
  }
  EXPECT_EQ(at, packed.size());
  return out;
}

// The array's values, decoded according to its format attribute.
template <class T>
std::vector<T> read_array(const std::string& xml, const std::string& name, bool zlib) {
  const Array a = find_array(xml, name);
  std::vector<T> v;
  if (a.format == "ascii") {
    std::istringstream is(a.text);
    std::string tok;
    while (is >> tok) {
      if constexpr (std::is_floating_point_v<T>) v.push_back(std::strtod(tok.c_str(), nullptr));
      else v.push_back(static_cast<T>(std::stoll(tok)));
    }
    return v;
  }
  EXPECT_EQ(a.format, "binary");
  const Bytes b = decode_binary(a.text, zlib);
  EXPECT_EQ(b.size() % sizeof(T), 0u);
  v.resize(b.size() / sizeof(T));
  if (!b.empty()) std::memcpy(v.data(), b.data(), b.size());
  return v;
}

template <class T>
void expect_bit_equal(const std::vector<T>& got, const std::vector<T>& want, const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  EXPECT_EQ(std::memcmp(got.data(), want.data(), want.size() * sizeof(T)), 0) << what;
}

class VtuTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    for (char& c : name) c = c == '/' ? '_' : c;  // parameterised names contain '/'
    dir_ = fs::temp_directory_path() / ("pliant_vtu_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// Two tets on five points, with values that a careless text or binary path would alter.
struct Sample {
  std::vector<double> points{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1.0 / 3, 0.1, -2.5e-300};
  std::vector<Tet> tets{{0, 1, 2, 3}, {1, 2, 3, 4}};
  std::vector<VtuField> fields{
      {"velocity", 3, false,
       {0.1, 0.2, 0.3, 1.0 / 3, -1.0 / 7, 1e308, 4.9e-324, -0.0, std::numbers::pi, 2, 3, 4, 5, 6,
        std::nextafter(1.0, 2.0)}},
      {"stress", 1, true, {123.456, -7.25e-12}}};
};

class VtuEncodings : public VtuTest, public ::testing::WithParamInterface<VtuEncoding> {};

TEST_P(VtuEncodings, RoundTripBitExact) {
  const Sample s;
  const fs::path file = dir_ / "frame.vtu";
  write_vtu(file, s.points, s.tets, s.fields, GetParam());
  ASSERT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(dir_ / "frame.vtu.tmp"));
  const std::string xml = slurp(file);
  const bool zlib = GetParam() == VtuEncoding::base64_zlib;

  EXPECT_NE(xml.find("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
                     "header_type=\"UInt64\""),
            std::string::npos);
  EXPECT_EQ(xml.find("compressor=\"vtkZLibDataCompressor\"") != std::string::npos, zlib);
  EXPECT_NE(xml.find("NumberOfPoints=\"5\""), std::string::npos);
  EXPECT_NE(xml.find("NumberOfCells=\"2\""), std::string::npos);
  // The point field sits in PointData, the cell field in CellData.
  const auto in = [&](const char* section, const char* name) {
    const std::size_t a = xml.find(std::string("<") + section + ">");
    const std::size_t b = xml.find(std::string("</") + section + ">");
    const std::size_t f = xml.find(std::string("Name=\"") + name + "\"");
    return a < f && f < b;
  };
  EXPECT_TRUE(in("PointData", "velocity"));
  EXPECT_TRUE(in("CellData", "stress"));
  EXPECT_TRUE(in("Points", "Points"));

  const Array vel = find_array(xml, "velocity");
  EXPECT_EQ(vel.type, "Float64");
  EXPECT_EQ(vel.components, "3");
  EXPECT_EQ(vel.format, GetParam() == VtuEncoding::ascii ? "ascii" : "binary");
  EXPECT_EQ(find_array(xml, "stress").components, "1");
  EXPECT_EQ(find_array(xml, "Points").components, "3");

  expect_bit_equal(read_array<double>(xml, "Points", zlib), s.points, "Points");
  expect_bit_equal(read_array<double>(xml, "velocity", zlib), s.fields[0].values, "velocity");
  expect_bit_equal(read_array<double>(xml, "stress", zlib), s.fields[1].values, "stress");
  ASSERT_EQ(find_array(xml, "connectivity").type, "Int32");
  expect_bit_equal(read_array<std::int32_t>(xml, "connectivity", zlib),
                   std::vector<std::int32_t>{0, 1, 2, 3, 1, 2, 3, 4}, "connectivity");
  ASSERT_EQ(find_array(xml, "offsets").type, "Int32");
  expect_bit_equal(read_array<std::int32_t>(xml, "offsets", zlib), std::vector<std::int32_t>{4, 8}, "offsets");
  ASSERT_EQ(find_array(xml, "types").type, "UInt8");
  expect_bit_equal(read_array<std::uint8_t>(xml, "types", zlib), std::vector<std::uint8_t>{10, 10}, "types");
}

INSTANTIATE_TEST_SUITE_P(All, VtuEncodings,
                         ::testing::Values(VtuEncoding::ascii, VtuEncoding::base64,
                                           VtuEncoding::base64_zlib),
                         [](const auto& info) {
                           switch (info.param) {
                             case VtuEncoding::ascii: return std::string("ascii");
                             case VtuEncoding::base64: return std::string("base64");
                             default: return std::string("zlib");
                           }
                         });

// Arrays larger than one 32 KiB block (several blocks, partial last one) and exactly one full
// block (last block size 0 in the header).
TEST_F(VtuTest, ZlibMultipleBlocks) {
  const std::size_t np = 5000, nc = 4096;  // points: 120000 B = 3 full blocks + 21696 B
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> points(3 * np);
  for (double& x : points) x = u(rng);
  std::vector<Tet> tets(nc);
  for (std::size_t c = 0; c < nc; ++c)
    for (int k = 0; k < 4; ++k) tets[c][k] = static_cast<std::int32_t>((7 * c + 13 * k) % np);
  std::vector<double> cell(nc);  // 32768 B: one full block
  for (double& x : cell) x = u(rng);
  const fs::path file = dir_ / "big.vtu";
  write_vtu(file, points, tets, {{"c", 1, true, cell}}, VtuEncoding::base64_zlib);
  const std::string xml = slurp(file);

  std::uint64_t blocks = 0;
  const Bytes pb = decode_binary(find_array(xml, "Points").text, true, &blocks);
  EXPECT_EQ(blocks, 4u);
  ASSERT_EQ(pb.size(), points.size() * 8);
  EXPECT_EQ(std::memcmp(pb.data(), points.data(), pb.size()), 0);

  const std::string ctext = strip(find_array(xml, "c").text);
  const Bytes header = base64_decode(ctext.substr(0, 4 * ((8 * 4 + 2) / 3)));
  EXPECT_EQ(u64_at(header, 0), 1u);
  EXPECT_EQ(u64_at(header, 1), 32768u);
  EXPECT_EQ(u64_at(header, 2), 0u);
  expect_bit_equal(read_array<double>(xml, "c", true), cell, "c");
  const auto conn = read_array<std::int32_t>(xml, "connectivity", true);
  ASSERT_EQ(conn.size(), 4 * nc);
  EXPECT_EQ(std::memcmp(conn.data(), tets.data(), conn.size() * 4), 0);
}

TEST_F(VtuTest, EmptyMeshIsValid) {
  for (VtuEncoding e : {VtuEncoding::ascii, VtuEncoding::base64, VtuEncoding::base64_zlib}) {
    const fs::path file = dir_ / "empty.vtu";
    write_vtu(file, {}, {}, {}, e);
    const std::string xml = slurp(file);
    EXPECT_NE(xml.find("NumberOfPoints=\"0\""), std::string::npos);
    EXPECT_TRUE(read_array<double>(xml, "Points", e == VtuEncoding::base64_zlib).empty());
  }
}

TEST_F(VtuTest, OverwriteReplacesContents) {
  const Sample s;
  const fs::path file = dir_ / "f.vtu";
  write_vtu(file, s.points, s.tets, s.fields, VtuEncoding::ascii);
  write_vtu(file, s.points, {s.tets.data(), 1}, {}, VtuEncoding::ascii);
  EXPECT_NE(slurp(file).find("NumberOfCells=\"1\""), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "f.vtu.tmp"));
}

TEST_F(VtuTest, FieldSizeMismatchNamesField) {
  Sample s;
  s.fields[1].values.pop_back();
  const fs::path file = dir_ / "bad.vtu";
  try {
    write_vtu(file, s.points, s.tets, s.fields);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("stress"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(file));
  EXPECT_FALSE(fs::exists(dir_ / "bad.vtu.tmp"));
}

TEST_F(VtuTest, IndexOutOfRangeThrows) {
  Sample s;
  s.tets[1][3] = 5;
  EXPECT_THROW(write_vtu(dir_ / "bad.vtu", s.points, s.tets, {}), InputError);
}

TEST_F(VtuTest, UnwritablePathNamesPath) {
  const Sample s;
  const fs::path file = dir_ / "no_such_folder" / "x.vtu";
  try {
    write_vtu(file, s.points, s.tets, s.fields);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
  PvdSeries pvd(dir_ / "no_such_folder" / "x.pvd");
  EXPECT_THROW(pvd.write(), InputError);
}

TEST_F(VtuTest, PvdListsEntriesInOrder) {
  PvdSeries pvd(dir_ / "run.pvd");
  pvd.add(0.0, "frames/f_0000.vtu");
  pvd.add(0.1, "frames/f_0001.vtu");
  pvd.add(0.25, "frames/f_0002.vtu", 1);
  pvd.write();
  pvd.add(1.0 / 3, "frames/f_0003.vtu");
  pvd.write();  // rewrites the whole collection
  const std::string xml = slurp(dir_ / "run.pvd");
  EXPECT_NE(xml.find("<VTKFile type=\"Collection\""), std::string::npos);
  EXPECT_NE(xml.find("<Collection>"), std::string::npos);
  EXPECT_NE(xml.find("</Collection>"), std::string::npos);
  std::vector<std::string> files, times, parts;
  const std::regex ds("<DataSet\\s[^>]*/>");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), ds); it != std::sregex_iterator(); ++it) {
    const std::string tag = it->str();
    files.push_back(attribute(tag, "file"));
    times.push_back(attribute(tag, "timestep"));
    parts.push_back(attribute(tag, "part"));
  }
  EXPECT_EQ(files, (std::vector<std::string>{"frames/f_0000.vtu", "frames/f_0001.vtu",
                                             "frames/f_0002.vtu", "frames/f_0003.vtu"}));
  ASSERT_EQ(times.size(), 4u);
  EXPECT_EQ(std::strtod(times[1].c_str(), nullptr), 0.1);
  EXPECT_EQ(std::strtod(times[3].c_str(), nullptr), 1.0 / 3);
  EXPECT_EQ(parts, (std::vector<std::string>{"0", "0", "1", "0"}));
  EXPECT_FALSE(fs::exists(dir_ / "run.pvd.tmp"));
}

}  // namespace
}  // namespace pliant
