// Tetrahedralisation with CGAL Mesh_3 (CGAL 5.5). This is the only pliant file that includes
// CGAL: one CGAL translation unit takes one to two minutes and 4-5 GB to compile, so everything
// that needs CGAL lives here, behind the plain API of pliant/meshing.hpp. Lengths are in metres
// (a surface file's coordinates are taken as metres).
//
// Reproducibility: make_mesh_3 runs with no_perturb() and exude(time_limit = 0). By default
// CGAL 5.5 stops the perturber and the exuder on a wall-clock limit, so the mesh would depend on
// machine load; with no_exude() it is reproducible but keeps slivers (min dihedral angles of
// 0.4-1 deg on the organ: fatal for an explicit solver's time step). An exuder run to the end
// is deterministic too (0.2 s at 4k tets, 0.7 s at 11k: 5-7x the refinement alone) and lifts the
// organ's minimum dihedral angle to ~12 deg. Both domains seed their random generator with 0.
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
#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/meshing.hpp"
#include "surface_soup.hpp"

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

// Surface files: the inside of a closed triangle surface, sharp edges protected if that works
// (see mesh_surface_file).
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
TetMesh extract_tets(const C3t3& c3t3) {
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
  return mesh;
}

// Mesh_3 with the reproducible settings described at the top of the file.
template <class C3t3, class Domain, class Criteria>
TetMesh run_mesh_3(const Domain& domain, const Criteria& criteria, bool perturb = false) {
  namespace P = CGAL::parameters;  // CGAL 5.5: old Boost.Parameter syntax
  // perturb: also the sliver perturber, run to its end (time_limit = 0: reproducible). It lifts
  // the smallest dihedral angles of coarse meshes of simplified surfaces (6 deg -> see
  // mesh_closed_surface), at 4-5x the cost: nothing for the few hundred tets of a coarse level.
  const C3t3 c3t3 = perturb ? CGAL::make_mesh_3<C3t3>(domain, criteria, P::odt(P::max_iteration_number = 40),
                                                      P::perturb(P::time_limit = 0), P::exude(P::time_limit = 0))
                            : CGAL::make_mesh_3<C3t3>(domain, criteria, P::no_perturb(), P::exude(P::time_limit = 0));
  return extract_tets(c3t3);
}

double min_tet_volume(const TetMesh& m) {
  double v = INFINITY;
  for (const Tet& t : m.tets)
    v = std::min(v, signed_tet_volume(m.point(t[0]), m.point(t[1]), m.point(t[2]), m.point(t[3])));
  return v;
}

TetMesh finalized(TetMesh mesh, const std::string& what) {
  if (mesh.tets.empty())
    throw InputError(fmt::format("meshing {}: CGAL produced no tetrahedra (is cell_size larger "
                                 "than the body?)", what));
  MeshLoadReport report;
  finalize_tet_mesh(mesh, what, report);
  return mesh;
}

