// The deformation monitor: per tet, the largest Hessian eigenvalue of the energy density now over
// its value at rest (element_stiffness.hpp gives the formulas and why).
#include "pliant/kernels/element_stiffness.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "tet_batch.hpp"
#include "tet_local.hpp"

namespace pliant {
using detail::Mat3;
using detail::TetLocal;

void symmetric_eigenvalues3(const double a[9], double eig[3]) {
  const double a00 = a[0], a01 = a[1], a02 = a[2], a11 = a[4], a12 = a[5], a22 = a[8];
  const double off = a01 * a01 + a02 * a02 + a12 * a12;
  const double q = (a00 + a11 + a22) / 3;
  const double d0 = a00 - q, d1 = a11 - q, d2 = a22 - q;
  const double p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2 * off;
  if (!(p2 > 0)) {  // a multiple of the identity (or NaN)
    eig[0] = eig[1] = eig[2] = q;
    return;
  }
  const double p = std::sqrt(p2 / 6);
  // B = (A - q I) / p; r = det(B) / 2, in [-1, 1] up to rounding.
  const double b00 = d0 / p, b11 = d1 / p, b22 = d2 / p, b01 = a01 / p, b02 = a02 / p, b12 = a12 / p;
  const double det = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02);
  const double r = std::clamp(det / 2, -1.0, 1.0);
  const double phi = std::acos(r) / 3;
  constexpr double kTwoThirdsPi = 2.0943951023931954923;
  const double hi = q + 2 * p * std::cos(phi), lo = q + 2 * p * std::cos(phi + kTwoThirdsPi);
  eig[0] = lo;
  eig[1] = 3 * q - hi - lo;
  eig[2] = hi;
}

namespace {

// Symmetric part of a 3x3 matrix of T as doubles, row-major.
template <class T>
void sym_to_double(const Mat3<T>& A, double out[9]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[3 * i + j] = 0.5 * (double(A.m[i][j]) + double(A.m[j][i]));
}

}  // namespace

template <class T>
void element_stiffness_ratio_stvk(const ElementContext<T>& c, Range r, double* ratio) {
  const double lambda = double(c.lambda), mu = double(c.mu);
  const double rest = 3 * lambda + 2 * mu;  // Pa: the hydrostatic scaling mode at rest
  for (std::size_t t = r.begin; t < r.end; ++t) {
    TetLocal<T> e;
    std::int32_t n[4];
    detail::load_tet(c, t, e, n);
    const Mat3<T> F = detail::corner_gradient(e.x, e.g);
    double C[9];
    sym_to_double(detail::mul_tn(F, F), C);
    double c2[3];  // squared stretches s_i^2, eigenvalues of C = F^T F
    symmetric_eigenvalues3(C, c2);
    double s[3], E[3], S[3];
    for (int i = 0; i < 3; ++i) {
      c2[i] = std::max(c2[i], 0.0);
      s[i] = std::sqrt(c2[i]);
      E[i] = 0.5 * (c2[i] - 1);
    }
    const double trE = E[0] + E[1] + E[2];
    for (int i = 0; i < 3; ++i) S[i] = lambda * trE + 2 * mu * E[i];  // principal 2nd PK stresses (Pa)
    double top = 0;
    for (int i = 0; i < 3; ++i) {
      // Scaling block H_ij = delta_ij S_i + s_i s_j (lambda + 2 mu delta_ij): Gershgorin row i.
      double row = std::fabs(S[i] + c2[i] * (lambda + 2 * mu));
      for (int j = 0; j < 3; ++j)
        if (j != i) row += s[i] * s[j] * lambda;
      top = std::max(top, row);
      for (int j = i + 1; j < 3; ++j) {
        // twist: a weighted mean of S_i and S_j (s >= 0); flip, divided out in closed form.
        const double twist = std::max(std::fabs(S[i]), std::fabs(S[j]));
        const double flip = std::fabs(lambda * trE + mu * (c2[i] + s[i] * s[j] + c2[j] - 1));
        top = std::max(top, std::max(twist, flip));
      }
    }
    ratio[t] = top / rest;
  }
}

