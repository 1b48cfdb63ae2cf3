// Validation and normalisation of tetrahedral meshes, shared by every mesh source (files,
// generators, meshers): a TetMesh that leaves finalize_tet_mesh has finite coordinates,
// in-range indices, positively oriented non-degenerate tets and no unused vertex, so that
// the rest of the engine never has to check again. Lengths in m, volumes in m^3.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include "mesh_reader_util.hpp"
#include "pliant/error.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant {

double signed_tet_volume(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  const double wx = d[0] - a[0], wy = d[1] - a[1], wz = d[2] - a[2];
  const double det = ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx);
  return det / 6.0;
}

namespace meshio {

void finalize_tet_mesh_named(TetMesh& mesh, const std::string& source, MeshLoadReport& report,
                             const std::function<std::string(std::size_t)>& where) {
  if (mesh.points.size() % 3 != 0)
    fail(fmt::format("{}: {} coordinates is not a multiple of 3", source, mesh.points.size()));
  const std::size_t n = mesh.node_count();
  if (n == 0) fail(fmt::format("{}: the mesh has no nodes", source));
  if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    fail(fmt::format("{}: too many nodes ({})", source, n));
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d p = mesh.point(i);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      fail(fmt::format("{}: node {} has a non-finite coordinate ({}, {}, {})", source, i, p[0],
                       p[1], p[2]));
  }
  if (mesh.tets.empty())
    fail(fmt::format("{}: the mesh has no tetrahedra ({} other cells skipped)", source,
                     report.skipped_cells));

  // Indices in range and four distinct corners.
  std::vector<char> used(n, 0);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& tet = mesh.tets[t];
    for (int k = 0; k < 4; ++k) {
      if (tet[k] < 0 || static_cast<std::size_t>(tet[k]) >= n)
        fail(fmt::format("{}{}: refers to node {}, which is not defined (the mesh has {} nodes)",
                         source, where(t), tet[k], n));
      for (int j = 0; j < k; ++j)
        if (tet[j] == tet[k])
          fail(fmt::format("{}{}: degenerate tetrahedron (node {} appears twice)", source,
                           where(t), tet[k]));
      used[tet[k]] = 1;
    }
  }
  // Degenerate tets are errors; inverted ones are turned over by swapping two corners. A tet is
  // degenerate when |V| <= 1e-12 L^3, L its longest edge: flat to within 1e-12 of its own size
  // (a regular tet has V = 0.118 L^3; the rounding of the volume is about 1e-16 L^3). Its own
  // size, not the mesh's: a threshold from the bounding box refused a valid 10 m x 1 mm x 1 mm bar
  // and let one far-away node make healthy small tets "degenerate".
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    Tet& tet = mesh.tets[t];
    const Vec3d p[4] = {mesh.point(tet[0]), mesh.point(tet[1]), mesh.point(tet[2]), mesh.point(tet[3])};
    double longest2 = 0;  // m^2
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const double dx = p[b][0] - p[a][0], dy = p[b][1] - p[a][1], dz = p[b][2] - p[a][2];
        longest2 = std::max(longest2, dx * dx + dy * dy + dz * dz);
      }
    const double tolerance = 1e-12 * longest2 * std::sqrt(longest2);  // m^3
    const double v = signed_tet_volume(p[0], p[1], p[2], p[3]);
    if (!(std::abs(v) > tolerance))
      fail(fmt::format("{}{}: degenerate tetrahedron (volume {:g})", source, where(t),
                       v == 0.0 ? 0.0 : v));
    if (v < 0) {
      std::swap(tet[2], tet[3]);
      ++report.reoriented_tets;
    }
  }

  // Drop unused vertices, keeping the order of the others.
  const auto kept = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
  if (kept == n) return;
  std::vector<std::int32_t> remap(n, -1);
  std::vector<double> points;
  points.reserve(3 * kept);
  for (std::size_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    remap[i] = static_cast<std::int32_t>(points.size() / 3);
    points.insert(points.end(), mesh.points.begin() + 3 * i, mesh.points.begin() + 3 * i + 3);
  }
  for (Tet& tet : mesh.tets)
    for (auto& v : tet) v = remap[v];
  mesh.points = std::move(points);
  report.dropped_vertices += n - kept;
  report.vertex_map = std::move(remap);
}

}  // namespace meshio

void finalize_tet_mesh(TetMesh& mesh, const std::string& source, MeshLoadReport& report) {
  meshio::finalize_tet_mesh_named(mesh, source, report,
                                  [](std::size_t i) { return fmt::format(": cell {}", i); });
}

// Rejects a scale that is not finite and positive (a negative one would turn every tet inside
// out) and a non-finite translation (m).
void transform_mesh(TetMesh& mesh, double scale, const Vec3d& translate) {
  if (!std::isfinite(scale) || !(scale > 0))
    throw InputError(fmt::format("mesh scale must be finite and positive, got {}", scale));
  for (double t : translate)
    if (!std::isfinite(t))
      throw InputError(fmt::format("mesh.translate must be 3 finite numbers (m), got [{}, {}, {}]", translate[0],
                                   translate[1], translate[2]));
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    mesh.points[i] = mesh.points[i] * scale + translate[i % 3];
}

}  // namespace pliant
