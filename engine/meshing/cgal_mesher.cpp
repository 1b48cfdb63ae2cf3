// Tetrahedralisation with CGAL Mesh_3 (CGAL 5.5). This is the only pliant file that includes
// CGAL: one CGAL translation unit takes about a minute and 4 GB to compile, so everything that
// needs CGAL lives here, behind the plain API of pliant/meshing.hpp. Units: metres.
//
// Reproducibility: make_mesh_3 runs with no_perturb() and no_exude(). CGAL 5.5 stops those two
// optimisers on a wall-clock limit, so with them the mesh would depend on machine load. Both
// domains seed their random generator with 0, so the same input gives the same mesh every run.
//
// Criteria, for cell size s: facet_angle 25 deg, facet_size s, cell_size s,
// cell_radius_edge_ratio 3, facet_distance s/4 (implicit shapes) or s/8 (surface files, whose
// facets are usually coarser than s), edge_size s (sharp features of surface files).
// Mesh_3 gives about 4.3 * volume / s^3 tetrahedra.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"

namespace pliant {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

// Implicit shapes: the domain is {p : f(p) < 0} inside a bounding sphere.
using ImplicitDomain = CGAL::Labeled_mesh_domain_3<K>;
using ImplicitTr = CGAL::Mesh_triangulation_3<ImplicitDomain>::type;
using ImplicitC3t3 = CGAL::Mesh_complex_3_in_triangulation_3<ImplicitTr>;

// Surface files: the inside of a closed triangle surface, its sharp edges (>= 60 deg) protected.
using SurfaceDomain = CGAL::Polyhedral_mesh_domain_with_features_3<K, SurfaceMesh>;
using SurfaceTr = CGAL::Mesh_triangulation_3<SurfaceDomain>::type;
using SurfaceC3t3 = CGAL::Mesh_complex_3_in_triangulation_3<SurfaceTr, SurfaceDomain::Corner_index,
                                                            SurfaceDomain::Curve_index>;

constexpr double kMaxTets = 5e6;
constexpr double kTetsPerCellVolume = 5.0;  // a slight over-estimate of Mesh_3's ~4.3 V/s^3

// Refuses a cell size that is not a positive finite length, or that would give more than
// kMaxTets tetrahedra for a body of volume `volume` (m^3).
void check_cell_size(double s, double volume, const std::string& what) {
  if (!std::isfinite(s) || s <= 0.0)
    throw InputError(fmt::format("meshing {}: cell_size must be a finite length > 0 (m), got {}",
                                 what, s));
  const double estimate = kTetsPerCellVolume * volume / (s * s * s);
  if (estimate > kMaxTets)
    throw InputError(fmt::format(
        "meshing {}: cell_size {} m is too small for a body of {:.3g} m^3: it would give about "
        "{:.3g} tetrahedra (limit {:.0f} million); use cell_size >= {:.3g} m",
        what, s, volume, estimate, kMaxTets / 1e6, std::cbrt(kTetsPerCellVolume * volume / kMaxTets)));
}

// Cells in the complex -> TetMesh. Vertices are numbered in order of first appearance while
// iterating the cells (the triangulation's storage order, deterministic for a deterministic
// run); each tet is made positively oriented.
template <class C3t3>
TetMesh extract_tets(const C3t3& c3t3, const std::string& what) {
  using Vertex_handle = typename C3t3::Vertex_handle;
  struct Hash {
    std::size_t operator()(const Vertex_handle& v) const { return std::hash<const void*>()(&*v); }
  };
  TetMesh mesh;
  std::unordered_map<Vertex_handle, std::int32_t, Hash> index;
  mesh.tets.reserve(c3t3.number_of_cells_in_complex());
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    Tet t;
    for (int i = 0; i < 4; ++i) {
      const Vertex_handle v = c->vertex(i);
      auto [it, added] = index.try_emplace(v, static_cast<std::int32_t>(index.size()));
      if (added) {
        const Point& p = v->point().point();  // Mesh_3 vertices carry weighted points
        mesh.points.insert(mesh.points.end(), {p.x(), p.y(), p.z()});
      }
      t[i] = it->second;
    }
    if (signed_tet_volume(mesh.point(t[0]), mesh.point(t[1]), mesh.point(t[2]), mesh.point(t[3])) < 0)
      std::swap(t[2], t[3]);
    mesh.tets.push_back(t);
  }
  if (mesh.tets.empty())
    throw InputError(fmt::format("meshing {}: CGAL produced no tetrahedra (is cell_size larger "
                                 "than the body?)", what));
  MeshLoadReport report;
  finalize_tet_mesh(mesh, what, report);
  return mesh;
}

