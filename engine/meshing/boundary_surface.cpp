// The boundary of a tet mesh as a triangle surface of its own: the start of a coarser level's
// pipeline (simplify, then mesh) when the body comes from a volume file or an implicit shape.
#include <unordered_map>

#include "pliant/mesh_quality.hpp"
#include "pliant/meshing.hpp"

namespace pliant {

TriangleSurface boundary_surface(const TetMesh& mesh) {
  TriangleSurface s;
  std::unordered_map<std::int32_t, std::int32_t> index;  // mesh node -> surface point
  for (const auto& tri : boundary_triangles(mesh.tets)) {
    std::array<std::int32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      auto [it, added] = index.try_emplace(tri[std::size_t(k)], static_cast<std::int32_t>(s.point_count()));
      if (added) {
        const Vec3d p = mesh.point(std::size_t(tri[std::size_t(k)]));
        s.points.insert(s.points.end(), p.begin(), p.end());
      }
      t[std::size_t(k)] = it->second;
    }
    s.triangles.push_back(t);
  }
  return s;
}

}  // namespace pliant