namespace {

// One corotational tet's ratio: the scalar code (element_stiffness_ratio_corotational_scalar,
// and the lanes' fallback for tets off the fast path).
// at: where its rotation is (ElementContext::listed_rotation[k][at] when set, else rotation[k][t]).
template <class T>
double corotational_ratio(const ElementContext<T>& c, std::size_t t, std::size_t at) {
  const double lambda = double(c.lambda), mu = double(c.mu);
  const double rest = 3 * lambda + 2 * mu;  // Pa: the scaling block's largest eigenvalue, at any F
  TetLocal<T> e;
  std::int32_t n[4];
  detail::load_tet(c, t, e, n);
  const Mat3<T> F = detail::corner_gradient(e.x, e.g);
  // The rotation the last force pass stored (one step old): close enough for a monitor, and the
  // rotation iteration would cost more than the rest of this pass.
  T q[4];
  for (int k = 0; k < 4; ++k) q[k] = c.listed_rotation[k] ? c.listed_rotation[k][at] : c.rotation[k][t];
  const Mat3<T> R = detail::quat_to_matrix(q);
  double RtF[9];
  sym_to_double(detail::mul_tn(R, F), RtF);
  // Fast path: with e = S - I and eps = |e|_F >= max |s_i - 1|, every twist mode is at most
  // (4 mu + 6 lambda) eps / (2 (1 - eps)) = (3 lambda + 2 mu) eps / (1 - eps), below the scaling
  // mode while eps <= 1/2: the ratio is then exactly 1, without eigenvalues.
  double e2 = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double d = RtF[3 * i + j] - (i == j ? 1.0 : 0.0);
      e2 += d * d;
    }
  if (e2 <= 0.25) return 1;
  double s[3];  // signed principal stretches
  symmetric_eigenvalues3(RtF, s);
  const double trS = s[0] + s[1] + s[2];
  double psi[3];
  for (int i = 0; i < 3; ++i) psi[i] = 2 * mu * (s[i] - 1) + lambda * (trS - 3);  // principal stresses (Pa)
  double top = rest;  // scaling: 2 mu + 3 lambda; flip: 2 mu, below it
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const double den = std::max(std::fabs(s[i] + s[j]), kMinStretchSum);
      top = std::max(top, std::fabs(psi[i] + psi[j]) / den);
    }
  return top / rest;
}

// The fast-path test of corotational_ratio on the W tets [t, t + count) at once, one per lane:
// F, R and R^T F in T with the helpers the scalar code calls (the same bits per lane), then
// e2 = |sym(R^T F) - I|_F^2: for double the scalar code's operations in its order, for float in
// float lanes with a margin (below). Returns lanes whose ratio is exactly 1 by the scalar test
// (NaN fails, as there); the others run the scalar code. Lanes past `count` repeat the last tet.
// (Float lanes with the double test, converted, made the monitor twice as slow.)
template <class T, class At>
typename simd::Pack<T>::M corotational_fast_lanes(const ElementContext<T>& c, const At& at) {
  using V = typename simd::Pack<T>::V;
  detail::TetBatch<T> e;
  for (int a = 0; a < 4; ++a) at.corners(c, a, e.n[a]);
  // Positions: from the interleaved copy when the context has one (the caller packed it from x
  // just before: the same values the scalar code reads from x), else gathered from x[3][n].
  detail::load_positions(c, e);
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) e.g[a][k] = at.grad(c, 3 * a + k);
  const Mat3<V> F = detail::corner_gradient(e.x, e.g);
  V q[4];
  for (int k = 0; k < 4; ++k) q[k] = at.rotation(c, k);
  const Mat3<V> RtF = detail::mul_tn(detail::quat_to_matrix(q), F);
  if constexpr (std::is_same_v<T, double>) {
    // The scalar test itself (sym_to_double, then - I, squares summed in the same order).
    V e2 = V{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const V d = 0.5 * (RtF.m[i][j] + RtF.m[j][i]) - (i == j ? 1.0 : 0.0);
        e2 += d * d;
      }
    return e2 <= 0.25;
  } else {
    // Float: the same sum in float lanes, against 1/4 less a margin, so that a lane that passes
    // also passes the scalar test in double. From the same float R^T F, each term d = sym - I
    // differs from the double one by at most ~2.5 u (u = 2^-24; the sum of the two floats is
    // rounded relative to itself, the - 1 cancels only an error of u |S_ii| <= 1.5 u, as
    // |d| <= 1/2 wherever e2 is near 1/4), each square by ~2.5 u and the 9-term sum by ~8 u of
    // 1/4: e2 in float is within ~30 u = 1.8e-6 of e2 in double. The margin, 1e-4, is 50 times
    // that. A lane in the margin or above (or NaN, or overflowed) runs the scalar code, which
    // decides exactly; so the ratios are the scalar code's in every case.
    V e2 = V{};
    for (int i = 0; i < 3; ++i) {
      const V d = RtF.m[i][i] - 1.0f;
      e2 += d * d;
    }
    V off = V{};
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) {
        const V d = 0.5f * (RtF.m[i][j] + RtF.m[j][i]);
        off += d * d;
      }
    e2 += 2.0f * off;
    return e2 <= 0.2499f;
  }
}

