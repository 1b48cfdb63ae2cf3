// The levels of a multiresolution body and their links at rest (pliant/hierarchy.hpp).
#include "pliant/hierarchy.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"
#include "pliant/world.hpp"
#include "tet_locator.hpp"

namespace pliant {
namespace {

// Mesh_3 gives about 4.3 V / s^3 tets for cell size s (cgal_mesher.cpp): the cell size a mesh of
// n tets and volume V corresponds to, whatever made it.
double equivalent_cell_size(const TetMesh& m) {
  double volume = 0;
  for (const Tet& t : m.tets) volume += signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
  return std::cbrt(4.3 * volume / double(std::max<std::size_t>(m.tet_count(), 1)));
}

double surface_area(const TriangleSurface& s) {
  double a = 0;
  for (const auto& t : s.triangles) {
    const double* p = &s.points[3 * std::size_t(t[0])];
    const double* q = &s.points[3 * std::size_t(t[1])];
    const double* r = &s.points[3 * std::size_t(t[2])];
    const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, v[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    a += 0.5 * std::hypot(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]);
  }
  return a;
}

double mesh_volume(const TetMesh& m) {
  double v = 0;
  for (const Tet& t : m.tets) v += signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3]));
  return v;
}

// Edge collapse cuts off the convex parts of a surface and Mesh_3's facets are chords of it: a
// coarse level comes out smaller than the body (the organ: 9% less volume at level 1, 27% at level
// 0), so it would be lighter and softer than the body it stands for. Scaled about its centroid to
// the finest mesh's volume, every level has the body's mass.
void match_volume(TetMesh& coarse, const TetMesh& fine) {
  const double vc = mesh_volume(coarse), vf = mesh_volume(fine);
  if (!(vc > 0 && vf > 0)) return;
  const double f = std::cbrt(vf / vc);
  Vec3d c{0, 0, 0};
  for (std::size_t i = 0; i < coarse.node_count(); ++i)
    for (std::size_t k = 0; k < 3; ++k) c[k] += coarse.points[3 * i + k] / double(coarse.node_count());
  for (std::size_t i = 0; i < coarse.node_count(); ++i)
    for (std::size_t k = 0; k < 3; ++k) coarse.points[3 * i + k] = c[k] + f * (coarse.points[3 * i + k] - c[k]);
}

TetMesh coarse_box(const MeshSourceDef& fine, double ratio, int k) {
  MeshSourceDef src = fine;
  const double f = std::pow(ratio, k);
  for (int c = 0; c < 3; ++c) src.cells[std::size_t(c)] = std::max(1, int(std::ceil(double(fine.cells[std::size_t(c)]) / f - 1e-9)));
  return build_mesh(src);
}

}  // namespace

std::vector<TetMesh> build_level_meshes(const BodyDef& def, TetMesh finest) {
  const MultiresolutionDef& mr = def.multiresolution;
  const int n = mr.levels;
  if (n < 1) throw InputError(fmt::format("body '{}': multiresolution.levels must be >= 1, got {}", def.name, n));
  if (!mr.coarser.empty() && int(mr.coarser.size()) + 1 != n)
    throw InputError(fmt::format("body '{}': multiresolution lists {} coarser meshes for {} levels", def.name,
                                 mr.coarser.size(), n));
  if (!(mr.ratio > 1) || !std::isfinite(mr.ratio))
    throw InputError(fmt::format("body '{}': multiresolution.ratio must be > 1, got {}", def.name, mr.ratio));
  std::vector<TetMesh> meshes(static_cast<std::size_t>(n));
  meshes[std::size_t(n - 1)] = std::move(finest);
  if (n == 1) return meshes;
  if (!mr.coarser.empty()) {
    for (int l = 0; l < n - 1; ++l) meshes[std::size_t(l)] = build_mesh(mr.coarser[std::size_t(l)]);
    return meshes;
  }
  if (def.mesh.kind == MeshSourceDef::Kind::box) {
    for (int l = 0; l < n - 1; ++l) meshes[std::size_t(l)] = coarse_box(def.mesh, mr.ratio, n - 1 - l);
    return meshes;
  }
  // Surface pipeline (thesis Fig. 5.1): simplify the boundary level by level, mesh each surface.
  if (!mr.faces.empty() && int(mr.faces.size()) + 1 != n)
    throw InputError(fmt::format("body '{}': multiresolution.faces gives {} counts for {} coarser levels", def.name,
                                 mr.faces.size(), n - 1));
  const TetMesh& fine = meshes[std::size_t(n - 1)];
  const double h = equivalent_cell_size(fine);
  TriangleSurface surface = boundary_surface(fine);
  for (int l = n - 2; l >= 0; --l) {
    const int k = n - 1 - l;
    const std::string what = fmt::format("body '{}', level {} of {}", def.name, l, n);
    const double faces = mr.faces.empty() ? double(surface.triangles.size()) / (mr.ratio * mr.ratio)
                                          : double(mr.faces[std::size_t(l)]);
    surface = simplify_surface(surface, std::size_t(std::max(4.0, std::round(faces))), what);
    // Ratio: ratio^k times the finest cell size. Face counts: the size whose facets, of area
    // sqrt(3)/4 s^2, would tile the simplified surface in that many triangles.
    const double s = mr.faces.empty() ? h * std::pow(mr.ratio, k)
                                      : std::sqrt(surface_area(surface) / (0.433 * double(surface.triangles.size())));
    TetMesh m = mesh_closed_surface(surface, s, what);
    match_volume(m, fine);
    renumber_for_locality(m);
    meshes[std::size_t(l)] = std::move(m);
  }
  return meshes;
}

