// VTK XML UnstructuredGrid reader (.vtu, and SOFA's XML files misnamed .vtk). Why: it is
// what ParaView, meshio and SOFA exchange volume meshes in. Reads each <Piece>'s Points (m)
// and Cells (connectivity, offsets, types), with DataArrays inline as format="ascii" or
// format="binary" (base64; header UInt32 or UInt64 per header_type; optionally
// compressor="vtkZLibDataCompressor"; LittleEndian or BigEndian, swapped as needed).
// format="appended" and other compressors are refused with a clear error. No XML library is
// available, so a small scanner below handles what VTK writes: elements, quoted attributes,
// comments, <?...?> and <!...> declarations. VTK_TETRA (10) cells are kept,
// VTK_QUADRATIC_TETRA (24) by its 4 corners, other cells skipped and counted.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

#include "pliant/error.hpp"
#include <vector>

#include <fmt/format.h>
#include <zlib.h>

#include "mesh_reader_util.hpp"
#include "pliant/mesh_io.hpp"

namespace pliant {
namespace {

using namespace meshio;

struct XmlNode {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::size_t offset = 0;                         // of its '<' in the text
  std::size_t content_begin = 0, content_end = 0;  // text between start and end tag
  std::vector<XmlNode> children;

  const std::string* attr(std::string_view key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return &v;
    return nullptr;
  }
  const XmlNode* child(std::string_view n) const {
    for (const auto& c : children)
      if (c.name == n) return &c;
    return nullptr;
  }
};

// A tolerant, non-validating scanner: builds the element tree, checks that tags nest.
class XmlScanner {
 public:
  XmlScanner(const std::string& src, std::string_view text) : src_(src), text_(text) {}

  XmlNode parse() {
    XmlNode document;
    content(document, 0);
    return document;
  }

 private:
  [[noreturn]] void error(std::size_t at, const std::string& msg) const {
    fail(fmt::format("{}:{}: {}", src_, line_of(text_, at), msg));
  }
  static bool blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
  static bool name_char(char c) { return !blank(c) && c != '/' && c != '>' && c != '=' && c != '<'; }
  bool at(std::string_view s) const { return text_.substr(pos_, s.size()) == s; }
  void skip_blanks() {
    while (pos_ < text_.size() && blank(text_[pos_])) ++pos_;
  }
  void skip_past(std::string_view end, const char* what) {
    const std::size_t start = pos_, e = text_.find(end, pos_);
    if (e == std::string_view::npos) error(start, fmt::format("unterminated {}", what));
    pos_ = e + end.size();
  }
  std::string name() {
    const std::size_t b = pos_;
    while (pos_ < text_.size() && name_char(text_[pos_])) ++pos_;
    if (pos_ == b) error(b, "expected a tag or attribute name");
    return std::string(text_.substr(b, pos_ - b));
  }
  static std::string unescape(std::string_view v) {
    static const std::pair<std::string_view, char> entities[] = {
        {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}, {"&quot;", '"'}, {"&apos;", '\''}};
    std::string out;
    for (std::size_t i = 0; i < v.size();) {
      bool done = false;
      for (const auto& [e, c] : entities)
        if (v.substr(i, e.size()) == e) out += c, i += e.size(), done = true;
      if (!done) out += v[i++];
    }
    return out;
  }

  // Children and text of `node` up to its end tag (up to the end of the text for the document).
  void content(XmlNode& node, int depth) {
    for (;;) {
      const std::size_t lt = text_.find('<', pos_);
      if (lt == std::string_view::npos) {
        if (depth == 0) return;
        error(node.offset, fmt::format("<{}> is not closed (truncated file?)", node.name));
      }
      pos_ = lt;
      if (at("<!--")) { skip_past("-->", "comment"); continue; }
      if (at("<![CDATA[")) { skip_past("]]>", "CDATA section"); continue; }
      if (at("<?")) { skip_past("?>", "<?...?> declaration"); continue; }
      if (at("<!")) { skip_past(">", "<!...> declaration"); continue; }
      if (at("</")) {
        pos_ += 2;
        const std::string n = name();
        skip_blanks();
        if (pos_ >= text_.size() || text_[pos_] != '>') error(lt, "malformed end tag");
        ++pos_;
        if (depth == 0) error(lt, fmt::format("</{}> closes nothing", n));
        if (n != node.name)
          error(lt, fmt::format("</{}> closes <{}> opened at line {}", n, node.name,
                                line_of(text_, node.offset)));
        node.content_end = lt;
        return;
      }
      node.children.push_back(start_tag(depth));
    }
  }