// Ratios of the tets [r.begin, r.end), or of the listed tets ids[r.begin..r.end) when ids is not
// null, W at a time: lanes on the fast path give 1, the others the scalar code. out(t, ratio) is
// called for every tet off the fast path in list (or ascending) order, and (when Ones) for the
// fast ones too.
template <class T, bool Ones, class Out>
void corotational_ratios(const ElementContext<T>& c, const std::int32_t* ids, Range r, const Out& out) {
  constexpr int W = simd::Pack<T>::W;
  for (std::size_t t = r.begin; t < r.end; t += W) {
    const int count = int(std::min<std::size_t>(W, r.end - t));
    const auto fast = ids ? corotational_fast_lanes(c, detail::ListedTets<T>(ids, t, count))
                          : corotational_fast_lanes(c, detail::ConsecutiveTets<T>{t, count});
    if (!Ones && !simd::any(~fast)) continue;  // every lane at ratio 1 (lanes past count repeat the last)
    for (int l = 0; l < count; ++l) {
      const std::size_t tet = ids ? std::size_t(ids[t + std::size_t(l)]) : t + std::size_t(l);
      if (fast[l]) {
        if constexpr (Ones) out(tet, 1.0);
      } else {
        out(tet, corotational_ratio(c, tet, t + std::size_t(l)));
      }
    }
  }
}

}  // namespace

template <class T>
void element_stiffness_ratio_corotational(const ElementContext<T>& c, Range r, double* ratio) {
  corotational_ratios<T, true>(c, nullptr, r, [&](std::size_t t, double v) { ratio[t] = v; });
}

template <class T>
double element_stiffness_ratio_corotational_max(const ElementContext<T>& c, Range r) {
  double top = 1;
  corotational_ratios<T, false>(c, nullptr, r, [&](std::size_t, double v) { top = std::max(top, v); });
  return top;
}

template <class T>
double element_stiffness_ratio_corotational_max_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r) {
  double top = 1;
  corotational_ratios<T, false>(c, tets, r, [&](std::size_t, double v) { top = std::max(top, v); });
  return top;
}

template <class T>
void element_stiffness_ratio_corotational_scalar(const ElementContext<T>& c, Range r, double* ratio) {
  for (std::size_t t = r.begin; t < r.end; ++t) ratio[t] = corotational_ratio(c, t, t);
}

template <class T>
void element_stiffness_ratio_springs(const ElementContext<T>& c, Range r, double* ratio) {
  constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (std::size_t t = r.begin; t < r.end; ++t) {
    double worst = 1;
    for (const auto& edge : kEdges) {
      const std::int32_t a = c.tet[edge[0]][t], b = c.tet[edge[1]][t];
      double l2 = 0, L2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(c.x[k][b]) - double(c.x[k][a]), D = double(c.X[k][b]) - double(c.X[k][a]);
        l2 += d * d;
        L2 += D * D;
      }
      // Along the edge the tangent is k, across it k (1 - L / l): 1 + |1 - L / l| (l floored at
      // kMinStretchSum L so that l = 0 stays finite; see element_stiffness.hpp).
      const double l_over_L = std::max(std::sqrt(l2 / L2), kMinStretchSum);
      worst = std::max(worst, 1 + std::fabs(1 - 1 / l_over_L));
    }
    ratio[t] = worst;
  }
}

#define PLIANT_INSTANTIATE(T)                                                                      \
  template void element_stiffness_ratio_stvk<T>(const ElementContext<T>&, Range, double*);         \
  template void element_stiffness_ratio_corotational<T>(const ElementContext<T>&, Range, double*); \
  template double element_stiffness_ratio_corotational_max<T>(const ElementContext<T>&, Range);     \
  template double element_stiffness_ratio_corotational_max_listed<T>(const ElementContext<T>&, const std::int32_t*, Range); \
  template void element_stiffness_ratio_corotational_scalar<T>(const ElementContext<T>&, Range, double*); \
  template void element_stiffness_ratio_springs<T>(const ElementContext<T>&, Range, double*);
PLIANT_INSTANTIATE(float)
PLIANT_INSTANTIATE(double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant
