// Legacy VTK reader ("# vtk DataFile Version x.y", ASCII, DATASET UNSTRUCTURED_GRID), the
// format ParaView, meshio and many scripts still write. Reads POINTS (any numeric type, taken
// as m), CELLS (the classic "n i0 i1 ..." layout and the 5.1 OFFSETS/CONNECTIVITY layout) and
// CELL_TYPES; FIELD and METADATA blocks are skipped, POINT_DATA/CELL_DATA end the reading.
// VTK_TETRA (10) cells are kept, VTK_QUADRATIC_TETRA (24) by its 4 corners, others skipped and
// counted. The body is read as a stream of tokens that remember their line, for messages.
#include <cctype>
#include <cmath>
#include <type_traits>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "mesh_reader_util.hpp"
#include "pliant/mesh_io.hpp"

namespace pliant {
namespace {

using namespace meshio;

class VtkReader {
 public:
  VtkReader(std::string source, std::string_view text, MeshLoadReport& report)
      : src_(std::move(source)), text_(text), report_(report) {}

  TetMesh read() {
    read_header();
    bool have_dataset = false;
    std::string_view tok;
    while (next(tok)) {
      const std::size_t at = tok_line_;
      if (iequals(tok, "DATASET")) {
        const std::string_view kind = word("the dataset type");
        if (!iequals(kind, "UNSTRUCTURED_GRID"))
          error(fmt::format("DATASET {} is not supported (expected UNSTRUCTURED_GRID)", kind));
        have_dataset = true;
      } else if (!have_dataset) {
        error(fmt::format("expected 'DATASET UNSTRUCTURED_GRID', found '{}'", tok));
      } else if (iequals(tok, "POINTS")) {
        read_points(at);
      } else if (iequals(tok, "CELLS")) {
        read_cells(at);
      } else if (iequals(tok, "CELL_TYPES")) {
        read_cell_types(at);
      } else if (iequals(tok, "FIELD")) {
        skip_field();
      } else if (iequals(tok, "METADATA")) {
        skip_metadata();
      } else if (iequals(tok, "POINT_DATA") || iequals(tok, "CELL_DATA")) {
        break;  // attributes: not needed
      } else {
        error(fmt::format("unexpected '{}' (expected POINTS, CELLS or CELL_TYPES)", tok));
      }
    }
    if (!have_dataset) fail(fmt::format("{}: no 'DATASET UNSTRUCTURED_GRID'", src_));
    if (points_line_ == 0) fail(fmt::format("{}: no POINTS section", src_));
    if (cells_line_ == 0) fail(fmt::format("{}: no CELLS section", src_));
    if (types_line_ == 0) fail(fmt::format("{}: no CELL_TYPES section", src_));
    if (types_.size() != cell_start_.size() - 1)
      fail(fmt::format("{}:{}: CELL_TYPES has {} entries but CELLS (line {}) has {} cells", src_,
                       types_line_, types_.size(), cells_line_, cell_start_.size() - 1));
    build_tets();
    finalize_tet_mesh_named(mesh_, src_, report_, [this](std::size_t i) {
      return fmt::format(":{}: cell {}", cell_line_[tet_cell_[i]], tet_cell_[i]);
    });
    return std::move(mesh_);
  }

 private:
  [[noreturn]] void error(const std::string& msg) const {
    fail(fmt::format("{}:{}: {}", src_, tok_line_, msg));
  }

  // The three header lines: magic + version, title, ASCII|BINARY. Tokens start after them.
  void read_header() {
    LineCursor lines(text_);
    lines.next();
    const std::string_view magic = trim(lines.line());
    if (!starts_with_nocase(magic, "# vtk DataFile Version"))
      fail(fmt::format("{}:1: not a legacy VTK file (expected '# vtk DataFile Version x.y')", src_));
    if (!lines.next() || !lines.next())
      fail(fmt::format("{}:{}: unexpected end of file in the header", src_, lines.number()));
    const std::string_view format = trim(lines.line());
    if (iequals(format, "BINARY"))
      fail(fmt::format("{}:3: BINARY legacy VTK is not supported, re-save as ASCII", src_));
    if (!iequals(format, "ASCII"))
      fail(fmt::format("{}:3: expected ASCII or BINARY, found '{}'", src_, format.substr(0, 40)));
    pos_ = 0;
    for (int i = 0; i < 3 && pos_ < text_.size(); ++i) {
      const std::size_t eol = text_.find('\n', pos_);
      pos_ = eol == std::string_view::npos ? text_.size() : eol + 1;
    }
    line_ = 4;
  }

