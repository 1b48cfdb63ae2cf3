// Procedural box meshes: the reference geometry of the physics tests (cantilever, bar, cube).
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant {
namespace {

// Cube corners are numbered i + 2 j + 4 k for (i, j, k) in {0,1}^3.
// 6 tets: the Kuhn split around the diagonal 0-7 (conforming under translation).
constexpr int kKuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
// 5 tets: a central tet and 4 corners; odd cells use the mirrored pattern so shared faces
// get the same diagonal.
constexpr int kFiveEven[5][4] = {{1, 2, 4, 7}, {0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}};
constexpr int kFiveOdd[5][4] = {{0, 3, 5, 6}, {1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}};

}  // namespace

TetMesh make_box_mesh(const Vec3d& min, const Vec3d& max, const std::array<int, 3>& cells, int tets_per_cell) {
  for (int a = 0; a < 3; ++a) {
    if (!(std::isfinite(min[a]) && std::isfinite(max[a]) && max[a] > min[a]))
      throw InputError(fmt::format("box mesh: max[{0}] must be greater than min[{0}] (got {1} and {2})", a, max[a], min[a]));
    if (cells[a] < 1) throw InputError(fmt::format("box mesh: cells[{}] must be at least 1, got {}", a, cells[a]));
  }
  if (tets_per_cell != 5 && tets_per_cell != 6)
    throw InputError(fmt::format("box mesh: tets_per_cell must be 5 or 6, got {}", tets_per_cell));
  const double total_cells = double(cells[0]) * cells[1] * cells[2];
  if (total_cells * tets_per_cell > 4e8) throw InputError("box mesh: more than 400 million tets requested");

  const int nx = cells[0], ny = cells[1], nz = cells[2];
  TetMesh mesh;
  mesh.points.reserve(3 * std::size_t(nx + 1) * (ny + 1) * (nz + 1));
  auto coord = [&](int axis, int i, int n) {  // exact at both ends
    return i == n ? max[axis] : min[axis] + (max[axis] - min[axis]) * (double(i) / n);
  };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        mesh.points.push_back(coord(0, i, nx));
        mesh.points.push_back(coord(1, j, ny));
        mesh.points.push_back(coord(2, k, nz));
      }
  auto node = [&](int i, int j, int k) { return std::int32_t(i + (nx + 1) * (j + (ny + 1) * k)); };
  mesh.tets.reserve(std::size_t(total_cells) * tets_per_cell);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        std::int32_t corner[8];
        for (int c = 0; c < 8; ++c) corner[c] = node(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        const bool odd = ((i + j + k) & 1) != 0;
        const int count = tets_per_cell;
        for (int t = 0; t < count; ++t) {
          const int* local = count == 6 ? kKuhn[t] : (odd ? kFiveOdd[t] : kFiveEven[t]);
          Tet tet{corner[local[0]], corner[local[1]], corner[local[2]], corner[local[3]]};
          if (signed_tet_volume(mesh.point(tet[0]), mesh.point(tet[1]), mesh.point(tet[2]), mesh.point(tet[3])) < 0)
            std::swap(tet[2], tet[3]);
          mesh.tets.push_back(tet);
        }
      }
  return mesh;
}

}  // namespace pliant
