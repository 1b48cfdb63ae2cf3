// Tetrahedralisation (CGAL Mesh_3) of closed surfaces and of shipped implicit shapes. Lives in
// its own library because CGAL is slow to compile; without CGAL these throw InputError saying
// that the build has no meshing.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

bool meshing_available();

// A closed, manifold triangle surface from .obj, .off, .stl or .ply, meshed at target cell size
// `cell_size` (m). Reproducible: the same file and size give the same mesh on every run.
// A surface that does not bound a volume throws InputError with its diagnosis (see
// diagnose_surface). With `repair`, such a surface is first repaired (repair_surface) and meshed
// if the repair gave a closed surface.
TetMesh mesh_surface_file(const std::filesystem::path& surface, double cell_size, bool repair = false);

// What a surface file is and why it does or does not bound a volume, in the file's units.
struct SurfaceDiagnosis {
  std::size_t vertices = 0, faces = 0;    // as read (faces of any size)
  std::size_t triangles = 0;              // after splitting polygons
  Vec3d min{}, max{};                     // bounding box of the vertices used by faces
  std::size_t non_manifold_edges = 0;     // edges shared by more than two faces
  std::size_t non_manifold_vertices = 0;  // vertices where separate sheets touch (after the edges are fine)
  std::size_t border_edges = 0;           // edges of one face only (the rims of holes)
  std::size_t holes = 0;                  // connected loops of 3 or more border edges
  std::size_t self_intersections = 0;     // pairs of faces that cross (checked on a manifold surface only)
  bool orientable = true;
  bool closed = false;                    // no border edges, manifold, orientable (the mesher then
                                          // removes local self-intersections itself, as far as CGAL can)
  double volume = 0;                      // enclosed volume, when closed (file units cubed)
  // Where the problems are: one line per kind, with a bounding box and up to 3 vertex positions.
  std::vector<std::string> problems;
  bool bounds_volume() const { return closed && self_intersections == 0; }
};
// Reads a surface (.obj, .off, .stl, .ply) and diagnoses it; throws InputError only when the
// file cannot be read at all. Needs CGAL (InputError saying so without).
SurfaceDiagnosis diagnose_surface(const std::filesystem::path& surface);

// Repairs a surface with CGAL's polygon mesh processing, as far as it can: stitches borders that
// coincide, removes non-manifold configurations (duplicating vertices), orients the faces, fills
// holes (triangulate, refine and fair the patch), removes self-intersections. The result, as a
// triangle soup in file units, and what was done.
struct RepairedSurface {
  std::vector<double> points;                       // x y z per vertex
  std::vector<std::array<std::int32_t, 3>> triangles;
  std::vector<std::string> steps;                   // what each stage changed, e.g. "filled 3 holes"
  SurfaceDiagnosis after;                           // the diagnosis of the result
};
RepairedSurface repair_surface(const std::filesystem::path& surface);

// Shipped implicit shapes, by name (see implicit_shape_names()). "organ": a smooth, liver-like
// body about 0.2 x 0.12 x 0.08 m centred on the origin; "sphere": radius 0.05 m; "capsule": a
// rounded cylinder along x, 0.2 m long, radius 0.03 m (see engine/meshing/implicit_shapes.cpp).
TetMesh mesh_implicit_shape(const std::string& name, double cell_size);
std::vector<std::string> implicit_shape_names();

// A triangle surface: interleaved points (m) and triangles oriented outwards (counter-clockwise
// seen from outside). The boundary of a tet mesh (boundary_surface), or a simplified copy of one.
struct TriangleSurface {
  std::vector<double> points;
  std::vector<std::array<std::int32_t, 3>> triangles;
  std::size_t point_count() const { return points.size() / 3; }
};

// The boundary of a tet mesh as a surface of its own (unused points dropped). No CGAL needed.
TriangleSurface boundary_surface(const TetMesh& mesh);

// Garland-Heckbert edge collapse (CGAL Surface_mesh_simplification, plane quadrics) of a closed
// surface to about `faces` triangles (never fewer than 4; a surface already that small is returned
// as it is). Deterministic. `what` names the surface in messages.
TriangleSurface simplify_surface(const TriangleSurface& surface, std::size_t faces, const std::string& what);

// The inside of a closed, manifold surface meshed at cell size `cell_size` (m), with the settings
// and the reproducibility of mesh_surface_file. `what` names the surface in messages.
TetMesh mesh_closed_surface(const TriangleSurface& surface, double cell_size, const std::string& what);

// Signed function of a shipped shape (negative inside), for tests and for the mesher.
double implicit_shape_value(const std::string& name, const Vec3d& p);

// Radius (m) of a sphere about the origin that strictly contains the shape.
double implicit_shape_bounding_radius(const std::string& name);

}  // namespace pliant
