// Ghost refresh, impulse gather and the impulse-taking integrator (multilevel_passes.hpp).
#include "pliant/kernels/multilevel_passes.hpp"

#include <cstddef>

namespace pliant {

template <class T>
void refresh_ghosts(const GhostContext<T>& c, Range r) {
  for (std::size_t i = r.begin; i < r.end; ++i) {
    double x[3] = {0, 0, 0}, v[3] = {0, 0, 0};
    for (std::int32_t e = c.offsets[i]; e < c.offsets[i + 1]; ++e) {
      const std::int32_t l = c.source_level[e], n = c.source_node[e];
      const double w = c.weight[e];
      for (int k = 0; k < 3; ++k) {
        x[k] += w * double(c.source_x[l][k][n]);
        v[k] += w * double(c.source_v[l][k][n]);
      }
    }
    const std::int32_t g = c.ghosts[i];
    for (int k = 0; k < 3; ++k) {
      c.x[k][g] = T(x[k]);
      c.v[k][g] = T(v[k]);
    }
  }
}

template <class T>
void receive_ghost_impulses(const ReceiveContext<T>& c, Range r) {
  for (std::size_t i = r.begin; i < r.end; ++i) {
    double j[3] = {0, 0, 0};
    bool any = false;
    for (std::int32_t e = c.offsets[i]; e < c.offsets[i + 1]; ++e) {
      const std::int32_t l = c.ghost_level[e];
      if (c.ghost_dt[l] == T(0)) continue;  // that level's window has not ended
      any = true;
      const double s = c.weight[e] * double(c.ghost_dt[l]);
      const std::int32_t g = c.ghost_node[e];
      for (int k = 0; k < 3; ++k) j[k] += s * double(c.ghost_f[l][k][g]);
    }
    if (!any) continue;
    const std::int32_t n = c.receivers[i];
    for (int k = 0; k < 3; ++k) c.impulse[k][n] += T(j[k]);
  }
}

template <class T>
bool integrate_symplectic_euler_impulse(const IntegrateContext<T>& c, T* const impulse[3], Range r) {
  bool finite = true;
  const T dt = c.dt;
  for (std::size_t n = r.begin; n < r.end; ++n) {
    if (c.state[n] != kNodeFree) {  // fixed nodes take no impulse (it is their reaction)
      for (int k = 0; k < 3; ++k) impulse[k][n] = T(0);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const T v0 = c.v[k][n] + impulse[k][n] * c.inv_mass[n];
      impulse[k][n] = T(0);
      const T a = c.f[k][n] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * v0;
      const T v = v0 + dt * a;
      const T x = c.x[k][n] + dt * v;
      c.v[k][n] = v;
      c.x[k][n] = x;
      finite &= within_bounds(x, v);
    }
  }
  return finite;
}

template void refresh_ghosts<float>(const GhostContext<float>&, Range);
template void refresh_ghosts<double>(const GhostContext<double>&, Range);
template void receive_ghost_impulses<float>(const ReceiveContext<float>&, Range);
template void receive_ghost_impulses<double>(const ReceiveContext<double>&, Range);
template bool integrate_symplectic_euler_impulse<float>(const IntegrateContext<float>&, float* const[3], Range);
template bool integrate_symplectic_euler_impulse<double>(const IntegrateContext<double>&, double* const[3], Range);

}  // namespace pliant
