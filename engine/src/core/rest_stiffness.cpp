// RestStiffness (rest_stiffness.hpp).
#include "rest_stiffness.hpp"

#include <algorithm>
#include <cmath>

namespace pliant::detail {

// The springs model linearised at rest (no tension there, so no geometric stiffness): each tet
// edge a-b of rest vector D adds k (D . (u_b - u_a)) D / |D|^2 to corner a and its opposite to b,
// k = E V / |D|^2, for the displacements u in c.x. Scalar, in double, into the corner forces.
template <class T>
void springs_linearised(const ElementContext<T>& c, Range r) {
  constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (std::size_t t = r.begin; t < r.end; ++t) {
    double f[4][3] = {};
    for (const auto& e : kEdges) {
      const std::int32_t a = c.tet[e[0]][t], b = c.tet[e[1]][t];
      double D[3], du[3];
      for (int k = 0; k < 3; ++k) {
        D[k] = double(c.X[k][b]) - double(c.X[k][a]);
        du[k] = double(c.x[k][b]) - double(c.x[k][a]);
      }
      const double L2 = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
      const double s = double(c.young) * double(c.volume[t]) / (L2 * L2) * (D[0] * du[0] + D[1] * du[1] + D[2] * du[2]);
      for (int k = 0; k < 3; ++k) {
        f[e[0]][k] += s * D[k];
        f[e[1]][k] -= s * D[k];
      }
    }
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) c.corner_force[3 * a + k][t] = T(f[a][k]);
  }
}

template <class T>
RestStiffness<T>::RestStiffness(Executor& exec, Level<T>& L) : exec_(exec), L_(L), springs_(L.model == ForceModel::springs) {
  const std::size_t nn = L.node_count;
  ec_ = element_context(L);
  ec_.bulk_viscosity = ec_.shear_viscosity = ec_.spring_damping = ec_.rayleigh = T(0);
  for (auto& r : ec_.rotation) r = nullptr;
  for (int k = 0; k < 3; ++k) {
    x_[k].assign(nn, T(0));
    f_[k].assign(nn, T(0));
    ec_.x[k] = x_[k].data();
    f0_[k].assign(nn, 0.0);
    fa_[k].assign(nn, 0.0);
  }
  gc_.offsets = L.incidence_offsets.data();
  gc_.incidence = L.incidence.data();
  for (int q = 0; q < 12; ++q) gc_.corner_force[q] = L.corner_force[q].data();
  for (int k = 0; k < 3; ++k) gc_.f[k] = f_[k].data();
  // The linear kernel is affine in the positions, f(x) = f(0) - K x: positions x = s u (no rest
  // positions, no cancellation) give K u = (f(0) - f(s u)) / s to rounding.
  if (!springs_) forces(f0_);
}

template <class T>
RestStiffness<T>::~RestStiffness() {
  for (auto& cf : L_.corner_force) std::fill(cf.begin(), cf.end(), T(0));
}

template <class T>
void RestStiffness<T>::forces(std::vector<double>* out) {
  const std::size_t nn = L_.node_count, nt = L_.tet_count;
  if (springs_)
    exec_.parallel_for(nt, pass_grain(nt, kTetGrain), [&](Range r) { springs_linearised(ec_, r); });
  else
    exec_.parallel_for(nt, pass_grain(nt, kTetGrain), [&](Range r) { element_forces_linear(ec_, r); });
  exec_.parallel_for(nn, pass_grain(nn, kNodeGrain), [&](Range r) { gather_forces(gc_, r); });
  for (int k = 0; k < 3; ++k)
    for (std::size_t i = 0; i < nn; ++i) out[k][i] = double(f_[k][i]);
}

template <class T>
void RestStiffness<T>::apply(const std::vector<double>& u, std::vector<double>& w) {
  const std::size_t nn = L_.node_count;
  double umax = 0;
  for (double v : u) umax = std::max(umax, std::fabs(v));
  w.assign(3 * nn, 0.0);
  if (!(umax > 0)) return;
  // Probing displacements of up to h_min: strains of order 1, so that the difference with f(0)
  // loses nothing to cancellation.
  const double h = L_.min_altitude > 0 ? L_.min_altitude : 1.0;
  const double s = h / umax;
  for (std::size_t i = 0; i < nn; ++i)
    for (int k = 0; k < 3; ++k) x_[k][i] = T(s * u[3 * i + std::size_t(k)]);
  forces(fa_);
  for (std::size_t i = 0; i < nn; ++i)
    for (int k = 0; k < 3; ++k) w[3 * i + std::size_t(k)] = (f0_[k][i] - fa_[k][i]) / s;
}

template class RestStiffness<float>;
template class RestStiffness<double>;

}  // namespace pliant::detail
