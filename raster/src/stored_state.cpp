// What a result file stores besides its mesh, for `pliant render FILE.vtu`: the point field
// "displacement" (3 components, m) and the cell field "von_mises" (Pa) that `pliant run` writes
// into every .vtu (engine run_scene.cpp), and the file's simulated time, from a "TimeValue"
// field-data array or from the ParaView .pvd series that lists the file (the run writes
// OUT/series.pvd for OUT/vtu/*.vtu). The engine's mesh reader keeps only points and cells, so
// the arrays are read here: DataArrays inline as ascii or base64 binary (UInt32/UInt64 headers,
// optionally vtkZLibDataCompressor, either byte order). Anything else (appended data, other
// compressors) leaves the field out with a note; the picture can still be drawn.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/error.hpp"
#include "pliant/raster/render.hpp"

namespace pliant::raster {
namespace {
namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream s;
  s << in.rdbuf();
  return std::move(s).str();
}

// A start tag: its name, attributes and the text up to its end tag (empty when self-closing).
struct Tag {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::string_view body;
  std::size_t end = 0;  // just past the element
  const std::string* attr(std::string_view key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
};

// The next element named `name` in `text` from `pos` (no nesting of the same name, which holds
// for VTKFile, Piece, PointData, CellData, FieldData and DataArray). Comments are skipped.
std::optional<Tag> next_tag(std::string_view text, std::string_view name, std::size_t pos) {
  for (;;) {
    const std::size_t lt = text.find('<', pos);
    if (lt == std::string_view::npos) return std::nullopt;
    if (text.substr(lt, 4) == "<!--") {
      const std::size_t e = text.find("-->", lt + 4);
      if (e == std::string_view::npos) return std::nullopt;
      pos = e + 3;
      continue;
    }
    pos = lt + 1;
    if (text.substr(lt + 1, name.size()) != name) continue;
    const std::size_t after = lt + 1 + name.size();
    if (after >= text.size() || !(std::isspace(static_cast<unsigned char>(text[after])) || text[after] == '>' || text[after] == '/'))
      continue;
    Tag tag;
    tag.name = std::string(name);
    std::size_t i = after;
    bool closed = false;
    for (;;) {
      while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      if (i >= text.size()) return std::nullopt;
      if (text[i] == '>') {
        ++i;
        break;
      }
      if (text.substr(i, 2) == "/>") {
        i += 2;
        closed = true;
        break;
      }
      const std::size_t k0 = i;
      while (i < text.size() && text[i] != '=' && text[i] != '>' && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      std::string key(text.substr(k0, i - k0));
      while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      if (i >= text.size() || text[i] != '=') return std::nullopt;
      ++i;
      while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      if (i >= text.size() || (text[i] != '"' && text[i] != '\'')) return std::nullopt;
      const char q = text[i];
      const std::size_t v1 = text.find(q, i + 1);
      if (v1 == std::string_view::npos) return std::nullopt;
      tag.attrs.emplace_back(std::move(key), std::string(text.substr(i + 1, v1 - i - 1)));
      i = v1 + 1;
    }
    if (closed) {
      tag.end = i;
      return tag;
    }
    const std::string close = "</" + std::string(name);
    const std::size_t e = text.find(close, i);
    if (e == std::string_view::npos) return std::nullopt;
    tag.body = text.substr(i, e - i);
    const std::size_t gt = text.find('>', e);
    tag.end = gt == std::string_view::npos ? text.size() : gt + 1;
    return tag;
  }
}

// "&quot;" and friends in attribute values (file names in a .pvd).
std::string unescape(std::string_view v) {
  static const std::pair<std::string_view, char> entities[] = {
      {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t i = 0; i < v.size();) {
    bool done = false;
    for (const auto& [e, c] : entities)
      if (!done && v.substr(i, e.size()) == e) out += c, i += e.size(), done = true;
    if (!done) out += v[i++];
  }
  return out;
}

bool parse_double(std::string_view s, double& v) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && !s.empty();
}

struct Encoding {
  bool swap = false, zlib = false;
  std::size_t header_bytes = 4;
};

template <class S>
S load(const unsigned char* p, bool swap) {
  unsigned char b[sizeof(S)];
  std::memcpy(b, p, sizeof(S));
  if (swap) std::reverse(b, b + sizeof(S));
  S s;
  std::memcpy(&s, b, sizeof(S));
  return s;
}

// Base64 that may restart after padding (VTK encodes a compressed array's header and data apart).
std::vector<unsigned char> base64(std::string_view s) {
  std::vector<unsigned char> out;
  unsigned quad[4];
  int n = 0, pad = 0;
  for (char ch : s) {
    if (std::isspace(static_cast<unsigned char>(ch))) continue;
    int v;
    if (ch >= 'A' && ch <= 'Z') v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z') v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9') v = ch - '0' + 52;
    else if (ch == '+') v = 62;
    else if (ch == '/') v = 63;
    else if (ch == '=' && n >= 2) v = 0, ++pad;
    else throw std::runtime_error(fmt::format("invalid base64 character '{}'", ch));
    quad[n++] = unsigned(v);
    if (n == 4) {
      const unsigned w = quad[0] << 18 | quad[1] << 12 | quad[2] << 6 | quad[3];
      const unsigned char b[3] = {static_cast<unsigned char>(w >> 16), static_cast<unsigned char>(w >> 8),
                                  static_cast<unsigned char>(w)};
      out.insert(out.end(), b, b + 3 - std::min(pad, 2));
      n = pad = 0;
    }
  }
  if (n != 0) throw std::runtime_error("base64 data is cut short");
  return out;
}

std::vector<unsigned char> payload(std::string_view body, const Encoding& enc) {
  const auto bytes = base64(body);
  const std::size_t hw = enc.header_bytes;
  auto word = [&](std::size_t i) -> std::uint64_t {
    if ((i + 1) * hw > bytes.size()) throw std::runtime_error("binary data is cut short");
    return hw == 8 ? load<std::uint64_t>(&bytes[8 * i], enc.swap) : load<std::uint32_t>(&bytes[4 * i], enc.swap);
  };
  if (!enc.zlib) {
    const std::uint64_t n = word(0);
    if (n > bytes.size() - hw) throw std::runtime_error("binary data is cut short");
    return {bytes.begin() + std::ptrdiff_t(hw), bytes.begin() + std::ptrdiff_t(hw + n)};
  }
  const std::uint64_t blocks = word(0), block = word(1), last = word(2);
  if (blocks > bytes.size() / hw || block > (1u << 30) || last > block)
    throw std::runtime_error("bad compression header");
  std::vector<unsigned char> out;
  std::size_t src = (3 + blocks) * hw;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::uint64_t csize = word(3 + b);
    const std::uint64_t usize = (b + 1 == blocks && last != 0) ? last : block;
    if (src > bytes.size() || csize > bytes.size() - src) throw std::runtime_error("binary data is cut short");
    if (usize > 1100 * csize + 64) throw std::runtime_error("bad compression header");
    const std::size_t at = out.size();
    out.resize(at + usize);
    uLongf got = uLongf(usize);
    if (uncompress(out.data() + at, &got, &bytes[src], uLong(csize)) != Z_OK || got != usize)
      throw std::runtime_error("corrupt zlib data");
    src += csize;
  }
  return out;
}

// The values of a DataArray as doubles.
std::vector<double> values_of(const Tag& da, const Encoding& enc) {
  const std::string* type = da.attr("type");
  const std::string format = da.attr("format") ? *da.attr("format") : "ascii";
  std::vector<double> out;
  if (format == "ascii") {
    std::string_view b = da.body;
    std::size_t i = 0;
    while (i < b.size()) {
      while (i < b.size() && std::isspace(static_cast<unsigned char>(b[i]))) ++i;
      const std::size_t t = i;
      while (i < b.size() && !std::isspace(static_cast<unsigned char>(b[i]))) ++i;
      if (i == t) break;
      double v = 0;
      if (!parse_double(b.substr(t, i - t), v))
        throw std::runtime_error(fmt::format("'{}' is not a number", b.substr(t, std::min<std::size_t>(i - t, 40))));
      out.push_back(v);
    }
    return out;
  }
  if (format != "binary") throw std::runtime_error(fmt::format("format=\"{}\" is not supported (only ascii and binary)", format));
  if (!type) throw std::runtime_error("no type");
  const auto bytes = payload(da.body, enc);
  auto convert = [&]<class S>(S) {
    if (bytes.size() % sizeof(S) != 0) throw std::runtime_error(fmt::format("{} bytes is not a whole number of {}", bytes.size(), *type));
    out.reserve(bytes.size() / sizeof(S));
    for (std::size_t i = 0; i < bytes.size(); i += sizeof(S)) out.push_back(double(load<S>(&bytes[i], enc.swap)));
  };
  if (*type == "Float32") convert(float{});
  else if (*type == "Float64") convert(double{});
  else if (*type == "Int32") convert(std::int32_t{});
  else if (*type == "Int64") convert(std::int64_t{});
  else if (*type == "UInt32") convert(std::uint32_t{});
  else if (*type == "UInt64") convert(std::uint64_t{});
  else throw std::runtime_error(fmt::format("type \"{}\" is not supported", *type));
  return out;
}

long long count_of(const Tag& t, const char* key) {
  const std::string* v = t.attr(key);
  long long n = -1;
  if (v) std::from_chars(v->data(), v->data() + v->size(), n);
  return n;
}

// The array named `name` in the section `section` (PointData, CellData, FieldData) of a piece,
// with `components` components; nullopt when absent.
std::optional<std::vector<double>> find_array(std::string_view piece, std::string_view section, std::string_view name,
                                              int components, const Encoding& enc) {
  const auto sec = next_tag(piece, section, 0);
  if (!sec) return std::nullopt;
  for (std::size_t pos = 0;;) {
    const auto da = next_tag(sec->body, "DataArray", pos);
    if (!da) return std::nullopt;
    pos = da->end;
    if (!da->attr("Name") || *da->attr("Name") != name) continue;
    const std::string* nc = da->attr("NumberOfComponents");
    if ((nc ? std::atoi(nc->c_str()) : 1) != components)
      throw std::runtime_error(fmt::format("{} \"{}\" has {} components, expected {}", section, name, nc ? *nc : "1",
                                           components));
    return values_of(*da, enc);
  }
}

}  // namespace

