// TetGen .node/.ele reader. Why: TetGen is the common free tetrahedral mesher, and its output
// is this pair of text files. Either name may be given; the other is found next to it.
//   .node: "<#points> <dim=3> <#attributes> <#markers>", then "<id> <x> <y> <z> [attrs] [marker]"
//   .ele:  "<#tets> <nodes per tet: 4|10> <#region attrs>", then "<id> <n1> ... [attr]"
// '#' starts a comment; blank lines are ignored; ids start at 0 or 1 (they are mapped, so any
// numbering works); attribute and marker columns are ignored; 10-node tets keep 4 corners.
// Coordinates are taken as m.
#include <algorithm>
#include <cctype>
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

// Tokens of the next line holding data (comments stripped); false at the end of the file.
bool data_line(LineCursor& cur, std::vector<std::string_view>& tok) {
  while (cur.next()) {
    std::string_view line = cur.line();
    line = line.substr(0, line.find('#'));
    tok = split(line);
    if (!tok.empty()) return true;
  }
  return false;
}

struct Header {
  std::vector<long long> v;
  std::size_t line;
};

Header read_header(const std::string& src, LineCursor& cur, std::size_t min_values) {
  std::vector<std::string_view> tok;
  if (!data_line(cur, tok)) fail(fmt::format("{}: no header line", src));
  Header h{{}, cur.number()};
  for (auto t : tok) {
    long long x = 0;
    if (!parse_int(t, x) || x < 0)
      fail(fmt::format("{}:{}: header: '{}' is not a count", src, cur.number(), t.substr(0, 40)));
    h.v.push_back(x);
  }
  if (h.v.size() < min_values)
    fail(fmt::format("{}:{}: header needs at least {} numbers", src, cur.number(), min_values));
  return h;
}

}  // namespace

TetMesh read_tetgen(const std::filesystem::path& path, MeshLoadReport& report) {
  report = {};
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::filesystem::path node_path = path, ele_path = path;
  if (ext == ".node" || ext == ".ele") {
    node_path.replace_extension(".node");
    ele_path.replace_extension(".ele");
  } else {  // a base name: "mesh" -> mesh.node + mesh.ele
    node_path += ".node";
    ele_path += ".ele";
  }
  const std::string node_src = node_path.string(), ele_src = ele_path.string();
  for (const auto& p : {node_path, ele_path})
    if (std::error_code ec; !std::filesystem::exists(p, ec))
      fail(fmt::format("{}: cannot open file (TetGen needs both {} and {})", p.string(),
                       node_path.filename().string(), ele_path.filename().string()));

  // Points.
  TetMesh mesh;
  std::unordered_map<long long, std::int32_t> index;  // TetGen point id -> index
  {
    const std::string text = read_file(node_path);
    LineCursor cur(text);
    const Header h = read_header(node_src, cur, 2);
    check_count(h.v[0], text.size(), 1, fmt::format("{}:{}", node_src, h.line),
                fmt::format("the number of points {}", h.v[0]));
    if (h.v[1] != 3)
      fail(fmt::format("{}:{}: dimension is {}, expected 3", node_src, h.line, h.v[1]));
    std::vector<std::string_view> tok;
    for (long long i = 0; i < h.v[0]; ++i) {
      if (!data_line(cur, tok))
        fail(fmt::format("{}:{}: unexpected end of file: the header (line {}) declares {} points, "
                         "only {} present", node_src, cur.number(), h.line, h.v[0], i));
      if (tok.size() < 4) fail(fmt::format("{}:{}: expected '<id> <x> <y> <z>'", node_src, cur.number()));
      long long id = 0;
      double x[3];
      if (!parse_int(tok[0], id))
        fail(fmt::format("{}:{}: point id '{}' is not an integer", node_src, cur.number(), tok[0].substr(0, 40)));
      for (int c = 0; c < 3; ++c) {
        if (!parse_double(tok[1 + c], x[c]))
          fail(fmt::format("{}:{}: '{}' is not a number", node_src, cur.number(), tok[1 + c].substr(0, 40)));
        if (!std::isfinite(x[c]))
          fail(fmt::format("{}:{}: point {} has a non-finite coordinate ({})", node_src, cur.number(), id, tok[1 + c]));
      }
      if (!index.emplace(id, static_cast<std::int32_t>(i)).second)
        fail(fmt::format("{}:{}: point {} is defined twice", node_src, cur.number(), id));
      mesh.points.insert(mesh.points.end(), {x[0], x[1], x[2]});
    }
    if (data_line(cur, tok))
      fail(fmt::format("{}:{}: more points than the {} declared at line {}", node_src, cur.number(),
                       h.v[0], h.line));
  }

  // Tetrahedra.
  struct Origin {
    std::size_t line;
    long long id;
  };
  std::vector<Origin> origins;
  {
    const std::string text = read_file(ele_path);
    LineCursor cur(text);
    const Header h = read_header(ele_src, cur, 2);
    check_count(h.v[0], text.size(), 1, fmt::format("{}:{}", ele_src, h.line),
                fmt::format("the number of tetrahedra {}", h.v[0]));
    const long long per = h.v[1];
    if (per != 4 && per != 10)
      fail(fmt::format("{}:{}: {} nodes per tetrahedron, expected 4 or 10", ele_src, h.line, per));
    std::vector<std::string_view> tok;
    for (long long i = 0; i < h.v[0]; ++i) {
      if (!data_line(cur, tok))
        fail(fmt::format("{}:{}: unexpected end of file: the header (line {}) declares {} "
                         "tetrahedra, only {} present", ele_src, cur.number(), h.line, h.v[0], i));
      if (tok.size() < static_cast<std::size_t>(1 + per))
        fail(fmt::format("{}:{}: expected an id and {} node ids", ele_src, cur.number(), per));
      long long id = 0;
      if (!parse_int(tok[0], id))
        fail(fmt::format("{}:{}: tetrahedron id '{}' is not an integer", ele_src, cur.number(), tok[0].substr(0, 40)));
      Tet tet{};
      for (int k = 0; k < 4; ++k) {
        long long n = 0;
        if (!parse_int(tok[1 + k], n))
          fail(fmt::format("{}:{}: node id '{}' is not an integer", ele_src, cur.number(), tok[1 + k].substr(0, 40)));
        const auto it = index.find(n);
        if (it == index.end())
          fail(fmt::format("{}:{}: tetrahedron {} refers to node {}, which is not defined in {}",
                           ele_src, cur.number(), id, n, node_path.filename().string()));
        tet[k] = it->second;
      }
      mesh.tets.push_back(tet);
      origins.push_back({cur.number(), id});
    }
    if (data_line(cur, tok))
      fail(fmt::format("{}:{}: more tetrahedra than the {} declared at line {}", ele_src,
                       cur.number(), h.v[0], h.line));
  }
  finalize_tet_mesh_named(mesh, ele_src, report, [&](std::size_t i) {
    return fmt::format(":{}: tetrahedron {}", origins[i].line, origins[i].id);
  });
  return mesh;
}

}  // namespace pliant