  XmlNode start_tag(int depth) {
    if (depth > 64) error(pos_, "XML nested too deeply");
    XmlNode node;
    node.offset = pos_++;
    node.name = name();
    for (;;) {
      skip_blanks();
      if (pos_ >= text_.size()) error(node.offset, fmt::format("<{} is cut short (truncated file?)", node.name));
      if (text_[pos_] == '>') { ++pos_; break; }
      if (at("/>")) {
        pos_ += 2;
        node.content_begin = node.content_end = pos_;
        return node;
      }
      std::string key = name();
      skip_blanks();
      if (pos_ >= text_.size() || text_[pos_] != '=') error(pos_, fmt::format("attribute {} has no value", key));
      ++pos_;
      skip_blanks();
      const char quote = pos_ < text_.size() ? text_[pos_] : '\0';
      if (quote != '"' && quote != '\'') error(pos_, fmt::format("attribute {}: value not quoted", key));
      const std::size_t end = text_.find(quote, pos_ + 1);
      if (end == std::string_view::npos) error(pos_, fmt::format("attribute {}: unterminated value", key));
      node.attrs.emplace_back(std::move(key), unescape(text_.substr(pos_ + 1, end - pos_ - 1)));
      pos_ = end + 1;
    }
    node.content_begin = pos_;
    if (node.name == "AppendedData") {  // raw bytes may contain '<': jump to the last end tag
      const std::size_t e = text_.rfind("</AppendedData>");
      if (e == std::string_view::npos || e < pos_) error(node.offset, "<AppendedData> is not closed");
      node.content_end = e;
      pos_ = e + std::string_view("</AppendedData>").size();
      return node;
    }
    content(node, depth + 1);
    return node;
  }

  const std::string& src_;
  std::string_view text_;
  std::size_t pos_ = 0;
};

// Reads one element of type S from possibly byte-swapped storage.
template <class S>
S load(const unsigned char* p, bool swap) {
  unsigned char b[sizeof(S)];
  std::memcpy(b, p, sizeof(S));
  if (swap) std::reverse(b, b + sizeof(S));
  S s;
  std::memcpy(&s, b, sizeof(S));
  return s;
}

class VtuReader {
 public:
  VtuReader(std::string source, std::string_view text, MeshLoadReport& report, VtuData* data)
      : src_(std::move(source)), text_(text), report_(report), data_(data) {}

  TetMesh read() {
    const XmlNode doc = XmlScanner(src_, text_).parse();
    const XmlNode* vtk = doc.child("VTKFile");
    if (!vtk) fail(fmt::format("{}: not a VTK XML file (no <VTKFile> element)", src_));
    if (const auto* type = vtk->attr("type"); type && *type != "UnstructuredGrid")
      error(*vtk, fmt::format("VTKFile type \"{}\" is not supported (expected UnstructuredGrid)", *type));
    if (const auto* order = vtk->attr("byte_order")) {
      if (*order != "LittleEndian" && *order != "BigEndian") error(*vtk, "unknown byte_order " + *order);
      swap_ = (*order == "BigEndian") != (std::endian::native == std::endian::big);
    } else {
      swap_ = std::endian::native == std::endian::big;
    }
    if (const auto* header = vtk->attr("header_type")) {
      if (*header == "UInt64") header_bytes_ = 8;
      else if (*header != "UInt32") error(*vtk, "unknown header_type " + *header);
    }
    if (const auto* comp = vtk->attr("compressor")) {
      if (*comp == "vtkZLibDataCompressor") zlib_ = true;
      else if (!comp->empty())
        error(*vtk, fmt::format("compressor \"{}\" is not supported (only vtkZLibDataCompressor)", *comp));
    }
    const XmlNode* grid = vtk->child("UnstructuredGrid");
    if (!grid) error(*vtk, "no <UnstructuredGrid> in <VTKFile>");
    bool any_piece = false;
    for (const XmlNode& piece : grid->children)
      if (piece.name == "Piece") read_piece(piece), any_piece = true;
    if (data_) {
      if (const XmlNode* fd = grid->child("FieldData")) read_data_arrays(*fd, data_->field, std::nullopt);
      // A point or cell array must cover every piece.
      for (auto* section : {&data_->point, &data_->cell}) {
        const std::size_t tuples = section == &data_->point ? data_->points : data_->cells;
        for (auto it = section->begin(); it != section->end();)
          if (it->second.values.size() != tuples * static_cast<std::size_t>(it->second.components)) {
            data_->notes.push_back(fmt::format("{}: DataArray \"{}\" is missing from some <Piece>", src_, it->first));
            it = section->erase(it);
          } else {
            ++it;
          }
      }
    }
    if (!any_piece) error(*grid, "no <Piece> in <UnstructuredGrid>");
    finalize_tet_mesh_named(mesh_, src_, report_,
                            [this](std::size_t i) { return fmt::format(": cell {}", tet_cell_[i]); });
    return std::move(mesh_);
  }

