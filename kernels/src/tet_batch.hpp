// Private helpers of the element kernels, batched: W consecutive tets in the lanes of a vector
// (simd.hpp). The loads gather each tet's corners, the stores write W corner forces at once,
// and the rotation extraction runs the Newton iteration of tet_local.hpp on every lane until
// all lanes have converged, freezing each lane at the iterate the scalar loop would return.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include "pliant/kernels/range.hpp"
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
__attribute__((always_inline)) inline void load_positions(const ElementContext<T>& c, TetBatch<T>& e) {
  if (c.xp) {
    for (int a = 0; a < 4; ++a) simd::gather_xyz(c.xp, e.n[a], e.x[a]);
  } else {
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 3; ++k) e.x[a][k] = simd::gather(c.x[k], e.n[a]);
  }
}

// Which tets the lanes of a batch hold, and how their per-tet values are read and written.
// Lanes past `count` repeat the last tet on load and are not stored (simd::load / simd::store).
//   ConsecutiveTets: tets [first, first + count) — contiguous loads and stores.
//   ListedTets: the tets id[0..count) at positions [first, first + count) of a list (a
//     multiresolution level's stepped tets, which lie scattered over its mesh): gathers and
//     scattered stores, so that a batch is full however short the runs of stepped tets are; the
//     rest data (corner indices, gradients, volumes) loaded from the context's copies in list
//     order when it has them (ElementContext::listed_tet ...). A list must not repeat a tet.
// Each lane does the same arithmetic either way: the same bits (tests/kernels/test_kernel_batches.cpp).
template <class T>
struct ConsecutiveTets {
  using V = typename simd::Pack<T>::V;
  static constexpr int W = simd::Pack<T>::W;
  std::size_t first;
  int count;
  V load(const T* p) const { return simd::load(p + first, count); }
  void store(T* p, const V& v) const { simd::store(p + first, count, v); }
  void store_force(T* p, const V& v) const { store(p, v); }  // corner forces: per tet
  std::size_t tet(int l) const { return first + std::size_t(l); }  // the tet of lane l < count
  void indices(const std::int32_t* p, std::int32_t out[W]) const { load_indices(p + first, count, out); }
  // The rest data: corner a's node indices, gradient component q, volume.
  void corners(const ElementContext<T>& c, int a, std::int32_t out[W]) const { indices(c.tet[a], out); }
  V grad(const ElementContext<T>& c, int q) const { return load(c.grad[q]); }
  V volume(const ElementContext<T>& c) const { return load(c.volume); }
  // Component k of the corotational warm start (ElementContext::rotation), and its store.
  V rotation(const ElementContext<T>& c, int k) const { return load(c.rotation[k]); }
  void store_rotation(const ElementContext<T>& c, int k, const V& v) const { store(c.rotation[k], v); }

  // out[l] = p[min(l, count - 1)]: contiguous indices, lanes past count repeating the last.
  static void load_indices(const std::int32_t* p, int count, std::int32_t out[W]) {
    if (count == W) {
      std::memcpy(out, p, sizeof(std::int32_t) * W);
    } else {
      for (int l = 0; l < W; ++l) out[l] = p[std::min(l, count - 1)];
    }
  }
};

template <class T>
struct ListedTets {
  using V = typename simd::Pack<T>::V;
  static constexpr int W = simd::Pack<T>::W;
  std::int32_t id[W];
  std::size_t first;  // the batch's position in the list
  int count;
  bool forces_in_order = false;  // corner forces by list position (ElementContext::listed_corner_forces)
  // The tets list[first .. first + n) (n <= W).
  ListedTets(const std::int32_t* list, std::size_t first_position, int n, bool forces_by_position = false)
      : first(first_position), count(n), forces_in_order(forces_by_position) {
    for (int l = 0; l < W; ++l) id[l] = list[first + std::size_t(std::min(l, n - 1))];
  }
  V load(const T* p) const { return simd::gather(p, id); }
  // Lanes past `count` repeat the last tet and are not stored: the stored lanes are distinct tets.
  void store(T* p, const V& v) const { simd::scatter<T>(p, id, count, v); }
  // Corner forces: at the batch's list positions when the context keeps them in list order (one
  // vector store), else scattered to its tets.
  void store_force(T* p, const V& v) const {
    if (forces_in_order) {
      simd::store(p + first, count, v);
    } else {
      store(p, v);
    }
  }
  std::size_t tet(int l) const { return std::size_t(id[l]); }  // the tet of lane l < count
  void indices(const std::int32_t* p, std::int32_t out[W]) const {
    if constexpr (W % simd::native::kNativeInts == 0) {
      simd::gather_i32<W>(p, id, out);
    } else {
      for (int l = 0; l < W; ++l) out[l] = p[id[l]];
    }
  }
  // The rest data, from the copies in list order when the context has them (the same values).
  void corners(const ElementContext<T>& c, int a, std::int32_t out[W]) const {
    if (c.listed_tet[a]) {
      ConsecutiveTets<T>::load_indices(c.listed_tet[a] + first, count, out);
    } else {
      indices(c.tet[a], out);
    }
  }
  V grad(const ElementContext<T>& c, int q) const {
    return c.listed_grad[q] ? simd::load(c.listed_grad[q] + first, count) : load(c.grad[q]);
  }
  V volume(const ElementContext<T>& c) const {
    return c.listed_volume ? simd::load(c.listed_volume + first, count) : load(c.volume);
  }
  // The warm start, from the list-order copy when the context has one (ElementContext::listed_rotation).
  V rotation(const ElementContext<T>& c, int k) const {
    return c.listed_rotation[k] ? simd::load(c.listed_rotation[k] + first, count) : load(c.rotation[k]);
  }
  void store_rotation(const ElementContext<T>& c, int k, const V& v) const {
    if (c.listed_rotation[k]) {
      simd::store(c.listed_rotation[k] + first, count, v);
    } else {
      store(c.rotation[k], v);
    }
  }
};

// Loads the batch's corner indices, positions, gradients and volumes.
template <class T, class At>
__attribute__((always_inline)) inline void load_batch(const ElementContext<T>& c, const At& at, TetBatch<T>& e) {
  for (int a = 0; a < 4; ++a) at.corners(c, a, e.n[a]);
  load_positions(c, e);
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) e.g[a][k] = at.grad(c, 3 * a + k);
  e.volume = at.volume(c);
}

template <class T>
__attribute__((always_inline)) inline void gather_corners(const T* const y[3], const TetBatch<T>& e, typename TetBatch<T>::V out[4][3]) {
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) out[a][k] = simd::gather(y[k], e.n[a]);
}

// The corner velocities of the batch's tets (e.n must be loaded), for the damped passes: from the
// interleaved copy when the context has one, else gathered from v[3][n].
template <class T>
__attribute__((always_inline)) inline void load_velocities(const ElementContext<T>& c, const TetBatch<T>& e,
                                                           typename TetBatch<T>::V out[4][3]) {
  if (c.vp) {
    for (int a = 0; a < 4; ++a) simd::gather_xyz(c.vp, e.n[a], out[a]);
  } else {
    gather_corners(c.v, e, out);
  }
}

// store_corner_forces of tet_local.hpp, W tets at once.
template <class T, class At>
__attribute__((always_inline)) inline void store_corner_forces_batch(const ElementContext<T>& c, const At& at,
                                      const Mat3<typename TetBatch<T>::V>& P, const typename TetBatch<T>::V g[3][3],
                                      const typename TetBatch<T>::V& volume) {
  using V = typename TetBatch<T>::V;
  // Component by component, so that corner 0's sum is one register: an array f0[3] across the
  // corner loop was zeroed with `rep stos` and kept in memory (2 % of the AVX2 pass in perf
  // samples). The same operations on each value, in the same order, as the scalar code.
  for (int i = 0; i < 3; ++i) {
    V f0 = V{};
    for (int a = 0; a < 3; ++a) {
      const V fi = -volume * dot3(P.m[i][0], g[a][0], P.m[i][1], g[a][1], P.m[i][2], g[a][2]);
      at.store_force(c.corner_force[3 * (a + 1) + i], fi);
      f0 -= fi;
    }
    at.store_force(c.corner_force[i], f0);
  }
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
      const RotationStep<V> s = rotation_step(mul_tn(R[b], A[b]));
      // The scalar loop's test (tet_local.hpp), lane by lane.
      const M newton = (s.tr > 0) & (s.h00 > 0) & (s.minor > 0) & (s.det > T(1e-6) * s.scale);
      for (int k = 0; k < 3; ++k) w[b][k] = s.w[k];
      // Newton lanes whose step is below the tolerance (or NaN) stop here, as the scalar break;
      // lanes whose step is final take it and stop after it (the scalar break after the update).
      stepping[b] = active[b] & newton & (s.angle2 > tol * tol);
      escaping[b] = active[b] & ~newton;
      active[b] = stepping[b] & ~M(rotation_step_is_final(s, tol));
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
    M any_active = M{}, any_stepping = M{};
    for (int b = 0; b < K; ++b) {
      any_active |= active[b];
      any_stepping |= stepping[b];
    }
    if (!simd::any(any_active | any_stepping)) break;
    for (int b = 0; b < K; ++b) {
      V n[4];
      rotate_by_step(q[b], w[b], n);
      for (int k = 0; k < 4; ++k) q[b][k] = stepping[b] ? n[k] : q[b][k];
      R[b] = quat_to_matrix(q[b]);
    }
    if (!simd::any(any_active)) break;  // every lane took its final update: no check after it
  }
}

}  // namespace pliant::detail
