// Private helpers of the element kernels, batched: W consecutive tets in the lanes of a vector
// (simd.hpp). The loads gather each tet's corners, the stores write W corner forces at once,
// and the rotation extraction runs the Newton iteration of tet_local.hpp on every lane until
// all lanes have converged, freezing each lane at the iterate the scalar loop would return.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include "simd.hpp"
#include "tet_local.hpp"

namespace pliant::detail {

template <class T>
struct TetBatch {
  using V = typename simd::Pack<T>::V;
  static constexpr int W = simd::Pack<T>::W;
  std::int32_t n[4][W];  // corner node indices (lanes past the end repeat the last tet)
  V x[4][3];             // corner positions (m)
  V g[3][3];             // rest gradients of corners 1..3 (1/m)
  V volume;              // m^3
};

// The corner positions of the batch's tets (e.n must be loaded): from the interleaved copy
// when the context has one (4 loads and a transpose per corner), else gathered from x[3][n].
template <class T>
inline void load_positions(const ElementContext<T>& c, TetBatch<T>& e) {
  if (c.xp) {
    for (int a = 0; a < 4; ++a) simd::gather_xyz(c.xp, e.n[a], e.x[a]);
  } else {
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) e.x[a][k] = simd::gather(c.x[k], e.n[a]);
  }
}

// Loads tets [t, t + count), count <= W, corner indices, positions, gradients and volumes.
template <class T>
inline void load_batch(const ElementContext<T>& c, std::size_t t, int count, TetBatch<T>& e) {
  constexpr int W = TetBatch<T>::W;
  for (int a = 0; a < 4; ++a) {
    if (count == W) {
      std::memcpy(e.n[a], c.tet[a] + t, sizeof(e.n[a]));
    } else {
      for (int l = 0; l < W; ++l) e.n[a][l] = c.tet[a][t + std::size_t(std::min(l, count - 1))];
    }
  }
  load_positions(c, e);
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) e.g[a][k] = simd::load(c.grad[3 * a + k] + t, count);
  e.volume = simd::load(c.volume + t, count);
}

template <class T>
inline void gather_corners(const T* const y[3], const TetBatch<T>& e, typename TetBatch<T>::V out[4][3]) {
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) out[a][k] = simd::gather(y[k], e.n[a]);
}

// store_corner_forces of tet_local.hpp, W tets at once.
template <class T>
inline void store_corner_forces_batch(const ElementContext<T>& c, std::size_t t, int count,
                                      const Mat3<typename TetBatch<T>::V>& P, const typename TetBatch<T>::V g[3][3],
                                      const typename TetBatch<T>::V& volume) {
  using V = typename TetBatch<T>::V;
  V f0[3] = {V{}, V{}, V{}};
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < 3; ++i) {
      const V fi = -volume * (P.m[i][0] * g[a][0] + P.m[i][1] * g[a][1] + P.m[i][2] * g[a][2]);
      simd::store(c.corner_force[3 * (a + 1) + i] + t, count, fi);
      f0[i] -= fi;
    }
  }
  for (int i = 0; i < 3; ++i) simd::store(c.corner_force[i] + t, count, f0[i]);
}

