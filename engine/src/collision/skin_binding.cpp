// Binding a skin to a level (skin_binding.hpp).
#include "skin_binding.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/scheduler/executor.hpp"
#include "surface_bvh.hpp"

namespace pliant::detail {

template <class T>
SkinLevelBinding bind_skin(const std::vector<double>& skin, const Level<T>& L, Executor& exec) {
  SkinLevelBinding b;
  if (L.boundary.empty()) throw InputError("a skin needs a body with a boundary");
  auto rest = [&](std::int32_t n) {
    return P3{double(L.X[0][std::size_t(n)]), double(L.X[1][std::size_t(n)]), double(L.X[2][std::size_t(n)])};
  };
  // The BVH over the rest boundary (nodes indexed directly: unused nodes sit at their rest place).
  EmbreeDevice device;
  SurfaceBvh bvh(device, L.boundary, L.node_count);
  float* v = bvh.vertices();
  for (std::size_t n = 0; n < L.node_count; ++n)
    for (int k = 0; k < 3; ++k) v[4 * n + std::size_t(k)] = float(L.X[k][n]);
  std::string error;
  if (!bvh.refit(exec, error)) throw InputError("binding a skin: " + error);
  double edges = 0;
  for (const auto& t : L.boundary) edges += std::sqrt(norm2(sub(rest(t[0]), rest(t[1]))));
  const double start = std::max(edges / double(L.boundary.size()), 1e-12);
  const std::size_t count = skin.size() / 3;
  b.nodes.resize(count);
  b.weights.resize(count);
  b.offset.resize(count);
  std::vector<std::uint32_t> near;
  for (std::size_t i = 0; i < count; ++i) {
    const P3 p{skin[3 * i], skin[3 * i + 1], skin[3 * i + 2]};
    const float centre[3] = {float(p[0]), float(p[1]), float(p[2])};
    double best = 1e300;
    std::uint32_t best_t = 0;
    TrianglePoint best_point;
    // Balls of doubling radius until one holds a triangle within its radius (the nearest
    // triangle is then among those it returned).
    for (double radius = start;; radius *= 2) {
      bvh.triangles_near(centre, float(radius * (1 + 1e-5)), near);
      for (std::uint32_t t : near) {
        const auto& tri = L.boundary[t];
        const TrianglePoint q = closest_on_triangle(p, rest(tri[0]), rest(tri[1]), rest(tri[2]));
        const double d2 = norm2(sub(p, q.point));
        if (d2 < best) {
          best = d2;
          best_t = t;
          best_point = q;
        }
      }
      if (best <= radius * radius || radius > 1e12) break;
    }
    const auto& tri = L.boundary[best_t];
    P3 e1, e2, n;
    triangle_frame(rest(tri[0]), rest(tri[1]), rest(tri[2]), e1, e2, n);
    const P3 d = sub(p, best_point.point);
    b.nodes[i] = tri;
    b.weights[i] = best_point.w;
    b.offset[i] = {dot(d, e1), dot(d, e2), dot(d, n)};
    b.max_distance = std::max(b.max_distance, std::sqrt(best));
  }
  return b;
}

template SkinLevelBinding bind_skin<float>(const std::vector<double>&, const Level<float>&, Executor&);
template SkinLevelBinding bind_skin<double>(const std::vector<double>&, const Level<double>&, Executor&);

}  // namespace pliant::detail