 private:
  [[noreturn]] void error(const XmlNode& at, const std::string& msg) const {
    fail(fmt::format("{}:{}: {}", src_, line_of(text_, at.offset), msg));
  }

  long long count_attr(const XmlNode& node, const char* key) const {
    const std::string* v = node.attr(key);
    long long n = 0;
    if (!v) error(node, fmt::format("<{}> has no {} attribute", node.name, key));
    if (!parse_int(*v, n) || n < 0) error(node, fmt::format("{}=\"{}\" is not a count", key, *v));
    check_file_count(node, n, fmt::format("{}=\"{}\"", key, *v));
    return n;
  }

  // Values the file can hold at most: a byte each, zlib-compressed up to 1032:1 (check_count).
  long long per_byte() const { return zlib_ ? 1100 : 1; }
  void check_file_count(const XmlNode& at, long long n, const std::string& what) const {
    check_count(n, text_.size(), per_byte(), fmt::format("{}:{}", src_, line_of(text_, at.offset)), what);
  }

  const XmlNode& array_named(const XmlNode& cells, const char* name) const {
    for (const XmlNode& c : cells.children)
      if (c.name == "DataArray" && c.attr("Name") && *c.attr("Name") == name) return c;
    error(cells, fmt::format("<Cells> has no DataArray named \"{}\"", name));
  }

  void read_piece(const XmlNode& piece) {
    const long long np = count_attr(piece, "NumberOfPoints");
    const long long nc = count_attr(piece, "NumberOfCells");
    const XmlNode* points = piece.child("Points");
    if (!points) error(piece, "<Piece> has no <Points>");
    const XmlNode* pda = points->child("DataArray");
    if (!pda) error(*points, "<Points> has no <DataArray>");
    if (const auto* nco = pda->attr("NumberOfComponents"); !nco || *nco != "3")
      error(*pda, "the Points DataArray must have NumberOfComponents=\"3\"");
    const auto xyz = read_array<double>(*pda, "Points", 3 * np);
    const XmlNode* cells = piece.child("Cells");
    if (!cells) error(piece, "<Piece> has no <Cells>");
    const auto conn = read_array<long long>(array_named(*cells, "connectivity"), "connectivity", std::nullopt);
    const auto offsets = read_array<long long>(array_named(*cells, "offsets"), "offsets", nc);
    const auto types = read_array<long long>(array_named(*cells, "types"), "types", nc);

    const long long base = static_cast<long long>(mesh_.node_count());
    mesh_.points.insert(mesh_.points.end(), xyz.begin(), xyz.end());
    long long begin = 0;
    for (long long c = 0; c < nc; ++c, ++cell_base_) {
      const long long end = offsets[c];
      if (end < begin || end > static_cast<long long>(conn.size()))
        fail(fmt::format("{}: cell {}: offset {} is out of order or beyond the {} connectivity values",
                         src_, cell_base_, end, conn.size()));
      const long long size = end - begin;
      if (types[c] == 10 || types[c] == 24) {
        const long long expected = types[c] == 10 ? 4 : 10;
        if (size != expected)
          fail(fmt::format("{}: cell {}: a tetrahedron (type {}) with {} points, expected {}", src_,
                           cell_base_, types[c], size, expected));
        Tet tet{};
        for (int k = 0; k < 4; ++k) {
          const long long p = conn[begin + k];
          if (p < 0 || p >= np)
            fail(fmt::format("{}: cell {}: refers to point {}, which is not defined ({} points)",
                             src_, cell_base_, p, np));
          tet[k] = static_cast<std::int32_t>(base + p);
        }
        mesh_.tets.push_back(tet);
        tet_cell_.push_back(cell_base_);
      } else {
        ++report_.skipped_cells;
      }
      begin = end;
    }
    if (begin != static_cast<long long>(conn.size()))
      error(array_named(*cells, "connectivity"),
            fmt::format("the connectivity has {} values, but the offsets end at {}", conn.size(), begin));
    if (data_) {
      if (const XmlNode* pd = piece.child("PointData")) read_data_arrays(*pd, data_->point, np);
      if (const XmlNode* cd = piece.child("CellData")) read_data_arrays(*cd, data_->cell, nc);
      data_->points += static_cast<std::size_t>(np);
      data_->cells += static_cast<std::size_t>(nc);
    }
  }