  // Next whitespace-separated token; tok_line_ is its line. False at the end of the text.
  bool next(std::string_view& tok) {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_])))
      if (text_[pos_++] == '\n') ++line_;
    tok_line_ = line_;
    if (pos_ >= text_.size()) return false;
    const std::size_t b = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    tok = text_.substr(b, pos_ - b);
    return true;
  }

  std::string_view word(const char* what) {
    std::string_view tok;
    if (!next(tok)) error(fmt::format("unexpected end of file: expected {}", what));
    return tok;
  }

  long long count(const char* what) {
    const std::string_view tok = word(what);
    long long n = 0;
    if (!parse_int(tok, n) || n < 0) error(fmt::format("expected {}, found '{}'", what, tok.substr(0, 40)));
    // Every counted item is at least one token of the (ASCII) file: check before using it.
    check_count(n, text_.size(), 1, fmt::format("{}:{}", src_, tok_line_), fmt::format("{} {}", what, n));
    return n;
  }

  // The i-th of n numbers that `section` (declared at line decl) announced.
  template <class T>
  T value(const char* section, std::size_t decl, long long i, long long n) {
    std::string_view tok;
    if (!next(tok))
      error(fmt::format("unexpected end of file: {} (line {}) needs {} values, found {}", section,
                        decl, n, i));
    T v{};
    bool ok;
    if constexpr (std::is_floating_point_v<T>) ok = parse_double(tok, v);
    else ok = parse_int(tok, v);
    if (!ok)
      error(fmt::format("expected value {} of the {} of {} (line {}), found '{}' (wrong count?)",
                        i + 1, n, section, decl, tok.substr(0, 40)));
    return v;
  }

  void read_points(std::size_t decl) {
    if (points_line_) error("second POINTS section");
    points_line_ = decl;
    const long long n = count("the number of points");
    word("the point data type");
    if (static_cast<double>(n) * 3 > static_cast<double>(text_.size()))  // >= 2 bytes a value
      error(fmt::format("POINTS declares {} points, more than the file can hold", n));
    mesh_.points.resize(3 * static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      for (long long c = 0; c < 3; ++c) {
        const double x = value<double>("POINTS", decl, 3 * i + c, 3 * n);
        if (!std::isfinite(x)) error(fmt::format("point {} has a non-finite coordinate ({})", i, x));
        mesh_.points[3 * i + c] = x;
      }
    }
  }

  void read_cells(std::size_t decl) {
    if (cells_line_) error("second CELLS section");
    cells_line_ = decl;
    const long long a = count("the number of cells");
    const long long b = count("the size of the cell list");
    std::size_t save_pos = pos_, save_line = line_;
    std::string_view tok;
    const bool offsets = next(tok) && iequals(tok, "OFFSETS");  // VTK 5.1 layout
    pos_ = save_pos, line_ = save_line;
    if (offsets) {
      next(tok);
      word("the OFFSETS data type");
      if (a < 1) error("OFFSETS needs at least one value");
      for (long long i = 0; i < a; ++i) {
        const long long o = value<long long>("OFFSETS", decl, i, a);
        if (o < 0 || o > b || (i > 0 && o < static_cast<long long>(cell_start_.back())) || (i == 0 && o != 0))
          error(fmt::format("offset {} ({}) is out of order or out of [0, {}]", i, o, b));
        cell_start_.push_back(static_cast<std::size_t>(o));
      }
      if (cell_start_.back() != static_cast<std::size_t>(b))
        error(fmt::format("the last offset is {}, but the connectivity has {} values",
                          cell_start_.back(), b));
      if (!next(tok) || !iequals(tok, "CONNECTIVITY")) error("expected CONNECTIVITY after the offsets");
      word("the CONNECTIVITY data type");
      std::vector<std::size_t> conn_line;  // line of each connectivity value
      for (long long j = 0; j < b; ++j) {
        conn_.push_back(value<long long>("CONNECTIVITY", decl, j, b));
        conn_line.push_back(tok_line_);
      }
      for (std::size_t c = 0; c + 1 < cell_start_.size(); ++c)
        cell_line_.push_back(cell_start_[c] < conn_line.size() ? conn_line[cell_start_[c]] : decl);
    } else {
      cell_start_.push_back(0);
      for (long long i = 0; i < a; ++i) {
        const long long k = value<long long>("CELLS", decl, static_cast<long long>(conn_.size() + i), b);
        cell_line_.push_back(tok_line_);
        if (k < 0) error(fmt::format("cell {} has a negative size", i));
        for (long long j = 0; j < k; ++j)
          conn_.push_back(value<long long>("CELLS", decl, static_cast<long long>(conn_.size() + i + 1), b));
        cell_start_.push_back(conn_.size());
      }
      if (static_cast<long long>(conn_.size()) + a != b)
        error(fmt::format("CELLS (line {}) declares a list of {} values, the {} cells hold {}", decl,
                          b, a, conn_.size() + a));
    }
  }

  void read_cell_types(std::size_t decl) {
    if (types_line_) error("second CELL_TYPES section");
    types_line_ = decl;
    const long long n = count("the number of cell types");
    for (long long i = 0; i < n; ++i) types_.push_back(value<long long>("CELL_TYPES", decl, i, n));
  }

  void skip_field() {
    word("the field name");
    const long long arrays = count("the number of field arrays");
    for (long long a = 0; a < arrays; ++a) {
      word("the array name");
      const long long comps = count("the number of components");
      const long long tuples = count("the number of tuples");
      if (comps > 0 && tuples > count_limit(text_.size(), 1) / comps)  // the product overflowed to 0 values
        error(fmt::format("a FIELD array of {} components x {} tuples is more than the file ({} bytes) can hold",
                          comps, tuples, text_.size()));
      word("the array data type");
      std::string_view tok;
      for (long long i = 0; i < comps * tuples; ++i)
        if (!next(tok)) error("unexpected end of file in a FIELD array");
    }
  }

  // METADATA holds INFORMATION/NAME/DATA lines with no count: skip up to the next section.
  void skip_metadata() {
    for (;;) {
      const std::size_t save_pos = pos_, save_line = line_;
      std::string_view tok;
      if (!next(tok)) return;
      for (const char* k : {"POINTS", "CELLS", "CELL_TYPES", "POINT_DATA", "CELL_DATA", "FIELD"})
        if (iequals(tok, k)) {
          pos_ = save_pos, line_ = save_line;
          return;
        }
    }
  }

  void build_tets() {
    const long long npts = static_cast<long long>(mesh_.node_count());
    for (std::size_t c = 0; c + 1 < cell_start_.size(); ++c) {
      const std::size_t b = cell_start_[c], size = cell_start_[c + 1] - b;
      if (types_[c] != 10 && types_[c] != 24) {
        ++report_.skipped_cells;
        continue;
      }
      tok_line_ = cell_line_[c];
      const std::size_t expected = types_[c] == 10 ? 4 : 10;
      if (size != expected)
        error(fmt::format("cell {} has type {} (tetrahedron) but {} points, expected {}", c,
                          types_[c], size, expected));
      Tet tet{};
      for (int k = 0; k < 4; ++k) {
        const long long p = conn_[b + k];
        if (p < 0 || p >= npts)
          error(fmt::format("cell {} refers to point {}, which is not defined ({} points)", c, p, npts));
        tet[k] = static_cast<std::int32_t>(p);
      }
      mesh_.tets.push_back(tet);
      tet_cell_.push_back(c);
    }
  }

  std::string src_;
  std::string_view text_;
  MeshLoadReport& report_;
  std::size_t pos_ = 0, line_ = 1, tok_line_ = 1;
  std::size_t points_line_ = 0, cells_line_ = 0, types_line_ = 0;  // 0: section not seen
  TetMesh mesh_;
  std::vector<long long> conn_, types_;
  std::vector<std::size_t> cell_start_;  // cell c is conn_[cell_start_[c], cell_start_[c+1])
  std::vector<std::size_t> cell_line_;   // line where cell c starts
  std::vector<std::size_t> tet_cell_;    // cell index of each kept tet
};

}  // namespace

TetMesh read_vtk_legacy(const std::filesystem::path& path, MeshLoadReport& report) {
  report = {};
  const std::string text = meshio::read_file(path);
  return VtkReader(path.string(), text, report).read();
}

}  // namespace pliant