std::optional<double> series_time(const fs::path& file) {
  std::error_code ec;
  const fs::path target = fs::weakly_canonical(file, ec);
  if (ec) return std::nullopt;
  // The .pvd files of the file's folder and of the folder above (OUT/series.pvd lists OUT/vtu/*.vtu).
  for (const fs::path& dir : {target.parent_path(), target.parent_path().parent_path()}) {
    fs::directory_iterator it(dir, ec);
    if (ec) continue;
    std::vector<fs::path> pvds;
    for (const auto& e : it) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      if (ext == ".pvd") pvds.push_back(e.path());
    }
    std::sort(pvds.begin(), pvds.end());
    for (const fs::path& pvd : pvds) {
      const std::string text = read_text(pvd);
      for (std::size_t pos = 0;;) {
        const auto ds = next_tag(text, "DataSet", pos);
        if (!ds) break;
        pos = ds->end;
        const std::string *f = ds->attr("file"), *t = ds->attr("timestep");
        if (!f || !t) continue;
        const fs::path listed = fs::weakly_canonical(dir / unescape(*f), ec);
        double time = 0;
        if (!ec && listed == target && parse_double(*t, time) && std::isfinite(time)) return time;
      }
    }
  }
  return std::nullopt;
}

StoredFields read_stored_fields(const fs::path& file, const TetMesh& mesh) {
  StoredFields s;
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const std::string text = ext == ".vtu" || ext == ".vtk" ? read_text(file) : std::string();
  const auto vtk = next_tag(text, "VTKFile", 0);
  if (vtk && vtk->attr("type") && *vtk->attr("type") == "UnstructuredGrid") {
    Encoding enc;
    if (const auto* order = vtk->attr("byte_order")) enc.swap = (*order == "BigEndian") != (std::endian::native == std::endian::big);
    if (const auto* h = vtk->attr("header_type")) enc.header_bytes = *h == "UInt64" ? 8 : 4;
    if (const auto* c = vtk->attr("compressor")) enc.zlib = *c == "vtkZLibDataCompressor";
    const bool other_compressor = vtk->attr("compressor") && !vtk->attr("compressor")->empty() && !enc.zlib;
    std::vector<double> disp, vm;
    bool have_disp = true, have_vm = true;
    long long points = 0, cells = 0;
    try {
      if (other_compressor) throw std::runtime_error(fmt::format("compressor \"{}\" is not supported", *vtk->attr("compressor")));
      // Field data: a "TimeValue" (VTK's name for the time of a data set).
      if (const auto t = find_array(vtk->body, "FieldData", "TimeValue", 1, enc); t && t->size() == 1 && std::isfinite((*t)[0]))
        s.time = (*t)[0];
      for (std::size_t pos = 0;;) {
        const auto piece = next_tag(vtk->body, "Piece", pos);
        if (!piece) break;
        pos = piece->end;
        const long long np = count_of(*piece, "NumberOfPoints"), nc = count_of(*piece, "NumberOfCells");
        if (np < 0 || nc < 0) throw std::runtime_error("a <Piece> without NumberOfPoints or NumberOfCells");
        points += np;
        cells += nc;
        if (have_disp) {
          const auto d = find_array(piece->body, "PointData", "displacement", 3, enc);
          if (d && (long long)d->size() == 3 * np) disp.insert(disp.end(), d->begin(), d->end());
          else have_disp = false;
        }
        if (have_vm) {
          const auto v = find_array(piece->body, "CellData", "von_mises", 1, enc);
          if (v && (long long)v->size() == nc) vm.insert(vm.end(), v->begin(), v->end());
          else have_vm = false;
        }
      }
    } catch (const std::exception& e) {
      s.note = fmt::format("{}: its fields cannot be read ({})", file.filename().string(), e.what());
      have_disp = have_vm = false;
    }
    const bool same = std::size_t(points) == mesh.node_count() && std::size_t(cells) == mesh.tet_count();
    if (!same && (have_disp || have_vm)) {
      s.note = fmt::format("{}: its fields do not match the mesh as read ({} points and {} cells in the file, {} nodes and "
                           "{} tets used)",
                           file.filename().string(), points, cells, mesh.node_count(), mesh.tet_count());
      have_disp = have_vm = false;
    }
    if (have_disp && points > 0) s.displacement = std::move(disp);
    if (have_vm && cells > 0) s.von_mises = std::move(vm);
  }
  if (!s.time) s.time = series_time(file);
  return s;
}

}  // namespace pliant::raster
