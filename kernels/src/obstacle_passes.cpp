// The half-space obstacle pass (see obstacle_passes.hpp). Most nodes are on the free side and
// cost a dot product; the few in contact take the branch.
#include "pliant/kernels/obstacle_passes.hpp"

#include <cmath>

#include "pliant/kernels/node_passes.hpp"

namespace pliant {

template <class T>
void resolve_half_space(const HalfSpaceContext<T>& c, Range r) {
  const T n0 = c.normal[0], n1 = c.normal[1], n2 = c.normal[2];
  const T p0 = c.point[0], p1 = c.point[1], p2 = c.point[2];
  for (std::size_t i = r.begin; i < r.end; ++i) {
    if (c.state[i] != kNodeFree) continue;
    const T d = n0 * (c.x[0][i] - p0) + n1 * (c.x[1][i] - p1) + n2 * (c.x[2][i] - p2);  // m
    if (!(d < 0)) continue;  // free side (or NaN: the divergence check reports it)
    c.x[0][i] -= d * n0;
    c.x[1][i] -= d * n1;
    c.x[2][i] -= d * n2;
    const T v0 = c.v[0][i], v1 = c.v[1][i], v2 = c.v[2][i];
    const T vn = n0 * v0 + n1 * v1 + n2 * v2;  // m/s, < 0: into the solid
    if (!(vn < 0)) continue;
    T w0 = v0 - vn * n0, w1 = v1 - vn * n1, w2 = v2 - vn * n2;  // tangential velocity
    if (c.friction > 0) {
      const T wt = std::sqrt(w0 * w0 + w1 * w1 + w2 * w2);
      const T slip = c.friction * -vn;  // the most friction can take off the tangential speed
      const T keep = wt > slip ? (wt - slip) / wt : T(0);
      w0 *= keep;
      w1 *= keep;
      w2 *= keep;
    }
    c.v[0][i] = w0;
    c.v[1][i] = w1;
    c.v[2][i] = w2;
    if (c.impulse[0]) {
      const double m = double(c.mass[i]);
      c.impulse[0][i] += m * (double(w0) - double(v0));
      c.impulse[1][i] += m * (double(w1) - double(v1));
      c.impulse[2][i] += m * (double(w2) - double(v2));
    }
  }
}

template void resolve_half_space<float>(const HalfSpaceContext<float>&, Range);
template void resolve_half_space<double>(const HalfSpaceContext<double>&, Range);

}  // namespace pliant
