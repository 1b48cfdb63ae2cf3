// A multiresolution body's hierarchy (thesis ch. 5 §2-3): the tet meshes of its levels, coarse to
// fine, independent of each other (non-nested: no vertex is shared), and what links them at rest:
// where each node of a level lies in the neighbouring levels (tet + barycentric weights), each
// node's parent (nearest node one level coarser) and children (the nodes one level finer in its
// Voronoi zone) with the ring of finer tets around them, and each tet's parent tets. Built once when
// a body is added; docs/multiresolution.md describes how the engine uses it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant {

// A point's place in a tet mesh: the tet that contains it, or the nearest one for a point just
// outside the mesh, with its barycentric weights there (clamped to >= 0 and renormalised when
// outside, so they still sum to 1).
struct TetLink {
  std::int32_t tet = -1;
  std::array<double, 4> weights{};
  double outside = 0;  // m: 0 inside (or on) the tet; else the distance to the point the weights give
};

struct LevelLinks {
  std::vector<TetLink> to_coarser;   // per node: its place in level l - 1 (empty at level 0)
  std::vector<TetLink> to_finer;     // per node: its place in level l + 1 (empty at the finest)
  std::vector<std::int32_t> parent;  // per node: the nearest node of level l - 1 at rest (empty at level 0)
  // Per node (CSR over its nodes): its children, the nodes of level l + 1 whose parent it is, and
  // the ring, the tets of level l + 1 incident to a child (sorted). Empty at the finest level.
  std::vector<std::int32_t> child_offsets, children;
  std::vector<std::int32_t> ring_offsets, ring;
  std::vector<std::int32_t> tet_parent;  // per tet: the tet of level l - 1 holding its centroid (empty at level 0)
  // Per tet (empty at level 0): for each corner, the tet of level l - 1 holding the point of the tet
  // next to that corner (an eighth of the way to the centroid). A nested tet finds its parent four
  // times; a tet of a non-nested level that straddles a face of the coarser mesh finds the tets on
  // both sides.
  std::vector<std::array<std::int32_t, 4>> tet_corner_parent;
  // Per tet (CSR, empty at level 0): its parent and corner parents, ascending, each once.
  std::vector<std::int32_t> tet_parent_offsets, tet_parents;
};

struct Hierarchy {
  std::vector<TetMesh> meshes;    // 0 (coarsest) .. N - 1 (finest)
  std::vector<LevelLinks> links;  // one per level
  std::size_t levels() const { return meshes.size(); }
};

// The meshes of the levels of a body, coarse to fine; `finest` is the body's own mesh (as
// build_mesh made it). Coarser levels as BodyDef::multiresolution says: a box at cells / ratio^k
// (rounded up, at least 1); the meshes it lists; otherwise the boundary of the finest mesh
// simplified to about 1/ratio^2 of the faces per level (simplify_surface) and meshed at ratio^k
// times the finest level's cell size (mesh_closed_surface; the finest cell size is the one Mesh_3
// would need for its tet count, cbrt(4.3 V / tets); or, with faces given, the size whose facets tile
// the simplified surface in that many triangles), then scaled about its centroid to the finest
// mesh's volume (simplification and meshing shrink a surface). Throws InputError (e.g. without CGAL).
std::vector<TetMesh> build_level_meshes(const BodyDef& def, TetMesh finest);

// Links the levels (the meshes must be finalized and non-empty).
Hierarchy link_levels(std::vector<TetMesh> meshes);

}  // namespace pliant
