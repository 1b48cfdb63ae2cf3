// Geometric measures of a tetrahedral mesh, for `pliant info` and for the stable time step.
#pragma once
#include "pliant/tet_mesh.hpp"

namespace pliant {

struct MeshQuality {
  std::size_t nodes = 0, tets = 0, boundary_triangles = 0;
  Vec3d bbox_min{}, bbox_max{};        // m
  double volume = 0;                   // m^3, sum of tet volumes
  double min_dihedral_deg = 0;         // smallest dihedral angle over all tets (degrees)
  double max_dihedral_deg = 0;         // largest
  double worst_aspect_ratio = 0;       // max over tets of (longest edge)/(smallest altitude) * sqrt(2/3): 1 for a regular tet, inf for a flat one
  double min_altitude = 0;             // m, smallest tet altitude (Courant length)
  double min_edge = 0, max_edge = 0;   // m
};

MeshQuality compute_mesh_quality(const TetMesh& mesh);

// Boundary triangles: faces used by exactly one tet, oriented outwards. Deterministic order
// (sorted by tet, then local face).
std::vector<std::array<std::int32_t, 3>> boundary_triangles(const std::vector<Tet>& tets);

}  // namespace pliant
