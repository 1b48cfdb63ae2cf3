// Deformation gradients and the peak strain of listed tets (strain_measure.hpp): the scalar code,
// and the same operations in the lanes of one register (simd.hpp).
#include "pliant/kernels/strain_measure.hpp"

#include <algorithm>

#include "simd.hpp"

namespace pliant {
namespace {

// One tet: F and its squared Green-Lagrange strain. The order of every operation is the one the
// lanes below repeat.
template <class T>
double strain_of(const StrainMeasureContext<T>& c, std::size_t e, std::array<double, 9>& F) {
  double d[3][3], g[3][3];
  const auto n0 = std::size_t(c.tet[0][e]);
  for (int k = 0; k < 3; ++k) {
    const auto n = std::size_t(c.tet[k + 1][e]);
    for (int i = 0; i < 3; ++i) {
      d[k][i] = c.x[i][n] - c.x[i][n0];
      g[k][i] = double(c.grad[3 * k + i][e]);
    }
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) F[std::size_t(3 * i + j)] = d[0][i] * g[0][j] + d[1][i] * g[1][j] + d[2][i] * g[2][j];
  double e2 = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double q = a == b ? -1.0 : 0.0;  // (F^T F - I)_ab
      for (int k = 0; k < 3; ++k) q += F[std::size_t(3 * k + a)] * F[std::size_t(3 * k + b)];
      e2 += 0.25 * q * q;
    }
  return e2;
}

}  // namespace

template <class T>
double deformation_gradients_listed_scalar(const StrainMeasureContext<T>& c, const std::int32_t* ids, Range r,
                                           std::array<double, 9>* F) {
  double top = 0;
  for (std::size_t i = r.begin; i < r.end; ++i) {
    const auto e = std::size_t(ids[i]);
    top = std::max(top, strain_of(c, e, F[e]));
  }
  return top;
}

template <class T>
double deformation_gradients_listed(const StrainMeasureContext<T>& c, const std::int32_t* ids, Range r,
                                    std::array<double, 9>* F) {
  using N = simd::Pack<double>::N;
  constexpr int W = simd::Pack<double>::NW;
  double top = 0;
  std::size_t i = r.begin;
  for (; i + W <= r.end; i += W) {
    std::int32_t node[4][W];
    N g[3][3] = {};
    for (int l = 0; l < W; ++l) {
      const auto e = std::size_t(ids[i + std::size_t(l)]);
      for (int k = 0; k < 4; ++k) node[k][l] = c.tet[k][e];
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j) g[k][j][l] = double(c.grad[3 * k + j][e]);
    }
    N d[3][3];
    for (int i3 = 0; i3 < 3; ++i3) {
      const N x0 = simd::native::gather(c.x[i3], node[0]);
      for (int k = 0; k < 3; ++k) d[k][i3] = simd::native::gather(c.x[i3], node[k + 1]) - x0;
    }
    N f[9];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) f[3 * a + b] = d[0][a] * g[0][b] + d[1][a] * g[1][b] + d[2][a] * g[2][b];
    N e2 = {};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        N q;
        for (int l = 0; l < W; ++l) q[l] = a == b ? -1.0 : 0.0;
        for (int k = 0; k < 3; ++k) q = q + f[3 * k + a] * f[3 * k + b];
        e2 = e2 + 0.25 * q * q;
      }
    for (int l = 0; l < W; ++l) {
      std::array<double, 9>& out = F[std::size_t(ids[i + std::size_t(l)])];
      for (int k = 0; k < 9; ++k) out[std::size_t(k)] = f[k][l];
      top = std::max(top, e2[l]);
    }
  }
  for (; i < r.end; ++i) {  // the last partial batch, one tet at a time
    const auto e = std::size_t(ids[i]);
    top = std::max(top, strain_of(c, e, F[e]));
  }
  return top;
}

#define PLIANT_STRAIN_MEASURE(T)                                                                                      \
  template double deformation_gradients_listed<T>(const StrainMeasureContext<T>&, const std::int32_t*, Range,          \
                                                  std::array<double, 9>*);                                          \
  template double deformation_gradients_listed_scalar<T>(const StrainMeasureContext<T>&, const std::int32_t*, Range,   \
                                                         std::array<double, 9>*);
PLIANT_STRAIN_MEASURE(float)
PLIANT_STRAIN_MEASURE(double)
#undef PLIANT_STRAIN_MEASURE

}  // namespace pliant