// Reads a polygon surface and checks that it bounds a volume. The steps of
// CGAL::IO::read_polygon_mesh (read soup, repair, orient, convert), done one by one so that a
// failure can say what is wrong with the file.
SurfaceMesh read_closed_surface(const std::string& file) {
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  if (!CGAL::IO::read_polygon_soup(file, points, faces))
    throw InputError(fmt::format("surface file '{}': unreadable (not a valid .obj, .off, .stl "
                                 "or .ply surface)", file));
  if (faces.empty()) throw InputError(fmt::format("surface file '{}': empty (no faces)", file));
  for (const Point& p : points)
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z()))
      throw InputError(fmt::format("surface file '{}': non-finite vertex coordinate", file));
  PMP::repair_polygon_soup(points, faces);  // merges duplicate points (STL), drops degenerate faces
  if (faces.empty())
    throw InputError(fmt::format("surface file '{}': empty (all faces degenerate)", file));
  if (!PMP::orient_polygon_soup(points, faces) || !PMP::is_polygon_soup_a_polygon_mesh(faces))
    throw InputError(fmt::format(
        "surface file '{}': not a manifold surface (an edge shared by more than two faces, or a "
        "vertex where separate sheets touch)", file));
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  if (!CGAL::is_triangle_mesh(sm) && !PMP::triangulate_faces(sm))
    throw InputError(fmt::format("surface file '{}': a polygon could not be triangulated", file));
  if (!CGAL::is_closed(sm)) {
    std::size_t border = 0;
    for (auto h : sm.halfedges()) border += sm.is_border(h) ? 1 : 0;
    throw InputError(fmt::format("surface file '{}': open surface with {} border edges; a "
                                 "closed surface is needed to bound a volume", file, border));
  }
  if (PMP::does_self_intersect(sm))
    throw InputError(fmt::format("surface file '{}': the surface intersects itself", file));
  return sm;
}

}  // namespace

bool meshing_available() { return true; }

TetMesh mesh_surface_file(const std::filesystem::path& surface, double cell_size) {
  const std::string file = surface.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(surface, ec))
    throw InputError(fmt::format("surface file '{}': no such file", file));
  if (!std::isfinite(cell_size) || cell_size <= 0.0) check_cell_size(cell_size, 0.0, "'" + file + "'");
  SurfaceMesh sm = read_closed_surface(file);
  check_cell_size(cell_size, std::abs(PMP::volume(sm)), "'" + file + "'");

  SurfaceDomain domain(sm);
  domain.detect_features();  // default: edges with a dihedral angle sharper than 60 deg

  namespace P = CGAL::parameters;  // CGAL 5.5: old Boost.Parameter syntax
  const double s = cell_size;
  CGAL::Mesh_criteria_3<SurfaceTr> criteria(P::edge_size = s, P::facet_angle = 25,
                                            P::facet_size = s, P::facet_distance = s / 8,
                                            P::cell_radius_edge_ratio = 3, P::cell_size = s);
  const auto c3t3 =
      CGAL::make_mesh_3<SurfaceC3t3>(domain, criteria, P::no_perturb(), P::no_exude());
  return extract_tets(c3t3, "'" + file + "'");
}

TetMesh mesh_implicit_shape(const std::string& name, double cell_size) {
  const double radius = implicit_shape_bounding_radius(name);  // throws for unknown names
  const std::string what = "implicit shape '" + name + "'";
  auto f = [name](const Point& p) { return implicit_shape_value(name, {p.x(), p.y(), p.z()}); };

  // Volume for the size check: cell count on a 48^3 grid over the bounding cube.
  if (!std::isfinite(cell_size) || cell_size <= 0.0) check_cell_size(cell_size, 0.0, what);
  constexpr int n = 48;
  const double h = 2 * radius / n;
  std::size_t inside = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        inside += f(Point(-radius + (i + 0.5) * h, -radius + (j + 0.5) * h,
                          -radius + (k + 0.5) * h)) < 0;
  check_cell_size(cell_size, static_cast<double>(inside) * h * h * h, what);

  namespace P = CGAL::parameters;
  const ImplicitDomain domain = ImplicitDomain::create_implicit_mesh_domain(
      f, K::Sphere_3(CGAL::ORIGIN, radius * radius), P::relative_error_bound = 1e-6);
  const double s = cell_size;
  CGAL::Mesh_criteria_3<ImplicitTr> criteria(P::facet_angle = 25, P::facet_size = s,
                                             P::facet_distance = s / 4,
                                             P::cell_radius_edge_ratio = 3, P::cell_size = s);
  const auto c3t3 =
      CGAL::make_mesh_3<ImplicitC3t3>(domain, criteria, P::no_perturb(), P::no_exude());
  return extract_tets(c3t3, what);
}

}  // namespace pliant
