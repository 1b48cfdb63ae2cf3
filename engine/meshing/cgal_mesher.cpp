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
TetMesh run_mesh_3(const Domain& domain, const Criteria& criteria) {
  namespace P = CGAL::parameters;  // CGAL 5.5: old Boost.Parameter syntax
  const C3t3 c3t3 =
      CGAL::make_mesh_3<C3t3>(domain, criteria, P::no_perturb(), P::exude(P::time_limit = 0));
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

// Fallback for .obj files that CGAL's strict reader refuses because of a line it does not
// know (the SOFA raptor_8kp.obj ends with a NUL byte): keeps "v" and "f" lines, ignores the
// rest. Returns false if a face index is out of range or nothing was read.
bool read_obj_leniently(const std::string& file, std::vector<Point>& points,
                        std::vector<std::vector<std::size_t>>& faces) {
  points.clear();
  faces.clear();
  std::ifstream in(file);
  std::string line, key;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    if (!(ls >> key)) continue;
    if (key == "v") {
      double x, y, z;
      if (!(ls >> x >> y >> z)) return false;
      points.emplace_back(x, y, z);
    } else if (key == "f") {
      std::vector<std::size_t>& f = faces.emplace_back();
      std::string corner;
      while (ls >> corner) {  // "i", "i/t", "i//n" or "i/t/n"; negative i counts from the end
        const long i = std::strtol(corner.c_str(), nullptr, 10);
        const long n = static_cast<long>(points.size());
        const long k = i < 0 ? n + i : i - 1;
        if (i == 0 || k < 0 || k >= n) return false;
        f.push_back(static_cast<std::size_t>(k));
      }
      if (f.size() < 3) return false;
    }
  }
  return !points.empty() && !faces.empty();
}

// Reads a polygon surface and checks that it bounds a volume. These are the steps of
// CGAL::IO::read_polygon_mesh (read a soup, repair, orient, convert), done one by one so that a
// failure can say what is wrong with the file. Local self-intersections (as in the SOFA
// liver-smooth.obj) are repaired by CGAL's experimental remove_self_intersections.
SurfaceMesh read_closed_surface(const std::string& file) {
  const auto fail = [&](const std::string& what) {
    return InputError(fmt::format("surface file '{}': {}", file, what));
  };
  std::error_code ec;
  if (std::filesystem::file_size(file, ec) == 0 && !ec) throw fail("empty file");
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".obj" && ext != ".off" && ext != ".stl" && ext != ".ply")
    throw fail("unsupported extension '" + ext + "' (surface files: .obj, .off, .stl, .ply)");
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  if (!CGAL::IO::read_polygon_soup(file, points, faces) &&
      !(ext == ".obj" && read_obj_leniently(file, points, faces)))
    throw fail("unreadable (not a valid .obj, .off, .stl or .ply surface, or no faces)");
  if (faces.empty()) throw fail("empty (no faces)");
  for (const Point& p : points)
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z()))
      throw fail("non-finite vertex coordinate");

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

bool meshing_available() { return true; }

TetMesh mesh_surface_file(const std::filesystem::path& surface, double cell_size) {
  const std::string file = surface.string();
  check_input_file(surface, "surface file");  // regular files only: CGAL's readers would hang on a FIFO
  if (!std::isfinite(cell_size) || cell_size <= 0.0) check_cell_size(cell_size, 0.0, "'" + file + "'");
  SurfaceMesh sm = read_closed_surface(file);
  check_cell_size(cell_size, std::abs(PMP::volume(sm)), "'" + file + "'");

  namespace P = CGAL::parameters;
  const double s = cell_size;
  const CGAL::Mesh_criteria_3<SurfaceTr> criteria(
      P::edge_size = s, P::facet_angle = 25, P::facet_size = s, P::facet_distance = s / 8,
      P::cell_radius_edge_ratio = 3, P::cell_size = s);

  // First with sharp edges (normals > 60 deg apart) protected, which keeps a CAD part's edges
  // and corners exact. On organic surfaces (the SOFA liver, the raptor) the detected "features"
  // are short, ragged polylines whose protecting balls leave tets of 1e-9 s^3 (fatal for an
  // explicit solver, and rejected by finalize_tet_mesh): then mesh again without features.
  // Good meshes have a smallest tet of 1e-3 to 5e-2 s^3.
  SurfaceDomain with_features(sm);
  with_features.detect_features(60);
  TetMesh mesh = run_mesh_3<SurfaceC3t3>(with_features, criteria);
  if (!(min_tet_volume(mesh) >= 1e-5 * s * s * s)) {
    const SurfaceDomain smooth(sm);
    mesh = run_mesh_3<SurfaceC3t3>(smooth, criteria);
  }
  return finalized(std::move(mesh), "'" + file + "'");
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
