// The stable step of a level: the highest angular frequency of its linearised, undamped
// dynamics at rest, estimated at load by a Lanczos iteration on M^-1 K, and the step of the
// explicit integrator for it (tightened by damping). See docs/architecture.md, "Time step".
//
// Why: the classic estimate omega_max ~ 2 c_p / h_min (h_min the smallest tet altitude) is not a
// bound. On Kuhn (6-tet) box meshes the highest mode is up to 22% above it, so a 20x1x1 bar at
// Courant number 0.9 diverged; on meshes from files it can be further off, and it knows nothing
// of the springs model's own stiffness. The Lanczos estimate measures the mesh, material and
// model at hand; the step keeps the smaller of the two.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "pliant/level_passes.hpp"
#include "rest_stiffness.hpp"
#include "simulation.hpp"

namespace pliant::detail {
namespace {

std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Largest eigenvalue of the symmetric tridiagonal matrix (diagonal a, off-diagonal b) by
// bisection on the Sturm sequence count: deterministic and accurate to rounding.
double tridiagonal_max_eigenvalue(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t n = a.size();
  double lo = 1e300, hi = -1e300;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = (i > 0 ? std::fabs(b[i - 1]) : 0.0) + (i + 1 < n ? std::fabs(b[i]) : 0.0);
    lo = std::min(lo, a[i] - r);
    hi = std::max(hi, a[i] + r);
  }
  // count(x): number of eigenvalues below x.
  auto count = [&](double x) {
    int c = 0;
    double d = 1;
    for (std::size_t i = 0; i < n; ++i) {
      const double off = i > 0 ? b[i - 1] * b[i - 1] : 0.0;
      d = a[i] - x - (i > 0 ? off / d : 0.0);
      if (d == 0) d = -1e-300 * (1 + std::fabs(x));
      if (d < 0) ++c;
    }
    return c;
  };
  for (int it = 0; it < 200 && hi - lo > 1e-15 * std::max(std::fabs(lo), std::fabs(hi)); ++it) {
    const double mid = 0.5 * (lo + hi);
    if (count(mid) >= int(n))
      hi = mid;
    else
      lo = mid;
  }
  return hi;
}

}  // namespace

double geometric_frequency(double h_min, const MaterialDef& m) {
  const double lambda = m.young * m.poisson / ((1 + m.poisson) * (1 - 2 * m.poisson));
  const double mu = m.young / (2 * (1 + m.poisson));
  return 2.0 * std::sqrt((lambda + 2 * mu) / m.density) / h_min;
}

double stable_step_for(double omega_max, const MaterialDef& m, ForceModel model, double courant) {
  const double lambda = m.young * m.poisson / ((1 + m.poisson) * (1 - 2 * m.poisson));
  const double mu = m.young / (2 * (1 + m.poisson));
  // Damping ratio of the highest mode, zeta = beta omega / 2 + alpha / (2 omega), with beta the
  // largest damping-to-stiffness ratio over the element's modes (docs/architecture.md, "Time
  // step", for the derivation): split a strain into its volumetric and deviatoric parts; the
  // elastic energy density is (lambda + 2 mu / 3) tr(e)^2 + 2 mu |dev e|^2, the viscous one
  // (phi + 2 psi / 3) tr(e)^2 + 2 psi |dev e|^2, so their ratio is at most
  // max((3 phi + 2 psi) / (3 lambda + 2 mu), psi / mu), reached by a pure volume change or a pure
  // shear. The former beta = (phi + 2 psi) / (lambda + 2 mu) is that ratio for a uniaxial strain
  // only, below the maximum unless phi / lambda = psi / mu: bulk viscosity alone at Courant
  // number 1 diverged (tests/core/test_damped_step.cpp). Springs: beta itself (their dashpots are
  // beta times each spring's stiffness).
  double phi = m.damping.stiffness * lambda, psi = m.damping.stiffness * mu;
  if (m.damping.bulk_viscosity) phi = *m.damping.bulk_viscosity;
  if (m.damping.shear_viscosity) psi = *m.damping.shear_viscosity;
  double beta = std::max((3 * phi + 2 * psi) / (3 * lambda + 2 * mu), psi / mu);
  if (model == ForceModel::springs) beta = m.damping.stiffness;
  const double zeta = 0.5 * beta * omega_max + m.damping.mass / (2 * omega_max);
  // Symplectic Euler on x'' = -omega^2 x - 2 zeta omega x' (velocity terms at the old velocity)
  // is stable iff (omega dt)^2 + 4 zeta (omega dt) <= 4, i.e. dt <= (2/omega)(sqrt(1+z^2) - z);
  // the left side grows with omega, so the highest mode sets the step.
  // For a highest mode damped far beyond critical the difference cancels (about 8 digits lost at
  // zeta = 1e4, all of them at 1e8: damping.mass = 1e12 1/s gave a step of 0 s, or one off by
  // orders of magnitude); there it is computed as the same number 1 / (sqrt(1+z^2) + z). Below,
  // as it always was (the same bits for every scene that was ever run).
  constexpr double kCancels = 1e4;
  const double root = std::sqrt(1 + zeta * zeta);
  return courant * (2.0 / omega_max) * (zeta > kCancels ? 1 / (root + zeta) : root - zeta);
}

