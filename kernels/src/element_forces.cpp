// The per-tet force and energy kernels of every force model (see element_forces.hpp): the force
// passes over ranges of tets (their batch functions are in element_batches.hpp, shared with the
// passes over lists, element_forces_listed.cpp), and the energy and stress reports, which stay
// scalar. The force passes run a vector register's worth of tets at a time (16 floats or 8 doubles
// with AVX-512, 8/4 with AVX2, 4/2 with SSE2), one tet per lane: the same bits as one tet at a
// time, on any ISA and range split (tests/kernels/test_kernel_batches.cpp).
#include "pliant/kernels/element_forces.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "element_batches.hpp"
#include "tet_local.hpp"

namespace pliant {
using detail::Mat3;
using detail::TetLocal;

namespace {

// Corotated strain R^T F - I. Only the force pass stores the refined rotation (keep = true):
// energy and stress reports work on a copy, so measuring never changes the trajectory.
template <class T>
Mat3<T> corotational_strain(const ElementContext<T>& c, std::size_t t, const Mat3<T>& F, Mat3<T>& R, bool keep) {
  T q[4] = {c.rotation[0][t], c.rotation[1][t], c.rotation[2][t], c.rotation[3][t]};
  R = detail::extract_rotation(F, q);
  if (keep)
    for (int k = 0; k < 4; ++k) c.rotation[k][t] = q[k];
  Mat3<T> eps = detail::sym(detail::mul_tn(R, F));  // S = R^T F, symmetric at the exact polar R
  for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
  return eps;
}

template <class Model, class T>
void forces(const ElementContext<T>& c, Range r, detail::Damping d) {
  using detail::Damping;
  switch (d) {
    case Damping::none: return detail::range_pass<Model, T, Damping::none>(c, r);
    case Damping::viscous: return detail::range_pass<Model, T, Damping::viscous>(c, r);
    case Damping::rayleigh: return detail::rayleigh_range_pass<Model, T>(c, r);
  }
}

}  // namespace

template <class T>
bool packed_corners_pay() {
  // perf/layout_ab packed, docs/performance.md "Data layout": AVX2 (AMD EPYC Zen 3) float
  // 0.75-0.85x the time, double 0.87-0.94x. AVX-512 (Xeon, 2026-11-29) float 1.06-1.27x, double
  // 0.93-1.07x: its gathers are cheaper than the transpose's shuffles there (the header says why).
  // SSE builds keep the gathers.
  return simd::kNativeBytes == 32;
}

template <class T>
bool packed_velocities_pay() {
  // AVX2 (Zen 3): the damped pass 0.85-0.89x (float) and 0.89-0.94x (double) of the pass with
  // positions packed only; AVX-512 (Xeon, before the copy fix): float 0.93-1.02x, dropped.
  return simd::kNativeBytes == 32;
}

template <class T>
T rayleigh_factor(T lambda, T mu, T phi, T psi) {
  if (!(mu > T(0)) || !(psi > T(0)) || !(lambda >= T(0)) || !(phi >= T(0))) return T(0);
  const T beta = psi / mu;
  const T want = beta * lambda;  // phi if proportional (0 when lambda = 0: nu = 0)
  const T tolerance = T(8) * std::numeric_limits<T>::epsilon() * std::max(phi, want);
  return std::abs(phi - want) <= tolerance ? beta : T(0);
}

template <class T>
void element_forces_linear(const ElementContext<T>& c, Range r) {
  forces<detail::Linear>(c, r, detail::damping_of(c));
}
template <class T>
void element_forces_stvk(const ElementContext<T>& c, Range r) {
  forces<detail::Stvk>(c, r, detail::damping_of(c));
}
template <class T>
void element_forces_corotational(const ElementContext<T>& c, Range r) {
  forces<detail::Corotational>(c, r, detail::damping_of(c));
}
template <class T>
void element_forces_springs(const ElementContext<T>& c, Range r) {
  forces<detail::Springs>(c, r, c.spring_damping != T(0) ? detail::Damping::viscous : detail::Damping::none);
}

// ---- energies -------------------------------------------------------------------------------
template <class T>
void element_energy_linear(const ElementContext<T>& c, Range r, double* energy) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    Mat3<T> eps = detail::sym(detail::corner_gradient(e.x, e.g));
    for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
    const double tr = detail::trace(eps);
    energy[t] = double(e.volume) * (double(c.mu) * double(detail::ddot(eps, eps)) + 0.5 * double(c.lambda) * tr * tr);
  }
}

template <class T>
void element_energy_stvk(const ElementContext<T>& c, Range r, double* energy) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    Mat3<T> E = detail::sym(detail::mul_tn(F, F));
    for (int i = 0; i < 3; ++i) E.m[i][i] -= T(1);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) E.m[i][j] *= T(0.5);
    const double tr = detail::trace(E);
    energy[t] = double(e.volume) * (double(c.mu) * double(detail::ddot(E, E)) + 0.5 * double(c.lambda) * tr * tr);
  }
}

template <class T>
void element_energy_corotational_scalar(const ElementContext<T>& c, Range r, double* energy) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    Mat3<T> R;
    const Mat3<T> eps = corotational_strain(c, t, F, R, false);
    const double tr = detail::trace(eps);
    energy[t] = double(e.volume) * (double(c.mu) * double(detail::ddot(eps, eps)) + 0.5 * double(c.lambda) * tr * tr);
  }
}