  // The DataArrays of a <PointData>, <CellData> or <FieldData> section, appended to `into` by
  // name; `tuples` values per component expected (for fields: any). An array that cannot be read
  // is dropped (with a note), and so is one missing from an earlier piece: a field must cover the
  // whole file to be used.
  void read_data_arrays(const XmlNode& section, std::map<std::string, VtuArray>& into,
                        std::optional<long long> tuples) {
    const std::size_t earlier = section.name == "PointData" ? data_->points : data_->cells;
    for (const XmlNode& da : section.children) {
      if (da.name != "DataArray" || !da.attr("Name")) continue;
      const std::string name = *da.attr("Name");
      long long nc = 1;
      const std::string* components = da.attr("NumberOfComponents");
      if (components && (!parse_int(*components, nc) || nc < 1)) nc = -1;
      const bool first_piece = tuples ? earlier == 0 : true;
      auto it = into.find(name);
      if (!first_piece && it == into.end()) continue;  // absent from an earlier piece
      try {
        if (nc < 1) error(da, fmt::format("DataArray \"{}\": bad NumberOfComponents", name));
        if (components) check_file_count(da, nc, fmt::format("NumberOfComponents=\"{}\"", *components));
        std::optional<long long> expected;
        if (tuples) {  // both checked against the file, but their product may still be too large
          if (*tuples > count_limit(text_.size(), per_byte()) / nc)
            error(da, fmt::format("DataArray \"{}\": {} tuples of {} components are more than the file ({} bytes) "
                                  "can hold", name, *tuples, nc, text_.size()));
          expected = *tuples * nc;
        }
        std::vector<double> v = read_array<double>(da, name.c_str(), expected);
        if (it == into.end()) {
          into[name] = VtuArray{static_cast<int>(nc), std::move(v)};
        } else if (it->second.components != nc) {
          error(da, fmt::format("DataArray \"{}\": {} components here, {} in an earlier piece", name, nc,
                                it->second.components));
        } else {
          it->second.values.insert(it->second.values.end(), v.begin(), v.end());
        }
      } catch (const InputError& e) {
        data_->notes.push_back(e.what());
        into.erase(name);
      }
    }
  }

