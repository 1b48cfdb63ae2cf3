// Tetrahedralisation (CGAL Mesh_3) of closed surfaces and of shipped implicit shapes. Lives in
// its own library because CGAL is slow to compile; without CGAL these throw InputError saying
// that the build has no meshing.
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

bool meshing_available();

// A closed, manifold triangle surface from .obj, .off, .stl or .ply, meshed at target cell size
// `cell_size` (m). Reproducible: the same file and size give the same mesh on every run.
TetMesh mesh_surface_file(const std::filesystem::path& surface, double cell_size);

// Shipped implicit shapes, by name (see implicit_shape_names()). "organ": a smooth, liver-like
// body about 0.2 x 0.12 x 0.08 m centred on the origin; "sphere": radius 0.05 m; "capsule": a
// rounded cylinder along x, 0.2 m long, radius 0.03 m (see engine/meshing/implicit_shapes.cpp).
TetMesh mesh_implicit_shape(const std::string& name, double cell_size);
std::vector<std::string> implicit_shape_names();

// Signed function of a shipped shape (negative inside), for tests and for the mesher.
double implicit_shape_value(const std::string& name, const Vec3d& p);

// Radius (m) of a sphere about the origin that strictly contains the shape.
double implicit_shape_bounding_radius(const std::string& name);

}  // namespace pliant