// extract_rotation of tet_local.hpp on every lane of K batches at once. A lane stops changing
// at the iteration where the scalar loop breaks; the loop ends when every lane of every batch
// has stopped (or after the same maximum number of iterations). Lanes whose Newton Hessian is not
// positive definite take the scalar escape (escape_rotation) one lane at a time, with the lane's
// own values, so that they too do exactly what the scalar loop does. K > 1 interleaves
// independent chains through the iteration's long dependency chain, but on the machine measured
// (docs/performance.md) register spills made K = 2 slower than K = 1, which the pass uses.
template <class T, int K>
__attribute__((always_inline)) inline void extract_rotation_batches(const Mat3<typename simd::Pack<T>::V> A[K],
                                                                    typename simd::Pack<T>::V q[K][4],
                                                                    Mat3<typename simd::Pack<T>::V> R[K]) {
  using V = typename simd::Pack<T>::V;
  using M = typename simd::Pack<T>::M;
  constexpr int W = simd::Pack<T>::W;
  constexpr int kMaxIterations = 64;
  const T tol = rotation_tolerance<T>();
  M active[K];
  for (int b = 0; b < K; ++b) {
    R[b] = quat_to_matrix(q[b]);
    active[b] = ~M{};
  }
  for (int it = 0; it < kMaxIterations; ++it) {
    V w[K][3];
    M stepping[K], escaping[K];
    M any_escaping = M{};
    for (int b = 0; b < K; ++b) {
      const Mat3<V> Mt = mul_tn(R[b], A[b]);
      const V g[3] = {Mt.m[2][1] - Mt.m[1][2], Mt.m[0][2] - Mt.m[2][0], Mt.m[1][0] - Mt.m[0][1]};
      const V tr = trace(Mt);
      const V h00 = tr - Mt.m[0][0], h11 = tr - Mt.m[1][1], h22 = tr - Mt.m[2][2];
      const V h01 = T(-0.5) * (Mt.m[0][1] + Mt.m[1][0]);
      const V h02 = T(-0.5) * (Mt.m[0][2] + Mt.m[2][0]);
      const V h12 = T(-0.5) * (Mt.m[1][2] + Mt.m[2][1]);
      const V c00 = h11 * h22 - h12 * h12, c01 = h02 * h12 - h01 * h22, c02 = h01 * h12 - h02 * h11;
      const V det = h00 * c00 + h01 * c01 + h02 * c02;
      const V scale = tr * tr * tr;
      // tr > 0 as in the scalar code: the scale must be positive for the test to mean "positive definite".
      const M newton = (tr > 0) & (h00 > 0) & (h00 * h11 - h01 * h01 > 0) & (det > T(1e-6) * scale);
      const V c11 = h00 * h22 - h02 * h02, c12 = h01 * h02 - h00 * h12, c22 = h00 * h11 - h01 * h01;
      const V inv = T(1) / det;
      w[b][0] = (c00 * g[0] + c01 * g[1] + c02 * g[2]) * inv;
      w[b][1] = (c01 * g[0] + c11 * g[1] + c12 * g[2]) * inv;
      w[b][2] = (c02 * g[0] + c12 * g[1] + c22 * g[2]) * inv;
      const V angle2 = w[b][0] * w[b][0] + w[b][1] * w[b][1] + w[b][2] * w[b][2];
      // Newton lanes whose step is below the tolerance (or NaN) stop here, as the scalar break.
      stepping[b] = active[b] & newton & (angle2 > tol * tol);
      escaping[b] = active[b] & ~newton;
      active[b] = stepping[b];
      any_escaping |= escaping[b];
    }
    // Escapes (rare: a warm start far from the answer, an inverted or flat tet), one lane at a
    // time, on M recomputed (the same bits) rather than kept live through the loop.
    if (simd::any(any_escaping)) {
      for (int b = 0; b < K; ++b) {
        if (!simd::any(escaping[b])) continue;
        const Mat3<V> Mt = mul_tn(R[b], A[b]);
        for (int l = 0; l < W; ++l) {
          if (!escaping[b][l]) continue;
          Mat3<T> m;
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) m.m[i][j] = Mt.m[i][j][l];
          T ql[4] = {q[b][0][l], q[b][1][l], q[b][2][l], q[b][3][l]};
          if (escape_rotation(m, ql, tol)) {  // jumped: the lane goes on (the scalar `continue`)
            for (int k = 0; k < 4; ++k) q[b][k][l] = ql[k];
            active[b][l] = -1;
          }
        }
      }
    }
    M any_active = M{};
    for (int b = 0; b < K; ++b) any_active |= active[b];
    if (!simd::any(any_active)) break;
    for (int b = 0; b < K; ++b) {
      const V d[4] = {V{} + T(1), T(0.5) * w[b][0], T(0.5) * w[b][1], T(0.5) * w[b][2]};
      V n[4];
      quat_mul(q[b], d, n);
      const V inv = T(1) / simd::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3]);
      for (int k = 0; k < 4; ++k) q[b][k] = stepping[b] ? n[k] * inv : q[b][k];
      R[b] = quat_to_matrix(q[b]);
    }
  }
}

}  // namespace pliant::detail