template <class T>
void element_energy_springs(const ElementContext<T>& c, Range r, double* energy) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    double sum = 0;
    for (const auto& edge : detail::kEdges) {
      const std::int32_t a = c.tet[edge[0]][t], b = c.tet[edge[1]][t];
      double l2 = 0, L2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(c.x[k][b]) - double(c.x[k][a]);
        const double D = double(c.X[k][b]) - double(c.X[k][a]);
        l2 += d * d;
        L2 += D * D;
      }
      const double stretch = std::sqrt(l2) - std::sqrt(L2);
      sum += 0.5 * double(c.young) * double(c.volume[t]) / L2 * stretch * stretch;
    }
    energy[t] = sum;
  }
}

// ---- stress for output ----------------------------------------------------------------------
template <class T>
void element_cauchy_stress(const ElementContext<T>& c, Range r, int measure, double* sigma9) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    Mat3<T> sigma;
    if (measure == 1) {
      Mat3<T> E = detail::sym(detail::mul_tn(F, F));
      for (int i = 0; i < 3; ++i) E.m[i][i] -= T(1);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) E.m[i][j] *= T(0.5);
      const Mat3<T> S = detail::hooke(E, c.lambda, c.mu);
      const Mat3<T> FS = detail::mul(F, S);
      const T J = F.m[0][0] * (F.m[1][1] * F.m[2][2] - F.m[1][2] * F.m[2][1]) -
                  F.m[0][1] * (F.m[1][0] * F.m[2][2] - F.m[1][2] * F.m[2][0]) +
                  F.m[0][2] * (F.m[1][0] * F.m[2][1] - F.m[1][1] * F.m[2][0]);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          sigma.m[i][j] = (FS.m[i][0] * F.m[j][0] + FS.m[i][1] * F.m[j][1] + FS.m[i][2] * F.m[j][2]) / J;
    } else if (measure == 2) {
      Mat3<T> R;
      const Mat3<T> s_rot = detail::hooke(corotational_strain(c, t, F, R, false), c.lambda, c.mu);
      const Mat3<T> Rs = detail::mul(R, s_rot);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          sigma.m[i][j] = Rs.m[i][0] * R.m[j][0] + Rs.m[i][1] * R.m[j][1] + Rs.m[i][2] * R.m[j][2];
    } else {
      Mat3<T> eps = detail::sym(F);
      for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
      sigma = detail::hooke(eps, c.lambda, c.mu);
    }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) sigma9[9 * t + 3 * i + j] = double(sigma.m[i][j]);
  }
}

// ---- rest geometry --------------------------------------------------------------------------
bool tet_rest_geometry(const double a[3], const double b[3], const double c[3], const double d[3], double* volume,
                       double grad[9]) {
  // Dm = [b-a, c-a, d-a] (columns); grad rows = rows of Dm^-1.
  double m[3][3];
  for (int i = 0; i < 3; ++i) {
    m[i][0] = b[i] - a[i];
    m[i][1] = c[i] - a[i];
    m[i][2] = d[i] - a[i];
  }
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  *volume = det / 6.0;
  if (!(det > 0) || !std::isfinite(det)) return false;
  const double inv = 1.0 / det;
  // Inverse by cofactors: inv(m)[i][j] = cof(m)[j][i] / det.
  double r[3][3];
  r[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * inv;
  r[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv;
  r[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv;
  r[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * inv;
  r[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv;
  r[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv;
  r[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * inv;
  r[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv;
  r[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) grad[3 * i + k] = r[i][k];
  return true;
}

double tet_min_altitude(const double a[3], const double b[3], const double c[3], const double d[3]) {
  const double* p[4] = {a, b, c, d};
  auto face_area = [&](int i, int j, int k) {
    double u[3], v[3];
    for (int q = 0; q < 3; ++q) {
      u[q] = p[j][q] - p[i][q];
      v[q] = p[k][q] - p[i][q];
    }
    const double n0 = u[1] * v[2] - u[2] * v[1], n1 = u[2] * v[0] - u[0] * v[2], n2 = u[0] * v[1] - u[1] * v[0];
    return 0.5 * std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
  };
  double volume, grad[9];
  tet_rest_geometry(a, b, c, d, &volume, grad);
  const double amax = std::fmax(std::fmax(face_area(1, 2, 3), face_area(0, 2, 3)),
                                std::fmax(face_area(0, 1, 3), face_area(0, 1, 2)));
  return amax > 0 ? 3.0 * std::fabs(volume) / amax : 0.0;
}

#define PLIANT_INSTANTIATE(T)                                                               \
  template bool packed_corners_pay<T>();                                                    \
  template bool packed_velocities_pay<T>();                                                 \
  template T rayleigh_factor<T>(T, T, T, T);                                               \
  template void element_forces_linear<T>(const ElementContext<T>&, Range);                  \
  template void element_forces_stvk<T>(const ElementContext<T>&, Range);                    \
  template void element_forces_corotational<T>(const ElementContext<T>&, Range);            \
  template void element_forces_springs<T>(const ElementContext<T>&, Range);                 \
  template void element_energy_linear<T>(const ElementContext<T>&, Range, double*);         \
  template void element_energy_stvk<T>(const ElementContext<T>&, Range, double*);           \
  template void element_energy_corotational_scalar<T>(const ElementContext<T>&, Range, double*); \
  template void element_energy_springs<T>(const ElementContext<T>&, Range, double*);        \
  template void element_cauchy_stress<T>(const ElementContext<T>&, Range, int, double*);
PLIANT_INSTANTIATE(float)
PLIANT_INSTANTIATE(double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant
