// Gmsh .msh reader, ASCII only: v1 ($NOD/$ELM, as in SOFA's liver.msh), v2.x ($MeshFormat
// 2.2 0 8, $Nodes/$Elements) and v4.1 (entity blocks). Why: most tetrahedral meshes found in
// the wild (SOFA's data among them) are Gmsh files. Node ids may be non-contiguous and start
// anywhere, so they are mapped to indices. Tets (type 4; type 11, the 10-node tet, by its 4
// corners) are kept; every other element is skipped and counted. Coordinates are taken as m.
// Parsing is line-based, which is how Gmsh writes these files; every error names file:line.
#include <array>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "mesh_reader_util.hpp"
#include "pliant/mesh_io.hpp"

namespace pliant {
namespace {

using namespace meshio;

// A line shortened and made printable, for messages.
std::string shown(std::string_view s) {
  std::string out(s.substr(0, 40));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  return s.size() > 40 ? out + "..." : out;
}

class GmshReader {
 public:
  GmshReader(std::string source, std::string_view text, MeshLoadReport& report)
      : src_(std::move(source)), cur_(text), report_(report), text_size_(text.size()) {}

  TetMesh read() {
    std::string_view line;
    while (next_content(line)) {
      if (line.front() != '$')
        error(fmt::format("expected a section ($MeshFormat, $Nodes, $Elements...), found '{}'",
                          shown(line)));
      if (iequals(line, "$MeshFormat")) {
        read_format();
      } else if (iequals(line, "$NOD")) {
        version_ = 1;
        read_nodes_v12("$ENDNOD");
      } else if (iequals(line, "$ELM")) {
        read_elements_v12(1, "$ENDELM");
      } else if (iequals(line, "$Nodes")) {
        if (version_ == 0) error("$Nodes before $MeshFormat");
        version_ == 4 ? read_nodes_v4() : read_nodes_v12("$EndNodes");
      } else if (iequals(line, "$Elements")) {
        if (version_ == 0) error("$Elements before $MeshFormat");
        version_ == 4 ? read_elements_v4() : read_elements_v12(2, "$EndElements");
      } else {
        skip_section(line);  // $Entities, $PhysicalNames, $NodeData, ...
      }
    }
    if (!have_nodes_) fail(fmt::format("{}: no node section ($Nodes or $NOD)", src_));
    if (!have_elements_) fail(fmt::format("{}: no element section ($Elements or $ELM)", src_));
    finalize_tet_mesh_named(mesh_, src_, report_, [this](std::size_t i) {
      return fmt::format(":{}: element {}", origins_[i].line, origins_[i].id);
    });
    return std::move(mesh_);
  }

 private:
  struct Origin {
    std::size_t line;
    long long id;
  };

  [[noreturn]] void error(const std::string& msg) const {
    fail(fmt::format("{}:{}: {}", src_, cur_.number(), msg));
  }

  // Next non-blank line, trimmed; false at the end of the file.
  bool next_content(std::string_view& out) {
    while (cur_.next()) {
      out = trim(cur_.line());
      if (!out.empty()) return true;
    }
    return false;
  }

  // Next line inside a section that should still hold data; `what` says what was expected.
  std::string_view data_line(const std::string& what) {
    std::string_view line;
    if (!next_content(line)) error("unexpected end of file: " + what);
    if (line.front() == '$') error(fmt::format("found '{}' but expected {}", shown(line), what));
    return line;
  }

  long long to_int(std::string_view tok, const char* what) const {
    long long v = 0;
    if (!parse_int(tok, v)) error(fmt::format("expected an integer ({}), found '{}'", what, shown(tok)));
    return v;
  }

  double to_double(std::string_view tok) const {
    double v = 0;
    if (!parse_double(tok, v)) error(fmt::format("expected a coordinate, found '{}'", shown(tok)));
    return v;
  }

  void expect_end(const char* marker, const std::string& context) {
    std::string_view line;
    if (!next_content(line)) error(fmt::format("unexpected end of file: missing {}", marker));
    if (!iequals(line, marker))
      error(fmt::format("expected {} ({}), found '{}'", marker, context, shown(line)));
  }

  void skip_section(std::string_view opener) {
    const std::string end = "$End" + std::string(opener.substr(1));
    const std::size_t start = cur_.number();
    std::string_view line;
    while (next_content(line))
      if (iequals(line, end)) return;
    fail(fmt::format("{}:{}: section {} (line {}) is not closed by {}", src_, cur_.number(),
                     shown(opener), start, end));
  }

  void read_format() {
    const auto tok = split(data_line("'version file-type data-size'"));
    if (tok.size() < 3) error("expected 'version file-type data-size'");
    double v = 0;
    if (!parse_double(tok[0], v)) error(fmt::format("bad version '{}'", shown(tok[0])));
    if (tok[1] != "0") error("binary .msh not supported, re-save as ASCII");
    if (v >= 2 && v < 4) version_ = 2;
    else if (v >= 4.1 && v < 5) version_ = 4;
    else error(fmt::format("Gmsh format {} is not supported (use 2.2 or 4.1, ASCII)", tok[0]));
    expect_end("$EndMeshFormat", "after the version line");
  }

  void add_node(long long id, double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      error(fmt::format("node {} has a non-finite coordinate ({}, {}, {})", id, x, y, z));
    const auto index = static_cast<std::int32_t>(mesh_.points.size() / 3);
    if (!node_index_.emplace(id, index).second) error(fmt::format("node {} is defined twice", id));
    mesh_.points.insert(mesh_.points.end(), {x, y, z});
  }

  // Keeps tets, counts the rest. `nodes` are the element's node ids as written.
  void add_element(long long id, long long type, const std::vector<std::string_view>& tok,
                   std::size_t first_node) {
    const std::size_t count = tok.size() - first_node;
    if (type != 4 && type != 11) {
      ++report_.skipped_cells;
      return;
    }
    const std::size_t expected = type == 4 ? 4 : 10;
    if (count != expected)
      error(fmt::format("element {} is a tetrahedron (type {}) with {} nodes, expected {}", id,
                        type, count, expected));
    Tet tet{};
    for (int k = 0; k < 4; ++k) {
      const long long node = to_int(tok[first_node + k], "node id");
      const auto it = node_index_.find(node);
      if (it == node_index_.end())
        error(fmt::format("element {} refers to node {}, which is not defined", id, node));
      tet[k] = it->second;
    }
    mesh_.tets.push_back(tet);
    origins_.push_back({cur_.number(), id});
  }

  long long read_count(const char* what) {
    const auto tok = split(data_line(what));
    if (tok.size() != 1) error(fmt::format("expected {}, found {} values", what, tok.size()));
    const long long n = to_int(tok[0], what);
    if (n < 0) error(fmt::format("negative {}", what));
    check_file_count(n, fmt::format("{} {}", what, n));
    return n;
  }

  // Every counted item takes a line of the file or more: a count beyond its size is refused
  // before it is used (check_count).
  void check_file_count(long long n, const std::string& what) const {
    check_count(n, text_size_, 1, fmt::format("{}:{}", src_, cur_.number()), what);
  }

  void read_nodes_v12(const char* end) {
    if (have_nodes_) error("second node section");
    have_nodes_ = true;
    const long long n = read_count("the number of nodes");
    const std::size_t count_line = cur_.number();
    for (long long i = 0; i < n; ++i) {
      const auto tok = split(data_line(fmt::format(
          "node {} (line {} declares {} nodes, only {} present)", i + 1, count_line, n, i)));
      if (tok.size() != 4) error("expected a node line 'id x y z'");
      add_node(to_int(tok[0], "node id"), to_double(tok[1]), to_double(tok[2]), to_double(tok[3]));
    }
    expect_end(end, fmt::format("line {} declares {} nodes: too many nodes?", count_line, n));
  }

  void read_elements_v12(int v, const char* end) {
    if (have_elements_) error("second element section");
    have_elements_ = true;
    const long long n = read_count("the number of elements");
    const std::size_t count_line = cur_.number();
    for (long long i = 0; i < n; ++i) {
      const auto tok = split(data_line(fmt::format(
          "element {} (line {} declares {} elements, only {} present)", i + 1, count_line, n, i)));
      const std::size_t head = v == 1 ? 5 : 3;  // v1: id type phys elem n; v2: id type ntags
      if (tok.size() < head) error("element line too short");
      const long long id = to_int(tok[0], "element id");
      const long long type = to_int(tok[1], "element type");
      if (v == 1) {
        const long long nn = to_int(tok[4], "number of nodes");
        if (nn < 0 || static_cast<std::size_t>(nn) != tok.size() - 5)
          error(fmt::format("element {} declares {} nodes but lists {}", id, nn, tok.size() - 5));
        add_element(id, type, tok, 5);
      } else {
        const long long tags = to_int(tok[2], "number of tags");
        if (tags < 0 || static_cast<std::size_t>(tags) > tok.size() - 3)
          error(fmt::format("element {}: bad number of tags {}", id, tags));
        add_element(id, type, tok, 3 + static_cast<std::size_t>(tags));
      }
    }
    expect_end(end, fmt::format("line {} declares {} elements: too many elements?", count_line, n));
  }

  // A v4 block header: exactly four integers.
  std::array<long long, 4> four_ints(const char* what) {
    const auto tok = split(data_line(what));
    if (tok.size() != 4) error(fmt::format("expected {} (4 integers)", what));
    std::array<long long, 4> out{};
    for (int i = 0; i < 4; ++i) out[i] = to_int(tok[i], what);
    return out;
  }

  void read_nodes_v4() {
    if (have_nodes_) error("second $Nodes section");
    have_nodes_ = true;
    const auto head = four_ints("'numEntityBlocks numNodes minNodeTag maxNodeTag'");
    check_file_count(head[0], fmt::format("numEntityBlocks {}", head[0]));
    check_file_count(head[1], fmt::format("numNodes {}", head[1]));
    const std::size_t head_line = cur_.number();
    long long total = 0;
    for (long long b = 0; b < head[0]; ++b) {
      const auto block = four_ints("a node block header 'entityDim entityTag parametric numNodes'");
      const long long n = block[3];
      if (n < 0) error("negative node count");
      check_file_count(n, fmt::format("numNodes {} of the block", n));
      std::vector<long long> tags;
      while (static_cast<long long>(tags.size()) < n) {  // tags: one per line, or several
        for (auto t : split(data_line(fmt::format("{} node tags", n)))) {
          if (static_cast<long long>(tags.size()) == n) error("more node tags than the block declares");
          tags.push_back(to_int(t, "node tag"));
        }
      }
      for (long long i = 0; i < n; ++i) {
        const auto tok = split(data_line(fmt::format("coordinates of node {}", tags[i])));
        if (tok.size() < 3) error("expected 'x y z'");
        add_node(tags[i], to_double(tok[0]), to_double(tok[1]), to_double(tok[2]));
      }
      total += n;
    }
    if (total != head[1])
      error(fmt::format("the header at line {} declares {} nodes, the blocks hold {}", head_line,
                        head[1], total));
    expect_end("$EndNodes", fmt::format("after the {} blocks declared at line {}", head[0], head_line));
  }

  void read_elements_v4() {
    if (have_elements_) error("second $Elements section");
    have_elements_ = true;
    const auto head = four_ints("'numEntityBlocks numElements minElementTag maxElementTag'");
    check_file_count(head[0], fmt::format("numEntityBlocks {}", head[0]));
    check_file_count(head[1], fmt::format("numElements {}", head[1]));
    const std::size_t head_line = cur_.number();
    long long total = 0;
    for (long long b = 0; b < head[0]; ++b) {
      const auto block = four_ints("an element block header 'entityDim entityTag elementType numElements'");
      if (block[3] < 0) error("negative element count");
      check_file_count(block[3], fmt::format("numElements {} of the block", block[3]));
      const std::size_t block_line = cur_.number();
      for (long long i = 0; i < block[3]; ++i) {
        const auto tok = split(data_line(fmt::format(
            "element {} (line {} declares {} elements, only {} present)", i + 1, block_line, block[3], i)));
        add_element(to_int(tok[0], "element tag"), block[2], tok, 1);
      }
      total += block[3];
    }
    if (total != head[1])
      error(fmt::format("the header at line {} declares {} elements, the blocks hold {}",
                        head_line, head[1], total));
    expect_end("$EndElements", fmt::format("after the {} blocks declared at line {}", head[0], head_line));
  }

  std::string src_;
  LineCursor cur_;
  MeshLoadReport& report_;
  std::size_t text_size_;  // bytes of the file
  TetMesh mesh_;
  std::unordered_map<long long, std::int32_t> node_index_;  // Gmsh node id -> index
  std::vector<Origin> origins_;                             // per kept tet: line, element id
  int version_ = 0;                                         // 1, 2 or 4 once known
  bool have_nodes_ = false, have_elements_ = false;
};

}  // namespace

TetMesh read_gmsh(const std::filesystem::path& path, MeshLoadReport& report) {
  report = {};
  const std::string text = meshio::read_file(path);
  return GmshReader(path.string(), text, report).read();
}

}  // namespace pliant