Hierarchy link_levels(std::vector<TetMesh> meshes) {
  Hierarchy h;
  h.meshes = std::move(meshes);
  const std::size_t n = h.meshes.size();
  h.links.resize(n);
  for (std::size_t l = 0; l < n; ++l)
    if (h.meshes[l].tet_count() == 0) throw InputError(fmt::format("level {} of the hierarchy has no tets", l));
  for (std::size_t l = 0; l + 1 < n; ++l) {
    const TetMesh& coarse = h.meshes[l];
    const TetMesh& fine = h.meshes[l + 1];
    LevelLinks& lc = h.links[l];
    LevelLinks& lf = h.links[l + 1];
    const detail::TetLocator in_coarse(coarse), in_fine(fine);
    const detail::NodeLocator coarse_nodes(coarse);
    lf.to_coarser.resize(fine.node_count());
    lf.parent.resize(fine.node_count());
    for (std::size_t i = 0; i < fine.node_count(); ++i) {
      lf.to_coarser[i] = in_coarse.locate(fine.point(i));
      lf.parent[i] = coarse_nodes.nearest(fine.point(i));
    }
    lc.to_finer.resize(coarse.node_count());
    for (std::size_t i = 0; i < coarse.node_count(); ++i) lc.to_finer[i] = in_fine.locate(coarse.point(i));
    lf.tet_parent.resize(fine.tet_count());
    lf.tet_parent_offsets.assign(1, 0);
    for (std::size_t t = 0; t < fine.tet_count(); ++t) {
      Vec3d c{0, 0, 0};
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) c[std::size_t(k)] += 0.25 * fine.points[3 * std::size_t(fine.tets[t][std::size_t(a)]) + std::size_t(k)];
      lf.tet_parent[t] = in_coarse.locate(c).tet;
      // The coarse tets next to its corners (activation.hpp: an active node gets every tet around
      // it). Points an eighth of the way from each corner to the centroid: strictly inside the tet,
      // so a nested tet finds only its parent, and well within the reach (a quarter of the mean
      // edge) inside which a finer node counts as covered by a coarser tet.
      std::array<std::int32_t, 5> found{lf.tet_parent[t], -1, -1, -1, -1};
      for (int a = 0; a < 4; ++a) {
        Vec3d q = c;
        for (int k = 0; k < 3; ++k) {
          const double corner = fine.points[3 * std::size_t(fine.tets[t][std::size_t(a)]) + std::size_t(k)];
          q[std::size_t(k)] = corner + 0.125 * (c[std::size_t(k)] - corner);
        }
        found[std::size_t(a) + 1] = in_coarse.locate(q).tet;
      }
      lf.tet_corner_parent.push_back({found[1], found[2], found[3], found[4]});
      std::sort(found.begin(), found.end());
      for (std::size_t e = 0; e < found.size(); ++e)
        if (found[e] >= 0 && (e == 0 || found[e] != found[e - 1])) lf.tet_parents.push_back(found[e]);
      lf.tet_parent_offsets.push_back(std::int32_t(lf.tet_parents.size()));
    }
    // Children (CSR, in fine node order) and rings (tets of the fine level around the children).
    lc.child_offsets.assign(coarse.node_count() + 1, 0);
    for (auto p : lf.parent) ++lc.child_offsets[std::size_t(p) + 1];
    for (std::size_t i = 0; i < coarse.node_count(); ++i) lc.child_offsets[i + 1] += lc.child_offsets[i];
    lc.children.resize(fine.node_count());
    {
      std::vector<std::int32_t> cursor(lc.child_offsets.begin(), lc.child_offsets.end() - 1);
      for (std::size_t i = 0; i < fine.node_count(); ++i) lc.children[std::size_t(cursor[std::size_t(lf.parent[i])]++)] = std::int32_t(i);
    }
    std::vector<std::vector<std::int32_t>> ring(coarse.node_count());
    for (std::size_t t = 0; t < fine.tet_count(); ++t)
      for (int a = 0; a < 4; ++a) {
        auto& r = ring[std::size_t(lf.parent[std::size_t(fine.tets[t][std::size_t(a)])])];
        if (r.empty() || r.back() != std::int32_t(t)) r.push_back(std::int32_t(t));
      }
    lc.ring_offsets.assign(coarse.node_count() + 1, 0);
    for (std::size_t i = 0; i < coarse.node_count(); ++i) {
      lc.ring_offsets[i + 1] = lc.ring_offsets[i] + std::int32_t(ring[i].size());
      lc.ring.insert(lc.ring.end(), ring[i].begin(), ring[i].end());
    }
  }
  return h;
}

}  // namespace pliant
