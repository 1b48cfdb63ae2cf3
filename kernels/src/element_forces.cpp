// The per-tet force and energy kernels of every force model (see element_forces.hpp).
// Branch-free per element except the corotational rotation refinement; damping terms are
// compiled in only when a viscous coefficient is non-zero (template flag), so undamped runs do
// not read velocities.
#include "pliant/kernels/element_forces.hpp"

#include <cmath>

#include "tet_local.hpp"

namespace pliant {
using detail::Mat3;
using detail::TetLocal;

namespace {

template <class T>
bool has_viscosity(const ElementContext<T>& c) {
  return c.bulk_viscosity != T(0) || c.shear_viscosity != T(0);
}

// ---- linear (Cauchy) ------------------------------------------------------------------------
template <class T, bool Damped>
void linear_pass(const ElementContext<T>& c, Range r) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    Mat3<T> eps = detail::sym(detail::corner_gradient(e.x, e.g));
    for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
    Mat3<T> P = detail::hooke(eps, c.lambda, c.mu);
    if constexpr (Damped) {
      T v[4][3];
      detail::load_velocities(c, n, v);
      detail::add_to(P, detail::hooke(detail::sym(detail::corner_gradient(v, e.g)), c.bulk_viscosity,
                                      c.shear_viscosity));
    }
    detail::store_corner_forces(c, t, P, e.g, e.volume);
  }
}

// ---- St Venant–Kirchhoff (Green–Lagrange) ---------------------------------------------------
template <class T, bool Damped>
void stvk_pass(const ElementContext<T>& c, Range r) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    Mat3<T> E = detail::sym(detail::mul_tn(F, F));
    for (int i = 0; i < 3; ++i) E.m[i][i] -= T(1);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) E.m[i][j] *= T(0.5);
    Mat3<T> S = detail::hooke(E, c.lambda, c.mu);
    if constexpr (Damped) {
      T v[4][3];
      detail::load_velocities(c, n, v);
      const Mat3<T> Fdot = detail::corner_gradient(v, e.g);
      detail::add_to(S, detail::hooke(detail::sym(detail::mul_tn(F, Fdot)), c.bulk_viscosity, c.shear_viscosity));
    }
    detail::store_corner_forces(c, t, detail::mul(F, S), e.g, e.volume);
  }
}

// ---- corotational ---------------------------------------------------------------------------
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

template <class T, bool Damped>
void corotational_pass(const ElementContext<T>& c, Range r) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    Mat3<T> R;
    const Mat3<T> eps = corotational_strain(c, t, F, R, true);
    Mat3<T> sigma = detail::hooke(eps, c.lambda, c.mu);
    if constexpr (Damped) {
      T v[4][3];
      detail::load_velocities(c, n, v);
      const Mat3<T> Fdot = detail::corner_gradient(v, e.g);
      detail::add_to(sigma,
                     detail::hooke(detail::sym(detail::mul_tn(R, Fdot)), c.bulk_viscosity, c.shear_viscosity));
    }
    detail::store_corner_forces(c, t, detail::mul(R, sigma), e.g, e.volume);
  }
}

// ---- springs --------------------------------------------------------------------------------
constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

template <class T, bool Damped>
void springs_pass(const ElementContext<T>& c, Range r) {
  for (std::size_t t = r.begin; t < r.end; ++t) {
    std::int32_t n[4];
    T x[4][3], X[4][3], v[4][3];
    for (int a = 0; a < 4; ++a) n[a] = c.tet[a][t];
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) {
        x[a][k] = c.x[k][n[a]];
        X[a][k] = c.X[k][n[a]];
      }
    if constexpr (Damped) {
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) v[a][k] = c.v[k][n[a]];
    }
    T f[4][3] = {};
    for (const auto& edge : kEdges) {
      const int a = edge[0], b = edge[1];
      T d[3], D[3];
      for (int k = 0; k < 3; ++k) {
        d[k] = x[b][k] - x[a][k];
        D[k] = X[b][k] - X[a][k];
      }
      const T L2 = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
      const T L = std::sqrt(L2);
      const T l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      const T k_spring = c.young * c.volume[t] / L2;  // N/m
      const T inv_l = l > T(0) ? T(1) / l : T(0);
      T s = k_spring * (l - L);  // tension (N)
      if constexpr (Damped) {
        T rel = 0;
        for (int k = 0; k < 3; ++k) rel += (v[b][k] - v[a][k]) * d[k];
        s += c.spring_damping * k_spring * rel * inv_l;
      }
      for (int k = 0; k < 3; ++k) {
        const T fk = s * d[k] * inv_l;
        f[a][k] += fk;
        f[b][k] -= fk;
      }
    }
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) c.corner_force[3 * a + k][t] = f[a][k];
  }
}

}  // namespace

template <class T>
void element_forces_linear(const ElementContext<T>& c, Range r) {
  has_viscosity(c) ? linear_pass<T, true>(c, r) : linear_pass<T, false>(c, r);
}
template <class T>
void element_forces_stvk(const ElementContext<T>& c, Range r) {
  has_viscosity(c) ? stvk_pass<T, true>(c, r) : stvk_pass<T, false>(c, r);
}
template <class T>
void element_forces_corotational(const ElementContext<T>& c, Range r) {
  has_viscosity(c) ? corotational_pass<T, true>(c, r) : corotational_pass<T, false>(c, r);
}
template <class T>
void element_forces_springs(const ElementContext<T>& c, Range r) {
  c.spring_damping != T(0) ? springs_pass<T, true>(c, r) : springs_pass<T, false>(c, r);
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
void element_energy_corotational(const ElementContext<T>& c, Range r, double* energy) {
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
    for (const auto& edge : kEdges) {
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
  template void element_forces_linear<T>(const ElementContext<T>&, Range);                  \
  template void element_forces_stvk<T>(const ElementContext<T>&, Range);                    \
  template void element_forces_corotational<T>(const ElementContext<T>&, Range);            \
  template void element_forces_springs<T>(const ElementContext<T>&, Range);                 \
  template void element_energy_linear<T>(const ElementContext<T>&, Range, double*);         \
  template void element_energy_stvk<T>(const ElementContext<T>&, Range, double*);           \
  template void element_energy_corotational<T>(const ElementContext<T>&, Range, double*);   \
  template void element_energy_springs<T>(const ElementContext<T>&, Range, double*);        \
  template void element_cauchy_stress<T>(const ElementContext<T>&, Range, int, double*);
PLIANT_INSTANTIATE(float)
PLIANT_INSTANTIATE(double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant
