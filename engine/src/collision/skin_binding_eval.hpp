// skin_vertex (skin_binding.hpp): the triangle's current frame applied to the stored offset.
#pragma once
#include <cmath>

#include "closest_points.hpp"

namespace pliant::detail {

// The orthonormal frame of a triangle: e1 along its first edge, n its unit normal, e2 = n x e1.
inline void triangle_frame(const P3& a, const P3& b, const P3& c, P3& e1, P3& e2, P3& n) {
  e1 = sub(b, a);
  n = cross(e1, sub(c, a));
  const double l1 = std::sqrt(norm2(e1)), ln = std::sqrt(norm2(n));
  e1 = l1 > 0 ? mul(e1, 1 / l1) : P3{1, 0, 0};
  n = ln > 0 ? mul(n, 1 / ln) : P3{0, 0, 1};
  e2 = cross(n, e1);
}

template <class At>
std::array<double, 3> skin_vertex(const SkinLevelBinding& b, std::size_t i, const At& at) {
  const auto& t = b.nodes[i];
  const P3 p0 = at(t[0]), p1 = at(t[1]), p2 = at(t[2]);
  P3 e1, e2, n;
  triangle_frame(p0, p1, p2, e1, e2, n);
  const auto& w = b.weights[i];
  const auto& o = b.offset[i];
  P3 x = add(add(mul(p0, w[0]), mul(p1, w[1])), mul(p2, w[2]));
  return add(x, add(add(mul(e1, o[0]), mul(e2, o[1])), mul(n, o[2])));
}

}  // namespace pliant::detail
