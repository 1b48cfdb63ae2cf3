// Surface simplification for the coarser levels of a multiresolution body (thesis ch. 5 §2.1:
// simplify the surface, then tetrahedralise it): CGAL's edge collapse with Garland-Heckbert plane
// quadrics, the fastest of CGAL 5.5's policies on the surfaces measured (debian-stack.md:
// 0.18-0.30 s for 35k triangles, against 0.43-0.56 s for Lindstrom-Turk). A CGAL translation unit
// of its own (about a minute to compile) so that cgal_mesher.cpp need not be rebuilt with it.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <fmt/format.h>

#include <unordered_map>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"

namespace pliant {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
namespace SMS = CGAL::Surface_mesh_simplification;

}  // namespace

TriangleSurface simplify_surface(const TriangleSurface& surface, std::size_t faces, const std::string& what) {
  faces = std::max<std::size_t>(faces, 4);
  if (surface.triangles.size() <= faces) return surface;
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> v;
  v.reserve(surface.point_count());
  for (std::size_t i = 0; i < surface.point_count(); ++i)
    v.push_back(sm.add_vertex(Point(surface.points[3 * i], surface.points[3 * i + 1], surface.points[3 * i + 2])));
  for (const auto& t : surface.triangles)
    if (sm.add_face(v[std::size_t(t[0])], v[std::size_t(t[1])], v[std::size_t(t[2])]) == SurfaceMesh::null_face())
      throw InputError(fmt::format("simplifying {}: the surface is not manifold", what));
  if (!CGAL::is_closed(sm)) throw InputError(fmt::format("simplifying {}: the surface is not closed", what));

  // A closed triangle surface has E = 3F/2 edges: stop at 1.5 x the wanted faces (CGAL 5.5 has no
  // face-count predicate). Garland-Heckbert plane policies: cost and placement from quadrics.
  using GH = SMS::GarlandHeckbert_plane_policies<SurfaceMesh, K>;
  GH gh(sm);
  SMS::Count_stop_predicate<SurfaceMesh> stop(static_cast<std::size_t>(1.5 * double(faces)));
  namespace P = CGAL::parameters;
  SMS::edge_collapse(sm, stop, P::get_cost(gh.get_cost()).get_placement(gh.get_placement()));
  sm.collect_garbage();

  TriangleSurface out;
  std::unordered_map<std::uint32_t, std::int32_t> index;
  for (auto vi : sm.vertices()) {
    index[std::uint32_t(vi)] = static_cast<std::int32_t>(out.point_count());
    const Point& p = sm.point(vi);
    out.points.insert(out.points.end(), {p.x(), p.y(), p.z()});
  }
  for (auto f : sm.faces()) {
    std::array<std::int32_t, 3> t{};
    int k = 0;
    for (auto vi : CGAL::vertices_around_face(sm.halfedge(f), sm)) t[std::size_t(k++)] = index[std::uint32_t(vi)];
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace pliant