  // A DataArray as T (double for coordinates, long long for indices); `expected` values if set.
  template <class T>
  std::vector<T> read_array(const XmlNode& da, const char* what, std::optional<long long> expected) {
    const std::string* type = da.attr("type");
    if (!type) error(da, fmt::format("DataArray \"{}\" has no type", what));
    const bool is_float = *type == "Float32" || *type == "Float64";
    if (!std::is_floating_point_v<T> && is_float)
      error(da, fmt::format("DataArray \"{}\" must hold integers, not {}", what, *type));
    const std::string* format = da.attr("format");
    const std::string fmt_name = format ? *format : "ascii";
    std::vector<T> out;
    const std::string_view body = text_.substr(da.content_begin, da.content_end - da.content_begin);
    if (fmt_name == "ascii") {
      out = ascii_values<T>(body, da.content_begin, what);
    } else if (fmt_name == "binary") {
      out = binary_values<T>(da, body, *type, what);
    } else if (fmt_name == "appended") {
      error(da, fmt::format("DataArray \"{}\" uses format=\"appended\", which is not supported; "
                            "re-save with inline ascii or binary data", what));
    } else {
      error(da, fmt::format("DataArray \"{}\": unknown format \"{}\"", what, fmt_name));
    }
    if (expected && static_cast<long long>(out.size()) != *expected)
      error(da, fmt::format("DataArray \"{}\" has {} values, expected {}", what, out.size(), *expected));
    return out;
  }

  template <class T>
  std::vector<T> ascii_values(std::string_view body, std::size_t body_offset, const char* what) {
    std::vector<T> out;
    for (std::size_t i = 0; i < body.size();) {
      while (i < body.size() && std::isspace(static_cast<unsigned char>(body[i]))) ++i;
      const std::size_t b = i;
      while (i < body.size() && !std::isspace(static_cast<unsigned char>(body[i]))) ++i;
      if (i == b) break;
      const std::string_view tok = body.substr(b, i - b);
      T v{};
      bool ok;
      if constexpr (std::is_floating_point_v<T>) ok = parse_double(tok, v);
      else ok = parse_int(tok, v);
      if (!ok)
        fail(fmt::format("{}:{}: DataArray \"{}\": '{}' is not a number", src_,
                         line_of(text_, body_offset + b), what, tok.substr(0, 40)));
      if constexpr (std::is_floating_point_v<T>)
        if (!std::isfinite(v))
          fail(fmt::format("{}:{}: point {} has a non-finite coordinate ({})", src_,
                           line_of(text_, body_offset + b), out.size() / 3, tok));
      out.push_back(v);
    }
    return out;
  }

  std::vector<unsigned char> base64(const XmlNode& da, std::string_view s, const char* what) const {
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
      else error(da, fmt::format("DataArray \"{}\": invalid base64 character '{}'", what, ch));
      if (pad && ch != '=') error(da, fmt::format("DataArray \"{}\": misplaced base64 padding", what));
      quad[n++] = static_cast<unsigned>(v);
      if (n == 4) {  // padding may end a group mid-stream: VTK encodes header and data apart
        const unsigned w = quad[0] << 18 | quad[1] << 12 | quad[2] << 6 | quad[3];
        const unsigned char bytes[3] = {static_cast<unsigned char>(w >> 16),
                                        static_cast<unsigned char>(w >> 8), static_cast<unsigned char>(w)};
        out.insert(out.end(), bytes, bytes + 3 - pad);
        n = pad = 0;
      }
    }
    if (n != 0) error(da, fmt::format("DataArray \"{}\": base64 data is cut short", what));
    return out;
  }

  std::uint64_t header_word(const std::vector<unsigned char>& bytes, std::size_t i) const {
    return header_bytes_ == 8 ? load<std::uint64_t>(&bytes[8 * i], swap_)
                              : load<std::uint32_t>(&bytes[4 * i], swap_);
  }