double courant_time_step(double h_min, const MaterialDef& m, ForceModel model, double courant) {
  return stable_step_for(geometric_frequency(h_min, m), m, model, courant);
}

template <class T>
double highest_frequency(Executor& exec, Level<T>& L, int iterations) {
  const std::size_t nn = L.node_count, nt = L.tet_count;
  // Free degrees of freedom only: fixed and prescribed nodes do not move under the integrator.
  std::vector<double> sqrt_inv_mass(nn);
  std::size_t free_nodes = 0;
  for (std::size_t i = 0; i < nn; ++i) {
    const double im = L.state[i] == kNodeFree ? double(L.inv_mass[i]) : 0.0;
    sqrt_inv_mass[i] = std::sqrt(im);
    free_nodes += im > 0;
  }
  if (free_nodes == 0 || nt == 0) return 0;

  // A q for A = M^-1/2 K M^-1/2 (symmetric; its eigenvalues are omega^2), K applied by
  // RestStiffness (the level's own kernel linearised at rest).
  RestStiffness<T> stiffness(exec, L);
  const std::size_t n = 3 * nn;
  std::vector<double> u(n), ku(n);
  auto apply = [&](const std::vector<double>& q, std::vector<double>& w) {
    for (std::size_t i = 0; i < nn; ++i)
      for (int k = 0; k < 3; ++k) u[3 * i + std::size_t(k)] = sqrt_inv_mass[i] * q[3 * i + std::size_t(k)];
    stiffness.apply(u, ku);
    for (std::size_t i = 0; i < nn; ++i)
      for (int k = 0; k < 3; ++k) w[3 * i + std::size_t(k)] = sqrt_inv_mass[i] * ku[3 * i + std::size_t(k)];
  };
  auto dot = [&](const std::vector<double>& a, const std::vector<double>& b) {  // fixed order
    double s = 0;
    for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
  };

  // Lanczos from a fixed pseudo-random start: the largest Ritz value approaches the largest
  // eigenvalue from below, much faster than the power iteration's Rayleigh quotient when the
  // top of the spectrum is dense (large meshes). The start is a function of each node's rest
  // position, not of its index, so that a renumbered mesh gets the same step (to rounding).
  std::vector<double> q(n), q_prev(n, 0.0), w(n);
  for (std::size_t i = 0; i < nn; ++i) {
    std::uint64_t h = 0x243F6A8885A308D3ull;
    for (int k = 0; k < 3; ++k) {
      const double c = double(L.X[k][i]) + 0.0;  // + 0.0: -0 and +0 hash alike
      std::uint64_t bits;
      std::memcpy(&bits, &c, sizeof bits);
      h = mix64(h ^ bits);
    }
    for (int k = 0; k < 3; ++k) {
      const double r = double(mix64(h + 0x9E3779B97F4A7C15ull * std::uint64_t(k + 1)) >> 11) * 0x1.0p-53;
      q[3 * i + k] = sqrt_inv_mass[i] > 0 ? 2 * r - 1 : 0.0;
    }
  }
  const double norm0 = std::sqrt(dot(q, q));
  for (double& e : q) e /= norm0;
  std::vector<double> alpha, beta;
  double beta_prev = 0;
  for (int it = 0; it < iterations; ++it) {
    apply(q, w);
    const double a = dot(w, q);
    for (std::size_t i = 0; i < n; ++i) w[i] -= a * q[i] + beta_prev * q_prev[i];
    const double c = dot(w, q);  // one pass of local re-orthogonalisation
    for (std::size_t i = 0; i < n; ++i) w[i] -= c * q[i];
    alpha.push_back(a + c);
    const double b = std::sqrt(dot(w, w));
    if (!(b > 1e-10 * std::fabs(alpha.back())) || it + 1 == iterations) break;  // invariant subspace
    beta.push_back(b);
    beta_prev = b;
    q_prev.swap(q);
    for (std::size_t i = 0; i < n; ++i) q[i] = w[i] / b;
  }
  beta.resize(alpha.size() > 0 ? alpha.size() - 1 : 0);
  const double lambda_max = tridiagonal_max_eigenvalue(alpha, beta);
  return lambda_max > 0 && std::isfinite(lambda_max) ? std::sqrt(lambda_max) : 0.0;
}

template double highest_frequency<float>(Executor&, Level<float>&, int);
template double highest_frequency<double>(Executor&, Level<double>&, int);

}  // namespace pliant::detail
