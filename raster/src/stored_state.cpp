// What a result file stores besides its mesh, for `pliant render FILE.vtu`: the point field
// "displacement" (3 components, m) and the cell field "von_mises" (Pa) that `pliant run` writes
// into every .vtu (engine run_scene.cpp), and the file's simulated time, from a "TimeValue"
// field-data array or from the ParaView .pvd series that lists the file (the run writes
// OUT/series.pvd for OUT/vtu/*.vtu). The arrays come from the engine's VTU reader (read_vtu with
// VtuData); anything it cannot decode leaves the field out with a note, and the picture can still
// be drawn. Only the .pvd lookup is parsed here.

#include <algorithm>
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
#include "pliant/input_file.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/raster/render.hpp"

namespace pliant::raster {
namespace {
namespace fs = std::filesystem;

// The file's text, or "" if it cannot be read (a .pvd that is not a regular file is skipped, not
// waited on: input_file.hpp).
std::string read_text(const fs::path& path) {
  try {
    return read_input_file(path, "file");
  } catch (const InputError&) {
    return {};
  }
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
  // VTK XML only (.vtu, or SOFA's XML misnamed .vtk): the engine's reader gives the arrays too.
  const std::string text = ext == ".vtu" || ext == ".vtk" ? read_text(file) : std::string();
  if (text.find("<VTKFile") != std::string::npos) {
    VtuData data;
    try {
      MeshLoadReport report;
      read_vtu(file, report, &data);
    } catch (const std::exception& e) {
      s.note = fmt::format("{}: its fields cannot be read ({})", file.filename().string(), e.what());
      data = {};
    }
    if (!data.notes.empty() && s.note.empty())
      s.note = fmt::format("{}: {}", file.filename().string(), data.notes.front());
    if (const auto t = data.field.find("TimeValue");
        t != data.field.end() && t->second.values.size() == 1 && std::isfinite(t->second.values[0]))
      s.time = t->second.values[0];
    const auto d = data.point.find("displacement");
    const auto v = data.cell.find("von_mises");
    const bool have_disp = d != data.point.end() && d->second.components == 3;
    const bool have_vm = v != data.cell.end() && v->second.components == 1;
    const bool same = data.points == mesh.node_count() && data.cells == mesh.tet_count();
    if (!same && (have_disp || have_vm)) {
      s.note = fmt::format("{}: its fields do not match the mesh as read ({} points and {} cells in the file, {} nodes and "
                           "{} tets used)",
                           file.filename().string(), data.points, data.cells, mesh.node_count(), mesh.tet_count());
    } else {
      if (have_disp && data.points > 0) s.displacement = std::move(d->second.values);
      if (have_vm && data.cells > 0) s.von_mises = std::move(v->second.values);
    }
  }
  if (!s.time) s.time = series_time(file);
  return s;
}

}  // namespace pliant::raster