  // Decoded (and decompressed) payload bytes of a binary DataArray.
  std::vector<unsigned char> payload(const XmlNode& da, std::string_view body, const char* what) const {
    const auto bytes = base64(da, body, what);
    const std::size_t hw = header_bytes_;
    auto cut = [&] { error(da, fmt::format("DataArray \"{}\": binary data is cut short", what)); };
    if (!zlib_) {
      if (bytes.size() < hw) cut();
      const std::uint64_t n = header_word(bytes, 0);
      if (n > bytes.size() - hw) cut();
      return {bytes.begin() + static_cast<std::ptrdiff_t>(hw), bytes.begin() + static_cast<std::ptrdiff_t>(hw + n)};
    }
    if (bytes.size() < 3 * hw) cut();
    const std::uint64_t blocks = header_word(bytes, 0), block = header_word(bytes, 1),
                        last = header_word(bytes, 2);
    if (blocks > bytes.size() / hw || bytes.size() < (3 + blocks) * hw) cut();
    if (block > (1u << 30) || last > block) error(da, fmt::format("DataArray \"{}\": bad compression header", what));
    std::vector<unsigned char> out;
    std::size_t src = (3 + blocks) * hw;
    for (std::uint64_t b = 0; b < blocks; ++b) {
      const std::uint64_t csize = header_word(bytes, 3 + b);
      const std::uint64_t usize = (b + 1 == blocks && last != 0) ? last : block;
      if (csize > bytes.size() - src) cut();
      if (usize > 1100 * csize + 64)  // beyond zlib's best ratio (~1032:1): a corrupt header
        error(da, fmt::format("DataArray \"{}\": bad compression header (block {})", what, b));
      const std::size_t at = out.size();
      out.resize(at + usize);
      uLongf got = static_cast<uLongf>(usize);
      if (uncompress(out.data() + at, &got, &bytes[src], static_cast<uLong>(csize)) != Z_OK || got != usize)
        error(da, fmt::format("DataArray \"{}\": corrupt zlib data (block {})", what, b));
      src += csize;
    }
    return out;
  }

  template <class T>
  std::vector<T> binary_values(const XmlNode& da, std::string_view body, const std::string& type,
                               const char* what) {
    const auto bytes = payload(da, body, what);
    std::vector<T> out;
    auto convert = [&]<class S>(S) {
      if (bytes.size() % sizeof(S) != 0)
        error(da, fmt::format("DataArray \"{}\": {} bytes is not a whole number of {}", what, bytes.size(), type));
      out.reserve(bytes.size() / sizeof(S));
      for (std::size_t i = 0; i < bytes.size(); i += sizeof(S)) {
        const S s = load<S>(&bytes[i], swap_);
        if constexpr (std::is_same_v<S, std::uint64_t> && !std::is_floating_point_v<T>)
          if (s > static_cast<std::uint64_t>(std::numeric_limits<long long>::max()))
            error(da, fmt::format("DataArray \"{}\": value {} too large", what, s));
        const T v = static_cast<T>(s);
        if constexpr (std::is_floating_point_v<T>)
          if (!std::isfinite(v))
            error(da, fmt::format("point {} has a non-finite coordinate ({})", out.size() / 3, v));
        out.push_back(v);
      }
    };
    if (type == "Int8") convert(std::int8_t{});
    else if (type == "UInt8") convert(std::uint8_t{});
    else if (type == "Int16") convert(std::int16_t{});
    else if (type == "UInt16") convert(std::uint16_t{});
    else if (type == "Int32") convert(std::int32_t{});
    else if (type == "UInt32") convert(std::uint32_t{});
    else if (type == "Int64") convert(std::int64_t{});
    else if (type == "UInt64") convert(std::uint64_t{});
    else if (type == "Float32") convert(float{});
    else if (type == "Float64") convert(double{});
    else error(da, fmt::format("DataArray \"{}\": unknown type \"{}\"", what, type));
    return out;
  }

  std::string src_;
  std::string_view text_;
  MeshLoadReport& report_;
  VtuData* data_ = nullptr;  // the data arrays too, when asked
  bool swap_ = false, zlib_ = false;
  std::size_t header_bytes_ = 4;
  TetMesh mesh_;
  long long cell_base_ = 0;           // cells of earlier pieces
  std::vector<long long> tet_cell_;   // cell index (over all pieces) of each kept tet
};

}  // namespace

TetMesh read_vtu(const std::filesystem::path& path, MeshLoadReport& report) { return read_vtu(path, report, nullptr); }

TetMesh read_vtu(const std::filesystem::path& path, MeshLoadReport& report, VtuData* data) {
  report = {};
  if (data) *data = {};
  const std::string text = meshio::read_file(path);
  return VtuReader(path.string(), text, report, data).read();
}

}  // namespace pliant