// Reads a polygon surface and checks that it bounds a volume. These are the steps of
// CGAL::IO::read_polygon_mesh (read a soup, repair, orient, convert), done one by one so that a
// failure can say what is wrong with the file. Local self-intersections (as in the SOFA
// liver-smooth.obj) are repaired by CGAL's experimental remove_self_intersections.
SurfaceMesh read_closed_surface(const std::string& file) {
  const auto fail = [&](const std::string& what) {
    return InputError(fmt::format("surface file '{}': {}", file, what));
  };
  const meshing_detail::SurfaceSoup soup = meshing_detail::read_surface_soup(file);
  std::vector<Point> points;
  points.reserve(soup.points.size());
  for (const auto& p : soup.points) points.emplace_back(p[0], p[1], p[2]);
  std::vector<std::vector<std::size_t>> faces = soup.faces;

  PMP::repair_polygon_soup(points, faces);  // merges duplicate points (STL), drops degenerate faces
  if (faces.empty()) throw fail("empty (all faces are degenerate)");
  std::map<std::pair<std::size_t, std::size_t>, int> edge_faces;
  for (const auto& f : faces)
    for (std::size_t i = 0; i < f.size(); ++i)
      ++edge_faces[std::minmax(f[i], f[(i + 1) % f.size()])];
  const auto shared = std::count_if(edge_faces.begin(), edge_faces.end(),
                                    [](const auto& e) { return e.second > 2; });
  if (shared > 0)
    throw fail(fmt::format("non-manifold: {} edges are shared by more than two faces", shared));
  if (!PMP::orient_polygon_soup(points, faces) || !PMP::is_polygon_soup_a_polygon_mesh(faces))
    throw fail("non-manifold (separate sheets of the surface touch at a vertex) or not orientable");

  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  if (!CGAL::is_triangle_mesh(sm) && !PMP::triangulate_faces(sm))
    throw fail("a polygon could not be triangulated");
  if (!CGAL::is_closed(sm)) {
    std::size_t border = 0;
    for (auto h : sm.halfedges()) border += sm.is_border(h) ? 1 : 0;
    throw fail(fmt::format("open surface with {} border edges; a closed surface is needed to "
                           "bound a volume", border));
  }
  if (PMP::does_self_intersect(sm)) {
    PMP::experimental::remove_self_intersections(sm);
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    PMP::self_intersections(sm, std::back_inserter(pairs));
    if (!pairs.empty() || !CGAL::is_closed(sm)) {
      const Point& p = sm.point(sm.target(sm.halfedge(pairs.empty() ? *sm.faces().begin()
                                                                    : pairs.front().first)));
      throw fail(fmt::format("the surface intersects itself ({} pairs of faces, e.g. near "
                             "({:.4g}, {:.4g}, {:.4g})) and could not be repaired",
                             pairs.size(), p.x(), p.y(), p.z()));
    }
  }
  return sm;
}

}  // namespace

// read_closed_surface, with the diagnosis of a surface that does not bound a volume (where its
// holes, non-manifold edges and self-intersections are) and what to do about it.
SurfaceMesh read_closed_surface_or_explain(const std::string& file) {
  try {
    return read_closed_surface(file);
  } catch (const InputError& e) {
    SurfaceDiagnosis d;
    try {
      d = diagnose_surface(file);
    } catch (const InputError&) {
      throw e;  // unreadable: the first message says it all
    }
    if (d.problems.empty()) throw;
    std::string msg = std::string(e.what()) + "; what is wrong with it:";
    for (const std::string& p : d.problems) msg += "\n    " + p;
    msg += "\n  (`pliant info FILE` shows this; \"repair\": true in the scene's mesh, or --repair, tries CGAL's repair)";
    throw InputError(msg);
  }
}

// The surface after repair_surface, if it bounds a volume now.
SurfaceMesh repaired_closed_surface(const std::filesystem::path& surface) {
  const RepairedSurface r = repair_surface(surface);
  std::string did;
  for (const std::string& s : r.steps) did += (did.empty() ? "" : "; ") + s;
  if (!r.after.bounds_volume()) {
    std::string msg = fmt::format("surface file '{}': the repair ({}) did not make it bound a volume; still:",
                                  surface.string(), did);
    for (const std::string& p : r.after.problems) msg += "\n    " + p;
    throw InputError(msg);
  }
  std::vector<Point> points;
  for (std::size_t i = 0; i + 2 < r.points.size(); i += 3) points.emplace_back(r.points[i], r.points[i + 1], r.points[i + 2]);
  std::vector<std::vector<std::size_t>> faces;
  for (const auto& t : r.triangles) faces.push_back({std::size_t(t[0]), std::size_t(t[1]), std::size_t(t[2])});
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  return sm;
}

bool meshing_available() { return true; }

