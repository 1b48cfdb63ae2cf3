// weight_compliance and scale_stiffness (calibration.hpp).
#include "calibration.hpp"

#include <cmath>

#include "../core/rest_stiffness.hpp"

namespace pliant::detail {

namespace {

// Solves K u = f on the degrees of freedom of mass > 0 (the others held at 0) by conjugate
// gradients preconditioned with M^-1 (the diagonal of K scales like the lumped masses), from u = 0.
// Returns the iterations taken (kMaxIterations if it did not converge).
template <class T>
int solve(RestStiffness<T>& K, const std::vector<double>& mass, const std::vector<double>& f, std::vector<double>& u) {
  constexpr int kMaxIterations = 20000;
  constexpr double kTolerance = 1e-8;  // residual over load (2-norms)
  const std::size_t nn = mass.size(), n = 3 * nn;
  auto dot = [&](const std::vector<double>& a, const std::vector<double>& b) {  // fixed order
    double s = 0;
    for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
  };
  std::vector<double> r = f, z(n), p(n), kp(n);
  u.assign(n, 0.0);
  auto precondition = [&] {
    for (std::size_t i = 0; i < nn; ++i)
      for (std::size_t k = 0; k < 3; ++k) z[3 * i + k] = mass[i] > 0 ? r[3 * i + k] / mass[i] : 0.0;
  };
  const double f_norm = std::sqrt(dot(f, f));
  precondition();
  p = z;
  double rz = dot(r, z);
  int it = 0;
  for (; it < kMaxIterations && std::sqrt(dot(r, r)) > kTolerance * f_norm; ++it) {
    K.apply(p, kp);
    for (std::size_t i = 0; i < nn; ++i)
      if (mass[i] == 0)
        for (std::size_t k = 0; k < 3; ++k) kp[3 * i + k] = 0.0;  // fixed (or inactive) degrees of freedom
    const double a = rz / dot(p, kp);
    for (std::size_t j = 0; j < n; ++j) {
      u[j] += a * p[j];
      r[j] -= a * kp[j];
    }
    precondition();
    const double rz_new = dot(r, z);
    for (std::size_t j = 0; j < n; ++j) p[j] = z[j] + (rz_new / rz) * p[j];
    rz = rz_new;
  }
  return it;
}

}  // namespace

template <class T>
Compliance weight_compliance(Executor& exec, Level<T>& L) {
  const std::size_t nn = L.node_count, n = 3 * nn;
  Compliance c;
  std::vector<double> mass(nn, 0.0);
  std::size_t fixed = 0;
  for (std::size_t i = 0; i < nn; ++i) {
    if (L.state[i] == kNodeFree) mass[i] = double(L.mass[i]);
    fixed += L.state[i] == kNodeFixed;
  }
  if (fixed == 0) return c;
  RestStiffness<T> K(exec, L);
  constexpr int kInverseIterations = 4;  // from the static deflection, already close to the mode
  std::vector<double> f(n), u;
  c.converged = true;
  for (std::size_t axis = 0; axis < 3; ++axis) {
    // Own weight along the axis (unit acceleration): f_i = m_i e_axis; then inverse iteration,
    // f = M u, toward the lowest mode that the weight excites; omega^2 = u.f / u.M u of the last
    // solution (its Rayleigh quotient: u.K u = u.f).
    for (std::size_t i = 0; i < nn; ++i)
      for (std::size_t k = 0; k < 3; ++k) f[3 * i + k] = k == axis ? mass[i] : 0.0;
    for (int pass = 0; pass <= kInverseIterations; ++pass) {
      const int it = solve(K, mass, f, u);
      c.iterations += it;
      c.converged &= it < 20000;
      double work = 0, inertia = 0, scale = 0;
      for (std::size_t j = 0; j < n; ++j) {
        work += u[j] * f[j];
        inertia += mass[j / 3] * u[j] * u[j];
        scale = std::max(scale, std::fabs(u[j]));
      }
      c.omega2[axis] = inertia > 0 ? work / inertia : 0.0;
      if (!(scale > 0)) break;
      for (std::size_t j = 0; j < n; ++j) f[j] = mass[j / 3] * u[j] / scale;
    }
  }
  return c;
}

template <class T>
void scale_stiffness(Executor& exec, Level<T>& L, const MaterialDef& material, double factor, double courant) {
  L.lambda = T(double(L.lambda) * factor);
  L.mu = T(double(L.mu) * factor);
  L.young = T(double(L.young) * factor);
  // A Rayleigh factor beta gives viscosities beta lambda, beta mu: they follow the moduli;
  // viscosities given as such stay (they are the material's, not the mesh's).
  if (!material.damping.bulk_viscosity) L.bulk_viscosity = T(double(L.bulk_viscosity) * factor);
  if (!material.damping.shear_viscosity) L.shear_viscosity = T(double(L.shear_viscosity) * factor);
  MaterialDef scaled = material;
  scaled.young = material.young * factor;
  L.omega_geometric *= std::sqrt(factor);
  L.omega_measured = highest_frequency(exec, L, kFrequencyIterations);
  L.omega_max = std::max(L.omega_geometric, L.omega_measured / kFrequencyMargin);
  L.stable_dt = stable_step_for(L.omega_max, scaled, L.model, courant);
}

template Compliance weight_compliance<float>(Executor&, Level<float>&);
template Compliance weight_compliance<double>(Executor&, Level<double>&);
template void scale_stiffness<float>(Executor&, Level<float>&, const MaterialDef&, double, double);
template void scale_stiffness<double>(Executor&, Level<double>&, const MaterialDef&, double, double);

}  // namespace pliant::detail
