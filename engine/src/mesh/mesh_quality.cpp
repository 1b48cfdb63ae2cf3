// Geometric measures of a tetrahedral mesh (`pliant info`, stable time step) and its boundary
// surface. Lengths in m, areas in m^2, volumes in m^3, angles in degrees.
#include "pliant/mesh_quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pliant {
namespace {

// Local face f is the face opposite corner f, ordered so that (b-a)x(c-a) points away from
// corner f when the tet is positively oriented (det[p1-p0, p2-p0, p3-p0] > 0).
constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
// The 6 edges (i, j) and the two corners (k, l) not on them: the edge's dihedral angle is
// between faces k and l.
constexpr int kEdge[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                             {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};

Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3d& a) { return std::sqrt(dot(a, a)); }

}  // namespace

std::vector<std::array<std::int32_t, 3>> boundary_triangles(const std::vector<Tet>& tets) {
  // One key per (tet, local face): sorted corners, then the face id 4*tet+f. Sorting groups
  // the copies of each face; a face seen once is on the boundary.
  struct Key {
    std::array<std::int32_t, 3> v;
    std::uint64_t id;
  };
  std::vector<Key> keys;
  keys.reserve(4 * tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<std::int32_t, 3> v{tets[t][kFace[f][0]], tets[t][kFace[f][1]], tets[t][kFace[f][2]]};
      std::sort(v.begin(), v.end());
      keys.push_back({v, 4 * static_cast<std::uint64_t>(t) + static_cast<std::uint64_t>(f)});
    }
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
    return a.v != b.v ? a.v < b.v : a.id < b.id;
  });
  std::vector<std::uint64_t> single;
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i + 1;
    while (j < keys.size() && keys[j].v == keys[i].v) ++j;
    if (j - i == 1) single.push_back(keys[i].id);
    i = j;
  }
  std::sort(single.begin(), single.end());  // by tet, then local face
  std::vector<std::array<std::int32_t, 3>> out;
  out.reserve(single.size());
  for (std::uint64_t id : single) {
    const Tet& t = tets[id / 4];
    const int* f = kFace[id % 4];
    out.push_back({t[f[0]], t[f[1]], t[f[2]]});
  }
  return out;
}

MeshQuality compute_mesh_quality(const TetMesh& mesh) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kDeg = 180.0 / std::numbers::pi;
  MeshQuality q;
  q.nodes = mesh.node_count();
  q.tets = mesh.tet_count();
  q.boundary_triangles = boundary_triangles(mesh.tets).size();

  if (q.nodes > 0) {
    q.bbox_min = q.bbox_max = mesh.point(0);
    for (std::size_t i = 1; i < q.nodes; ++i) {
      const Vec3d p = mesh.point(i);
      for (int a = 0; a < 3; ++a) {
        q.bbox_min[a] = std::min(q.bbox_min[a], p[a]);
        q.bbox_max[a] = std::max(q.bbox_max[a], p[a]);
      }
    }
  }
  if (q.tets == 0) return q;

  q.min_dihedral_deg = q.min_altitude = q.min_edge = kInf;
  const double regular_scale = std::sqrt(2.0 / 3.0);  // regular tet: altitude = edge*sqrt(2/3)
  for (const Tet& t : mesh.tets) {
    const Vec3d p[4] = {mesh.point(t[0]), mesh.point(t[1]), mesh.point(t[2]), mesh.point(t[3])};
    const double volume = std::abs(dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0])))) / 6;
    q.volume += volume;

    // Face normals (length = 2 * area); outward for a positive tet, all inward otherwise,
    // which leaves the dihedral angles unchanged.
    Vec3d n[4];
    double max_area = 0;
    for (int f = 0; f < 4; ++f) {
      const Vec3d& a = p[kFace[f][0]];
      n[f] = cross(sub(p[kFace[f][1]], a), sub(p[kFace[f][2]], a));
      max_area = std::max(max_area, norm(n[f]) / 2);
    }

    double longest = 0;
    for (const auto& e : kEdge) {
      const double len = norm(sub(p[e[1]], p[e[0]]));
      longest = std::max(longest, len);
      q.min_edge = std::min(q.min_edge, len);
      q.max_edge = std::max(q.max_edge, len);
      // Interior angle between faces k and l = pi - angle between their outward normals.
      const Vec3d& nk = n[e[2]];
      const Vec3d& nl = n[e[3]];
      const double angle = std::atan2(norm(cross(nk, nl)), -dot(nk, nl)) * kDeg;
      q.min_dihedral_deg = std::min(q.min_dihedral_deg, angle);
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
    }

    const double altitude = max_area > 0 ? 3 * volume / max_area : 0;  // smallest altitude
    q.min_altitude = std::min(q.min_altitude, altitude);
    const double aspect = altitude > 0 ? longest / altitude * regular_scale : kInf;
    q.worst_aspect_ratio = std::max(q.worst_aspect_ratio, aspect);
  }
  return q;
}

}  // namespace pliant