namespace {

// Mesh_3 of the inside of a closed surface (mesh_surface_file and mesh_closed_surface).
// smooth_only: no sharp-feature protection (the coarse levels of a hierarchy: a simplified organic
// surface is all "sharp" edges at 60 deg, and protecting them leaves tets far smaller than s).
TetMesh mesh_inside(const SurfaceMesh& sm, double cell_size, const std::string& what, bool perturb = false,
                    bool smooth_only = false) {
  check_cell_size(cell_size, std::abs(PMP::volume(sm)), what);
  namespace P = CGAL::parameters;
  const double s = cell_size;
  // A coarse level's surface is already simplified: follow it to s/4 (as implicit shapes), not
  // s/8, which only adds thin tets along its creases.
  const CGAL::Mesh_criteria_3<SurfaceTr> criteria(
      P::edge_size = s, P::facet_angle = 25, P::facet_size = s, P::facet_distance = smooth_only ? s / 4 : s / 8,
      P::cell_radius_edge_ratio = 3, P::cell_size = s);

  // First with sharp edges (normals > 60 deg apart) protected, which keeps a CAD part's edges
  // and corners exact. On organic surfaces (the SOFA liver, the raptor) the detected "features"
  // are short, ragged polylines whose protecting balls leave tets of 1e-9 s^3 (fatal for an
  // explicit solver, and rejected by finalize_tet_mesh): then mesh again without features.
  // Good meshes have a smallest tet of 1e-3 to 5e-2 s^3.
  if (smooth_only) {
    const SurfaceDomain smooth(sm);
    return finalized(run_mesh_3<SurfaceC3t3>(smooth, criteria, perturb), what);
  }
  SurfaceDomain with_features(sm);
  with_features.detect_features(60);
  TetMesh mesh = run_mesh_3<SurfaceC3t3>(with_features, criteria, perturb);
  if (!(min_tet_volume(mesh) >= 1e-5 * s * s * s)) {
    const SurfaceDomain smooth(sm);
    mesh = run_mesh_3<SurfaceC3t3>(smooth, criteria, perturb);
  }
  return finalized(std::move(mesh), what);
}

}  // namespace

TetMesh mesh_surface_file(const std::filesystem::path& surface, double cell_size, bool repair) {
  const std::string file = surface.string();
  check_input_file(surface, "surface file");  // regular files only: CGAL's readers would hang on a FIFO
  if (!std::isfinite(cell_size) || cell_size <= 0.0) check_cell_size(cell_size, 0.0, "'" + file + "'");
  SurfaceMesh sm = repair ? repaired_closed_surface(surface) : read_closed_surface_or_explain(file);
  return mesh_inside(sm, cell_size, "'" + file + "'");
}

TetMesh mesh_closed_surface(const TriangleSurface& surface, double cell_size, const std::string& what) {
  if (!std::isfinite(cell_size) || cell_size <= 0.0) check_cell_size(cell_size, 0.0, what);
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> v;
  v.reserve(surface.point_count());
  for (std::size_t i = 0; i < surface.point_count(); ++i)
    v.push_back(sm.add_vertex(Point(surface.points[3 * i], surface.points[3 * i + 1], surface.points[3 * i + 2])));
  for (const auto& t : surface.triangles)
    if (sm.add_face(v[std::size_t(t[0])], v[std::size_t(t[1])], v[std::size_t(t[2])]) == SurfaceMesh::null_face())
      throw InputError(fmt::format("meshing {}: the surface is not manifold", what));
  if (!CGAL::is_closed(sm)) throw InputError(fmt::format("meshing {}: the surface is not closed", what));
  return mesh_inside(sm, cell_size, what, /*perturb=*/true, /*smooth_only=*/true);
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
  const CGAL::Mesh_criteria_3<ImplicitTr> criteria(
      P::facet_angle = 25, P::facet_size = s, P::facet_distance = s / 4,
      P::cell_radius_edge_ratio = 3, P::cell_size = s);
  return finalized(run_mesh_3<ImplicitC3t3>(domain, criteria), what);
}

}  // namespace pliant
