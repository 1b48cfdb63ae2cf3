// Static obstacles (WorldDef::obstacles) as a level sees them: the per-node impulse record and
// the check, when a body is added, that none of its free nodes starts inside one (the pass would
// throw it out of the solid in one step, a violent start no scene means). The pass itself is
// kernels/obstacle_passes.hpp, run by Simulation::step.
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "simulation.hpp"

namespace pliant::detail {

template <class T>
void prepare_obstacles(Level<T>& L, const std::vector<ObstacleDef>& obstacles, const std::string& body,
                       const Vec3d& origin) {
  if (obstacles.empty()) return;
  for (auto& a : L.obstacle_impulse) a.assign(L.node_count, 0.0);
  // Tolerance: 1e-9 of the body's size, as for regions (a body placed exactly on the plane is on it).
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t n = 0; n < L.node_count; ++n)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(L.x[k][n]));
      hi[k] = std::max(hi[k], double(L.x[k][n]));
    }
  const double size = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const ObstacleDef& o = obstacles[i];
    double worst = 0;
    std::size_t node = 0;
    for (std::size_t n = 0; n < L.node_count; ++n) {
      if (L.state[n] != kNodeFree) continue;
      double d = 0;
      for (int k = 0; k < 3; ++k) d += o.normal[k] * (origin[k] + double(L.x[k][n]) - o.point[k]);
      if (d < worst) {
        worst = d;
        node = n;
      }
    }
    if (worst < -1e-9 * size)
      throw InputError(fmt::format(
          "body '{}' starts inside obstacles[{}] (the solid side of the plane through [{}, {}, {}] with normal "
          "[{:.6g}, {:.6g}, {:.6g}]): node {} at [{:.6g}, {:.6g}, {:.6g}] is {:.4g} m into it; move the body (mesh.translate) "
          "or the plane",
          body, i, o.point[0], o.point[1], o.point[2], o.normal[0], o.normal[1], o.normal[2], node,
          origin[0] + double(L.x[0][node]), origin[1] + double(L.x[1][node]), origin[2] + double(L.x[2][node]), -worst));
  }
}

template void prepare_obstacles<float>(Level<float>&, const std::vector<ObstacleDef>&, const std::string&, const Vec3d&);
template void prepare_obstacles<double>(Level<double>&, const std::vector<ObstacleDef>&, const std::string&, const Vec3d&);

}  // namespace pliant::detail
