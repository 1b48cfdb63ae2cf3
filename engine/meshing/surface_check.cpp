// Surfaces that do not bound a volume: what is wrong with them and where (diagnose_surface), and
// CGAL's polygon mesh processing to repair what it can (repair_surface): merge duplicate points,
// orient, stitch borders, split non-manifold vertices, fill holes, remove self-intersections.
// The second CGAL translation unit of pliant (the first is cgal_mesher.cpp, Mesh_3), kept apart
// so that neither grows past a minute or two of compilation. Also reads surface files into
// soups for both (surface_soup.hpp).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_mesh_to_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <numeric>
#include <sstream>

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
using Faces = std::vector<std::vector<std::size_t>>;

// Fallback for .obj files that CGAL's strict reader refuses because of a line it does not
// know (the SOFA raptor_8kp.obj ends with a NUL byte): keeps "v" and "f" lines, ignores the
// rest. Returns false if a face index is out of range or nothing was read.
bool read_obj_leniently(const std::string& file, std::vector<Point>& points, Faces& faces) {
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

std::vector<Point> to_points(const meshing_detail::SurfaceSoup& s) {
  std::vector<Point> p;
  p.reserve(s.points.size());
  for (const auto& x : s.points) p.emplace_back(x[0], x[1], x[2]);
  return p;
}

Vec3d vec(const Point& p) { return {p.x(), p.y(), p.z()}; }

std::string at(const Vec3d& p) { return fmt::format("({:.4g}, {:.4g}, {:.4g})", p[0], p[1], p[2]); }

// "in [lo]..[hi], e.g. at (a), (b), (c)": where a set of points lies.
std::string where(const std::vector<Vec3d>& pts) {
  if (pts.empty()) return "";
  Vec3d lo = pts[0], hi = pts[0];
  for (const Vec3d& p : pts)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
  std::string s = fmt::format("within [{:.4g}, {:.4g}, {:.4g}]..[{:.4g}, {:.4g}, {:.4g}], e.g. at ", lo[0], lo[1], lo[2],
                              hi[0], hi[1], hi[2]);
  std::vector<std::string> shown;  // up to 3 different positions, as printed
  for (const Vec3d& p : pts) {
    const std::string a = at(p);
    if (std::find(shown.begin(), shown.end(), a) == shown.end()) shown.push_back(a);
    if (shown.size() == 3) break;
  }
  for (std::size_t i = 0; i < shown.size(); ++i) s += (i ? ", " : "") + shown[i];
  return s;
}

std::size_t find_root(std::vector<std::size_t>& parent, std::size_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// Whether two triangles that self_intersections reports cross anywhere other than at the
// positions they share (as CGAL itself judges faces sharing a vertex: exact predicates).
// Sharing one position p, (p, a, b) and (p, c, d) cross iff segment ab meets the other triangle
// or cd meets the first; sharing two, iff they fold onto each other (the other corners coplanar
// and on the same side of the shared edge); sharing none or three, they intersect.
bool cross_beyond_shared_points(const SurfaceMesh& sm, SurfaceMesh::Face_index f, SurfaceMesh::Face_index g) {
  std::array<Point, 3> a, b;
  int i = 0;
  for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) a[std::size_t(i++)] = sm.point(v);
  i = 0;
  for (auto v : CGAL::vertices_around_face(sm.halfedge(g), sm)) b[std::size_t(i++)] = sm.point(v);
  std::vector<int> sa, sb;  // corners of a, b at a shared position
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      if (a[std::size_t(x)] == b[std::size_t(y)]) {
        sa.push_back(x);
        sb.push_back(y);
      }
  if (sa.empty() || sa.size() >= 3) return true;
  const auto other = [](const std::vector<int>& shared, int k) {  // the k-th corner not shared
    int n = 0;
    for (int c = 0; c < 3; ++c)
      if (std::find(shared.begin(), shared.end(), c) == shared.end() && n++ == k) return c;
    return 0;
  };
  const K::Triangle_3 ta(a[0], a[1], a[2]), tb(b[0], b[1], b[2]);
  if (sa.size() == 1) {
    const K::Segment_3 ea(a[std::size_t(other(sa, 0))], a[std::size_t(other(sa, 1))]);
    const K::Segment_3 eb(b[std::size_t(other(sb, 0))], b[std::size_t(other(sb, 1))]);
    return CGAL::do_intersect(ea, tb) || CGAL::do_intersect(eb, ta);
  }
  const Point& p = a[std::size_t(sa[0])];
  const Point& q = a[std::size_t(sa[1])];
  const Point& r = a[std::size_t(other(sa, 0))];
  const Point& s = b[std::size_t(other(sb, 0))];
  return CGAL::coplanar(p, q, r, s) && CGAL::coplanar_orientation(p, q, r, s) == CGAL::POSITIVE;
}

// The diagnosis of a soup (after repair_polygon_soup: merged points, no degenerate faces).
SurfaceDiagnosis diagnose_soup(std::vector<Point> points, Faces faces) {
  SurfaceDiagnosis d;
  d.vertices = points.size();
  d.faces = faces.size();
  bool any = false;
  for (const auto& f : faces)
    for (std::size_t v : f) {
      const Vec3d p = vec(points[v]);
      if (!any) d.min = d.max = p;
      any = true;
      for (int k = 0; k < 3; ++k) d.min[k] = std::min(d.min[k], p[k]), d.max[k] = std::max(d.max[k], p[k]);
    }
  for (const auto& f : faces) d.triangles += f.size() - 2;

  // Edges and how many faces use each.
  std::map<std::pair<std::size_t, std::size_t>, int> edge_faces;
  for (const auto& f : faces)
    for (std::size_t i = 0; i < f.size(); ++i) ++edge_faces[std::minmax(f[i], f[(i + 1) % f.size()])];
  std::vector<Vec3d> nm_at, border_at;
  std::vector<std::size_t> parent(points.size());
  std::iota(parent.begin(), parent.end(), std::size_t(0));
  std::vector<std::pair<std::size_t, std::size_t>> border;
  for (const auto& [e, n] : edge_faces) {
    const Vec3d mid = vec(CGAL::midpoint(points[e.first], points[e.second]));
    if (n > 2) {
      ++d.non_manifold_edges;
      nm_at.push_back(mid);
    } else if (n == 1) {
      ++d.border_edges;
      border.push_back(e);
      parent[find_root(parent, e.first)] = find_root(parent, e.second);
    }
  }
  // Holes: connected loops of 3 or more border edges, largest first (fewer: stray border edges
  // beside non-manifold edges or lone faces).
  std::map<std::size_t, std::pair<std::size_t, std::vector<std::size_t>>> pieces;  // root -> (edges, vertices)
  for (const auto& e : border) {
    auto& piece = pieces[find_root(parent, e.first)];
    ++piece.first;
    piece.second.push_back(e.first);
    piece.second.push_back(e.second);
  }
  std::vector<std::vector<Vec3d>> loops;  // the vertices of each loop, once each
  std::size_t stray = 0;
  for (auto& [root, piece] : pieces) {
    if (piece.first < 3) {
      stray += piece.first;
      continue;
    }
    std::sort(piece.second.begin(), piece.second.end());
    piece.second.erase(std::unique(piece.second.begin(), piece.second.end()), piece.second.end());
    std::vector<Vec3d>& l = loops.emplace_back();
    for (std::size_t v : piece.second) l.push_back(vec(points[v]));
  }
  d.holes = loops.size();
  if (d.non_manifold_edges)
    d.problems.push_back(fmt::format("{} non-manifold edge{} (shared by more than two faces) {}", d.non_manifold_edges,
                                     d.non_manifold_edges == 1 ? "" : "s", where(nm_at)));
  if (d.border_edges) {
    std::stable_sort(loops.begin(), loops.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
    std::string list;
    for (std::size_t i = 0; i < std::min<std::size_t>(3, loops.size()); ++i) {
      Vec3d c{0, 0, 0};
      for (const Vec3d& p : loops[i])
        for (int k = 0; k < 3; ++k) c[k] += p[k] / double(loops[i].size());
      list += fmt::format("{}{} edges around {}", i ? "; " : "", loops[i].size(), at(c));  // a loop: as many edges as vertices
    }
    std::string text = fmt::format("open: {} border edge{} (edges of one face only)", d.border_edges, d.border_edges == 1 ? "" : "s");
    if (d.holes)
      text += fmt::format(", {} hole{} (loops of 3 or more of them){}{}{}", d.holes, d.holes == 1 ? "" : "s",
                          d.holes == 1 ? " of " : ", the largest: ", list, loops.size() > 3 ? "; ..." : "");
    if (stray && d.holes)
      text += fmt::format("; and {} stray border edge{} (beside non-manifold edges or loose faces)", stray, stray == 1 ? "" : "s");
    else if (stray)
      text += ", all stray (beside non-manifold edges or loose faces): no hole";
    d.problems.push_back(text);
  }

  // Orientation and non-manifold vertices: orienting the soup splits every vertex where separate
  // sheets meet (and every non-manifold edge) into copies.
  const std::size_t before = points.size();
  const bool oriented = PMP::orient_polygon_soup(points, faces);
  if (d.non_manifold_edges == 0 && points.size() > before) {
    d.non_manifold_vertices = points.size() - before;
    std::vector<Vec3d> nv;
    for (std::size_t i = before; i < points.size(); ++i) nv.push_back(vec(points[i]));
    d.problems.push_back(fmt::format("{} non-manifold vertex{} (separate sheets of the surface touch there) {}",
                                     d.non_manifold_vertices, d.non_manifold_vertices == 1 ? "" : "es", where(nv)));
  }
  d.orientable = oriented || points.size() > before;  // false only when orientation failed without splitting
  if (!PMP::is_polygon_soup_a_polygon_mesh(faces)) {
    d.orientable = false;
    d.problems.push_back("the faces cannot be oriented consistently");
    return d;
  }
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  if (!CGAL::is_triangle_mesh(sm)) PMP::triangulate_faces(sm);
  std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> found, pairs;
  PMP::self_intersections(sm, std::back_inserter(found));
  // Faces that meet only at the copies made above of a non-manifold vertex or edge (the same
  // positions) do not intersect: keep such a pair only if the faces also cross elsewhere.
  for (const auto& [f, g] : found)
    if (cross_beyond_shared_points(sm, f, g)) pairs.push_back({f, g});
  d.self_intersections = pairs.size();
  if (!pairs.empty()) {
    std::vector<Vec3d> si;
    for (const auto& [f, g] : pairs) si.push_back(vec(CGAL::centroid(sm.point(sm.source(sm.halfedge(f))),
                                                                     sm.point(sm.target(sm.halfedge(f))),
                                                                     sm.point(sm.target(sm.next(sm.halfedge(f)))))));
    d.problems.push_back(fmt::format("{} pair{} of faces intersect {}", pairs.size(), pairs.size() == 1 ? "" : "s", where(si)));
  }
  d.closed = d.non_manifold_edges == 0 && d.non_manifold_vertices == 0 && d.border_edges == 0 && CGAL::is_closed(sm);
  if (d.closed) d.volume = std::abs(PMP::volume(sm));
  return d;
}

// A soup made ready for diagnosis: duplicate points merged (STL), degenerate faces dropped.
std::pair<std::vector<Point>, Faces> prepared_soup(const std::string& file) {
  const meshing_detail::SurfaceSoup soup = meshing_detail::read_surface_soup(file);
  std::vector<Point> points = to_points(soup);
  Faces faces = soup.faces;
  PMP::repair_polygon_soup(points, faces);
  if (faces.empty()) throw InputError(fmt::format("surface file '{}': empty (all faces are degenerate)", file));
  return {std::move(points), std::move(faces)};
}

}  // namespace

namespace meshing_detail {

SurfaceSoup read_surface_soup(const std::string& file) {
  const auto fail = [&](const std::string& what) { return InputError(fmt::format("surface file '{}': {}", file, what)); };
  // Regular files only (a FIFO would block CGAL's reader): says what the path is instead.
  if (check_input_file(file, "surface file") == 0) throw fail("empty file");
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".obj" && ext != ".off" && ext != ".stl" && ext != ".ply")
    throw fail("unsupported extension '" + ext + "' (surface files: .obj, .off, .stl, .ply)");
  std::vector<Point> points;
  Faces faces;
  if (!CGAL::IO::read_polygon_soup(file, points, faces) && !(ext == ".obj" && read_obj_leniently(file, points, faces)))
    throw fail("unreadable (not a valid .obj, .off, .stl or .ply surface, or no faces)");
  if (faces.empty()) throw fail("empty (no faces)");
  SurfaceSoup s;
  s.points.reserve(points.size());
  for (const Point& p : points) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) throw fail("non-finite vertex coordinate");
    s.points.push_back({p.x(), p.y(), p.z()});
  }
  s.faces = std::move(faces);
  return s;
}

}  // namespace meshing_detail

