// Gather and integrate (see node_passes.hpp). Both are streaming loops over SoA node arrays;
// the gather reads corner forces indirectly through the CSR incidence.
#include "pliant/kernels/node_passes.hpp"

#include <cmath>

namespace pliant {

template <class T>
void gather_forces(const GatherContext<T>& c, Range r) {
  for (std::size_t n = r.begin; n < r.end; ++n) {
    T f0 = 0, f1 = 0, f2 = 0;
    for (std::int32_t e = c.offsets[n]; e < c.offsets[n + 1]; ++e) {
      const std::int32_t code = c.incidence[e];
      const std::int32_t t = code >> 2, corner = code & 3;
      f0 += c.corner_force[3 * corner + 0][t];
      f1 += c.corner_force[3 * corner + 1][t];
      f2 += c.corner_force[3 * corner + 2][t];
    }
    if (c.external[0]) {
      f0 += c.external[0][n];
      f1 += c.external[1][n];
      f2 += c.external[2][n];
    }
    c.f[0][n] = f0;
    c.f[1][n] = f1;
    c.f[2][n] = f2;
  }
}

template <class T>
bool integrate_symplectic_euler(const IntegrateContext<T>& c, Range r) {
  bool finite = true;
  const T dt = c.dt;
  for (std::size_t n = r.begin; n < r.end; ++n) {
    if (c.state[n] != kNodeFree) continue;
    for (int k = 0; k < 3; ++k) {
      const T a = c.f[k][n] * c.inv_mass[n] + c.gravity[k] - c.mass_damping * c.v[k][n];
      const T v = c.v[k][n] + dt * a;
      const T x = c.x[k][n] + dt * v;
      c.v[k][n] = v;
      c.x[k][n] = x;
      finite &= std::isfinite(x) & std::isfinite(v);
    }
  }
  return finite;
}

template void gather_forces<float>(const GatherContext<float>&, Range);
template void gather_forces<double>(const GatherContext<double>&, Range);
template bool integrate_symplectic_euler<float>(const IntegrateContext<float>&, Range);
template bool integrate_symplectic_euler<double>(const IntegrateContext<double>&, Range);

}  // namespace pliant
