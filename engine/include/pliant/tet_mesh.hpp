// A tetrahedral mesh as it comes from a file, a generator or a mesher: interleaved points and
// 4-index cells. It is the exchange format between mesh sources and Level (which is SoA).
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pliant {

using Vec3d = std::array<double, 3>;
using Tet = std::array<std::int32_t, 4>;

struct TetMesh {
  std::vector<double> points;  // x0 y0 z0 x1 y1 z1 ... (m)
  std::vector<Tet> tets;       // positively oriented after finalize_tet_mesh

  std::size_t node_count() const { return points.size() / 3; }
  std::size_t tet_count() const { return tets.size(); }
  Vec3d point(std::size_t i) const { return {points[3 * i], points[3 * i + 1], points[3 * i + 2]}; }
};

// What loading did to the file's contents, so that the user can be told.
struct MeshLoadReport {
  std::size_t skipped_cells = 0;      // non-tetrahedral cells (triangles, lines, points, hexes...)
  std::size_t reoriented_tets = 0;    // negative-volume tets whose corners were swapped
  std::size_t dropped_vertices = 0;   // vertices used by no tet
  // When vertices were dropped: vertex_map[i] = the mesh node that the file's i-th vertex (in file
  // order, from 0) became, or -1 for a dropped one. Empty when none was dropped (identity).
  std::vector<std::int32_t> vertex_map;
};

// Signed volume of tet (a,b,c,d): det[b-a, c-a, d-a] / 6 (m^3).
double signed_tet_volume(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);

// Checks and normalises a freshly read mesh: every coordinate finite, every index in range,
// no repeated corner, no degenerate tet (|V| <= 1e-12 L^3, L the tet's longest edge); inverted tets are
// re-oriented, unused vertices dropped (indices remapped). `source` names the file in messages,
// cells are counted from 0 as they were read. Throws InputError.
void finalize_tet_mesh(TetMesh& mesh, const std::string& source, MeshLoadReport& report);

// A box [min, max] split into cells[0] x cells[1] x cells[2] hexahedra, each cut into 5 or 6
// tets (5: alternating orientation so faces match; 6: Kuhn split around the main diagonal).
// Dimensions and counts are exact. Throws InputError on non-positive sizes or counts.
TetMesh make_box_mesh(const Vec3d& min, const Vec3d& max, const std::array<int, 3>& cells,
                      int tets_per_cell = 6);

// Uniform scaling about the origin, then translation (scene "scale" and "translate").
void transform_mesh(TetMesh& mesh, double scale, const Vec3d& translate);

// Reorders nodes and tets for memory locality (nodes along a 3D Hilbert curve through their
// positions, tets by their smallest new corner indices; ties keep their order, so the result is
// deterministic). The corners of each tet keep their order (and orientation). Returns the node map:
// old_to_new[old index] = new index. Expects valid indices (e.g. a finalized mesh).
// build_mesh() applies it to meshes from files and from CGAL; box meshes are already in grid
// order and are left alone.
std::vector<std::int32_t> renumber_for_locality(TetMesh& mesh);

// The same mesh with its nodes and tets in a random order drawn from `seed` (a stand-in for a
// mesher's or file's order, for tests and benchmarks of renumbering). Corner order is kept.
TetMesh shuffled_order(const TetMesh& mesh, std::uint64_t seed);

}  // namespace pliant