SurfaceDiagnosis diagnose_surface(const std::filesystem::path& surface) {
  auto [points, faces] = prepared_soup(surface.string());
  return diagnose_soup(std::move(points), std::move(faces));
}

RepairedSurface repair_surface(const std::filesystem::path& surface) {
  const std::string file = surface.string();
  RepairedSurface out;
  const meshing_detail::SurfaceSoup soup = meshing_detail::read_surface_soup(file);
  std::vector<Point> points = to_points(soup);
  Faces faces = soup.faces;
  const std::size_t read_points = points.size(), read_faces = faces.size();
  PMP::repair_polygon_soup(points, faces);
  if (faces.empty()) throw InputError(fmt::format("surface file '{}': empty (all faces are degenerate)", file));
  if (points.size() != read_points || faces.size() != read_faces)
    out.steps.push_back(fmt::format("merged duplicate points and dropped degenerate or repeated faces ({} -> {} points, {} -> {} faces)",
                                    read_points, points.size(), read_faces, faces.size()));
  // Orienting splits non-manifold vertices and edges into separate sheets; stitching below joins
  // those sheets again where they share whole borders.
  const std::size_t before = points.size();
  PMP::orient_polygon_soup(points, faces);
  if (points.size() > before)
    out.steps.push_back(fmt::format("split {} non-manifold point{} to orient the faces", points.size() - before,
                                    points.size() - before == 1 ? "" : "s"));
  if (!PMP::is_polygon_soup_a_polygon_mesh(faces))
    throw InputError(fmt::format("surface file '{}': cannot be repaired: its faces cannot be oriented consistently", file));
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, faces, sm);
  if (!CGAL::is_triangle_mesh(sm)) PMP::triangulate_faces(sm);
  if (const std::size_t s = PMP::stitch_borders(sm)) out.steps.push_back(fmt::format("stitched {} pair{} of border edges", s, s == 1 ? "" : "s"));
  if (const std::size_t s = PMP::duplicate_non_manifold_vertices(sm))
    out.steps.push_back(fmt::format("split {} non-manifold vertex{}", s, s == 1 ? "" : "es"));
  // Holes: each border cycle is triangulated and refined to the density around it.
  std::vector<SurfaceMesh::Halfedge_index> cycles;
  PMP::extract_boundary_cycles(sm, std::back_inserter(cycles));
  std::size_t filled = 0, patch_faces = 0;
  for (auto h : cycles) {
    std::vector<SurfaceMesh::Face_index> patch;
    std::vector<SurfaceMesh::Vertex_index> added;
    PMP::triangulate_and_refine_hole(sm, h, std::back_inserter(patch), std::back_inserter(added));
    filled += patch.empty() ? 0 : 1;
    patch_faces += patch.size();
  }
  if (filled) out.steps.push_back(fmt::format("filled {} hole{} with {} triangles", filled, filled == 1 ? "" : "s", patch_faces));
  if (PMP::does_self_intersect(sm)) {
    PMP::experimental::remove_self_intersections(sm);
    out.steps.push_back("removed self-intersections (CGAL's experimental remove_self_intersections)");
  }
  if (CGAL::is_closed(sm) && !PMP::does_self_intersect(sm)) {
    PMP::orient_to_bound_a_volume(sm);
  }
  sm.collect_garbage();
  // Back to a plain soup: the mesher builds its own surface from it.
  std::vector<Point> rp;
  std::vector<std::vector<std::size_t>> rf;
  PMP::polygon_mesh_to_polygon_soup(sm, rp, rf);
  out.points.reserve(3 * rp.size());
  for (const Point& p : rp) out.points.insert(out.points.end(), {p.x(), p.y(), p.z()});
  for (const auto& f : rf) out.triangles.push_back({std::int32_t(f[0]), std::int32_t(f[1]), std::int32_t(f[2])});
  out.after = diagnose_soup(std::move(rp), std::move(rf));
  if (out.steps.empty()) out.steps.push_back("nothing to repair");
  return out;
}

}  // namespace pliant
