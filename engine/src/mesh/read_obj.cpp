// OBJ surfaces for skins (pliant/skin.hpp): vertices and faces only. No CGAL (the mesher's
// reader lives in engine/meshing/ and is not built without it).
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <string>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/skin.hpp"

namespace pliant {

SkinSurface read_obj_surface(const std::filesystem::path& path) {
  const std::string text = read_input_file(path, "skin surface");
  SkinSurface s;
  std::size_t pos = 0, line_no = 0;
  std::vector<std::int32_t> face;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    auto fail = [&](const std::string& why) {
      throw InputError(fmt::format("{}:{}: {}", path.string(), line_no, why));
    };
    const char* c = line.c_str();
    while (*c == ' ' || *c == '\t') ++c;
    if (c[0] == 'v' && (c[1] == ' ' || c[1] == '\t')) {
      c += 2;
      for (int k = 0; k < 3; ++k) {
        char* stop = nullptr;
        errno = 0;
        const double v = std::strtod(c, &stop);
        if (stop == c || !std::isfinite(v)) fail(fmt::format("vertex coordinate {} is not a finite number", k + 1));
        s.points.push_back(v);
        c = stop;
      }
      if (s.points.size() / 3 > std::size_t(INT32_MAX)) fail("too many vertices");
    } else if (c[0] == 'f' && (c[1] == ' ' || c[1] == '\t')) {
      c += 2;
      face.clear();
      for (;;) {
        while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
        if (*c == '\0') break;
        char* stop = nullptr;
        const long long i = std::strtoll(c, &stop, 10);
        if (stop == c) fail("a face index is not an integer");
        const long long n = static_cast<long long>(s.points.size() / 3);
        const long long index = i > 0 ? i - 1 : n + i;  // 1-based, or negative: counted back from the last vertex
        if (i == 0 || index < 0 || index >= n)
          fail(fmt::format("face index {} is out of range (vertices so far: {})", i, n));
        face.push_back(std::int32_t(index));
        c = stop;
        while (*c && *c != ' ' && *c != '\t' && *c != '\r') ++c;  // skip /vt/vn
      }
      if (face.size() < 3) fail(fmt::format("a face needs at least 3 vertices, got {}", face.size()));
      for (std::size_t k = 1; k + 1 < face.size(); ++k) s.triangles.push_back({face[0], face[k], face[k + 1]});
    }
  }
  if (s.triangles.empty()) throw InputError(fmt::format("{}: no faces (an OBJ skin needs \"f\" lines)", path.string()));
  return s;
}

}  // namespace pliant
