// read_tet_mesh: picks the reader from the file extension (and, for .vtk, from the content:
// SOFA's Bunny.vtk is really a VTK XML file), plus the small text helpers that all readers
// share (see mesh_reader_util.hpp). Every error names the file first.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "mesh_reader_util.hpp"
#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/mesh_io.hpp"

namespace pliant {
namespace meshio {

void fail(const std::string& message) { throw InputError(message); }

std::string read_file(const std::filesystem::path& path) {
  std::string text = read_input_file(path, "mesh file");  // regular files only
  if (trim(text).empty()) fail(fmt::format("{}: file is empty", path.string()));
  return text;
}

static bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_blank(s[i])) ++i;
    const std::size_t b = i;
    while (i < s.size() && !is_blank(s[i])) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
  return out;
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && starts_with_nocase(a, b);
}

bool starts_with_nocase(std::string_view s, std::string_view prefix) {
  if (s.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[i])) !=
        std::tolower(static_cast<unsigned char>(prefix[i])))
      return false;
  return true;
}

bool parse_int(std::string_view t, long long& out) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && end == t.data() + t.size();
}

bool parse_double(std::string_view t, double& out) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && end == t.data() + t.size();
}

long long count_limit(std::size_t file_bytes, long long per_byte) {
  // 2^50 at most (2^40 bytes x 1024): a product of two such counts still needs a check, one
  // count times a small factor (3 coordinates, 10 corners) does not.
  const double limit = double(file_bytes) * double(per_byte) + 64;
  return limit < 1125899906842624.0 ? static_cast<long long>(limit) : 1125899906842624LL;
}

void check_count(long long n, std::size_t file_bytes, long long per_byte, const std::string& where,
                 const std::string& what) {
  if (n < 0 || n > count_limit(file_bytes, per_byte))
    fail(fmt::format("{}: {} is more than the file ({} bytes) can hold", where, what, file_bytes));
}

std::size_t line_of(std::string_view text, std::size_t offset) {
  offset = std::min(offset, text.size());
  return 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + offset, '\n'));
}

bool LineCursor::next() {
  if (pos_ >= text_.size()) return false;
  std::size_t end = text_.find('\n', pos_);
  if (end == std::string_view::npos) end = text_.size();
  line_ = text_.substr(pos_, end - pos_);
  if (!line_.empty() && line_.back() == '\r') line_.remove_suffix(1);
  pos_ = end + 1;
  ++number_;
  return true;
}

// True when the file's first non-blank bytes open an XML document. Only a regular file is opened
// (a FIFO's open would block here, before the reader's own check).
static bool looks_like_xml(const std::filesystem::path& path) {
  check_input_file(path, "mesh file");
  std::ifstream in(path, std::ios::binary);
  char buf[256] = {};
  in.read(buf, sizeof buf);
  std::string_view head(buf, static_cast<std::size_t>(in.gcount()));
  if (head.substr(0, 3) == "\xEF\xBB\xBF") head.remove_prefix(3);  // UTF-8 byte order mark
  head = trim(head);
  return head.substr(0, 5) == "<?xml" || head.substr(0, 8) == "<VTKFile";
}

}  // namespace meshio

TetMesh read_tet_mesh(const std::filesystem::path& path, MeshLoadReport* report) {
  MeshLoadReport local;
  MeshLoadReport& r = report ? *report : local;
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".msh") return read_gmsh(path, r);
  if (ext == ".vtu") return read_vtu(path, r);
  if (ext == ".node" || ext == ".ele") return read_tetgen(path, r);
  if (ext == ".vtk") {
    return meshio::looks_like_xml(path) ? read_vtu(path, r) : read_vtk_legacy(path, r);
  }
  throw InputError(fmt::format(
      "{}: unknown mesh file extension '{}' (expected .msh, .vtk, .vtu, .node or .ele)",
      path.string(), ext));
}

}  // namespace pliant
