// The force passes' batch functions, one per force model: W tets at a time, one per vector lane
// (tet_batch.hpp), at either addressing (At: ConsecutiveTets or ListedTets). Each lane does the
// arithmetic of the scalar helpers of tet_local.hpp, so results are the same bits as a
// one-tet-at-a-time loop, whatever the range boundaries or the list
// (tests/kernels/test_kernel_batches.cpp). Branch-free per batch except the corotational rotation
// refinement (until every lane has converged); damping terms are compiled in only when a viscous
// coefficient is non-zero (Damping below), so undamped runs do not read velocities.
//
// Included by element_forces.cpp (the passes over ranges), element_forces_listed.cpp (over
// lists) and element_forces_rayleigh.cpp (the rayleigh passes of both): one translation unit each,
// so that each keeps the inlining budget the range passes had alone (in one unit, GCC 12 left the
// small matrix helpers out of line: slower).
#pragma once
#include <algorithm>
#include <cstdint>

#include "pliant/kernels/element_context.hpp"
#include "tet_batch.hpp"
#include "tet_local.hpp"

namespace pliant::detail {

template <class T>
bool has_viscosity(const ElementContext<T>& c) {
  return c.bulk_viscosity != T(0) || c.shear_viscosity != T(0);
}

// How a pass damps. viscous: the viscous stress D(e_dot) = phi tr(e_dot) I + 2 psi e_dot of the
// model's strain rate, a second Hooke law added to the elastic stress. rayleigh: the viscosities
// are beta times the Lamé moduli (ElementContext::rayleigh, Rayleigh stiffness damping: the
// default scene's), so D(e_dot) = Hooke(beta e_dot) and the stress is one Hooke law of the strain
// e + beta e_dot (the same value; a Hooke law and a product with R or F fewer per tet: the
// corotational damped pass counts 557 flops instead of 634, perf/src/workload.cpp).
enum class Damping { none, viscous, rayleigh };

template <class T>
Damping damping_of(const ElementContext<T>& c) {
  if (!has_viscosity(c)) return Damping::none;
  return c.rayleigh != T(0) ? Damping::rayleigh : Damping::viscous;
}

// y = a + beta b, entry by entry (the strain plus beta times its rate).
template <class V, class S>
__attribute__((always_inline)) inline Mat3<V> plus_scaled(const Mat3<V>& a, S beta, const Mat3<V>& b) {
  Mat3<V> y;
  const V vb = splat<V>(beta);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) y.m[i][j] = simd::mul_add(vb, b.m[i][j], a.m[i][j]);
  return y;
}

// ---- linear (Cauchy) ------------------------------------------------------------------------
template <class T, Damping Damp, class At>
__attribute__((always_inline)) inline void linear_batch(const ElementContext<T>& c, const At& at) {
  using V = typename simd::Pack<T>::V;
  TetBatch<T> e;
  load_batch(c, at, e);
  Mat3<V> F = corner_gradient(e.x, e.g);
  if constexpr (Damp == Damping::rayleigh) {  // eps + beta eps_dot = sym(F + beta F_dot) - I
    V v[4][3];
    load_velocities(c, e, v);
    F = plus_scaled(F, c.rayleigh, corner_gradient(v, e.g));
  }
  Mat3<V> eps = sym(F);
  for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
  Mat3<V> P = hooke(eps, c.lambda, c.mu);
  if constexpr (Damp == Damping::viscous) {
    V v[4][3];
    load_velocities(c, e, v);
    add_to(P, hooke(sym(corner_gradient(v, e.g)), c.bulk_viscosity, c.shear_viscosity));
  }
  store_corner_forces_batch(c, at, P, e.g, e.volume);
}

// Stores the corner forces of the first Piola–Kirchhoff stress Q S (stvk: Q = F, S the second
// Piola–Kirchhoff stress; corotational: Q = R, S the corotated stress), with the viscous stress of
// the strain rate sym(Q^T F_dot) added to S when viscous (rayleigh: S has it already).
template <class T, Damping Damp, class At>
__attribute__((always_inline)) inline void store_stress_batch(const ElementContext<T>& c, const At& at,
                                                              const TetBatch<T>& e,
                                                              const Mat3<typename simd::Pack<T>::V>& Q,
                                                              Mat3<typename simd::Pack<T>::V> S) {
  using V = typename simd::Pack<T>::V;
  if constexpr (Damp == Damping::viscous) {
    V v[4][3];
    load_velocities(c, e, v);
    const Mat3<V> Fdot = corner_gradient(v, e.g);
    add_to(S, hooke(sym(mul_tn(Q, Fdot)), c.bulk_viscosity, c.shear_viscosity));
  }
  store_corner_forces_batch(c, at, mul(Q, S), e.g, e.volume);
}

// ---- St Venant–Kirchhoff (Green–Lagrange) ---------------------------------------------------
template <class T, Damping Damp, class At>
__attribute__((always_inline)) inline void stvk_batch(const ElementContext<T>& c, const At& at) {
  using V = typename simd::Pack<T>::V;
  TetBatch<T> e;
  load_batch(c, at, e);
  const Mat3<V> F = corner_gradient(e.x, e.g);
  // E = (sym(F^T F) - I) / 2; with rayleigh E + beta E_dot = (sym(F^T (F + 2 beta F_dot)) - I) / 2,
  // E_dot = sym(F^T F_dot).
  Mat3<V> E;
  if constexpr (Damp == Damping::rayleigh) {
    V v[4][3];
    load_velocities(c, e, v);
    E = sym(mul_tn(F, plus_scaled(F, T(2) * c.rayleigh, corner_gradient(v, e.g))));
  } else {
    E = sym(mul_tn(F, F));
  }
  for (int i = 0; i < 3; ++i) E.m[i][i] -= T(1);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) E.m[i][j] *= T(0.5);
  store_stress_batch<T, Damp>(c, at, e, F, hooke(E, c.lambda, c.mu));
}

// ---- corotational ---------------------------------------------------------------------------
// The corotated strain sym(R^T F) - I of the loaded batch e, R refined from the stored rotation
// (its warm start); the refined rotation is stored back only when Keep (the force pass: the energy
// report works on a copy, so that measuring never changes the trajectory).
// With rayleigh (Damp), the strain plus beta times its rate, sym(R^T (F + beta F_dot)) - I (R from F
// alone, so the same rotation as undamped).
template <class T, bool Keep, Damping Damp = Damping::none, class At>
__attribute__((always_inline)) inline Mat3<typename simd::Pack<T>::V> corotated_strain_batch(
    const ElementContext<T>& c, const At& at, const TetBatch<T>& e, Mat3<typename simd::Pack<T>::V>& R) {
  using V = typename simd::Pack<T>::V;
  const Mat3<V> F[1] = {corner_gradient(e.x, e.g)};
  V q[1][4];
  for (int k = 0; k < 4; ++k) q[0][k] = at.rotation(c, k);
  Mat3<V> Rb[1];
  extract_rotation_batches<T, 1>(F, q, Rb);
  if constexpr (Keep)
    for (int k = 0; k < 4; ++k) at.store_rotation(c, k, q[0][k]);
  R = Rb[0];
  Mat3<V> eps;
  if constexpr (Damp == Damping::rayleigh) {
    V v[4][3];
    load_velocities(c, e, v);
    eps = sym(mul_tn(R, plus_scaled(F[0], c.rayleigh, corner_gradient(v, e.g))));
  } else {
    eps = sym(mul_tn(R, F[0]));
  }
  for (int i = 0; i < 3; ++i) eps.m[i][i] -= T(1);
  return eps;
}

template <class T, Damping Damp, class At>
__attribute__((always_inline)) inline void corotational_batch(const ElementContext<T>& c, const At& at) {
  using V = typename simd::Pack<T>::V;
  TetBatch<T> e;
  load_batch(c, at, e);
  Mat3<V> R;
  const Mat3<V> eps = corotated_strain_batch<T, true, Damp>(c, at, e, R);
  store_stress_batch<T, Damp>(c, at, e, R, hooke(eps, c.lambda, c.mu));
}

// ---- springs --------------------------------------------------------------------------------
constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

template <class T, Damping Damp, class At>
__attribute__((always_inline)) inline void springs_batch(const ElementContext<T>& c, const At& at) {
  using V = typename simd::Pack<T>::V;
  TetBatch<T> e;
  for (int a = 0; a < 4; ++a) at.corners(c, a, e.n[a]);
  V X[4][3], v[4][3];
  load_positions(c, e);
  auto& x = e.x;
  gather_corners(c.X, e, X);
  constexpr bool Damped = Damp != Damping::none;  // beta's dashpots (spring_damping), either way
  if constexpr (Damped) load_velocities(c, e, v);
  const V volume = at.volume(c);
  V f[4][3] = {};
  for (const auto& edge : kEdges) {
    const int a = edge[0], b = edge[1];
    V d[3], D[3];
    for (int k = 0; k < 3; ++k) {
      d[k] = x[b][k] - x[a][k];
      D[k] = X[b][k] - X[a][k];
    }
    const V L2 = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
    const V L = simd::sqrt(L2);
    const V l = simd::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const V k_spring = c.young * volume / L2;  // N/m
    const V inv_l = l > T(0) ? T(1) / l : V{};
    V s = k_spring * (l - L);  // tension (N)
    if constexpr (Damped) {
      V rel = V{};
      for (int k = 0; k < 3; ++k) rel += (v[b][k] - v[a][k]) * d[k];
      s += c.spring_damping * k_spring * rel * inv_l;
    }
    for (int k = 0; k < 3; ++k) {
      const V fk = s * d[k] * inv_l;
      f[a][k] += fk;
      f[b][k] -= fk;
    }
  }
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) at.store_force(c.corner_force[3 * a + k], f[a][k]);
}

// ---- corotational elastic energy --------------------------------------------------------------
// energy[t] (J) of the batch's tets: element_energy_corotational's scalar arithmetic per lane (the
// stored rotation refined on a copy, never written back), converted to double lane by lane.
template <class T, class At>
inline void corotational_energy_batch(const ElementContext<T>& c, const At& at, double* energy) {
  using V = typename simd::Pack<T>::V;
  TetBatch<T> e;
  load_batch(c, at, e);
  Mat3<V> R;
  const Mat3<V> eps = corotated_strain_batch<T, false>(c, at, e, R);
  const V tr = trace(eps), dd = ddot(eps, eps);
  for (int l = 0; l < at.count; ++l) {
    const double trl = double(tr[l]);
    energy[at.tet(l)] = double(e.volume[l]) * (double(c.mu) * double(dd[l]) + 0.5 * double(c.lambda) * trl * trl);
  }
}

// The models as types, for the passes below.
#define PLIANT_BATCH_MODEL(Name, fn)                                                              \
  struct Name {                                                                                   \
    template <class T, Damping Damp, class At>                                                    \
    __attribute__((always_inline)) static void batch(const ElementContext<T>& c, const At& at) { \
      fn<T, Damp>(c, at);                                                                         \
    }                                                                                             \
  };
PLIANT_BATCH_MODEL(Linear, linear_batch)
PLIANT_BATCH_MODEL(Stvk, stvk_batch)
PLIANT_BATCH_MODEL(Corotational, corotational_batch)
PLIANT_BATCH_MODEL(Springs, springs_batch)
#undef PLIANT_BATCH_MODEL

// The passes: W tets at a time of the range, or of the listed tets ids[r.begin..r.end). One
// function per model, damping and addressing, so that each inlines its one batch.
template <class Model, class T, Damping Damp>
void range_pass(const ElementContext<T>& c, Range r) {
  constexpr int W = simd::Pack<T>::W;
  for (std::size_t t = r.begin; t < r.end; t += W)
    Model::template batch<T, Damp>(c, ConsecutiveTets<T>{t, int(std::min<std::size_t>(W, r.end - t))});
}
template <class Model, class T, Damping Damp>
void listed_pass(const ElementContext<T>& c, const std::int32_t* ids, Range r) {
  constexpr int W = simd::Pack<T>::W;
  for (std::size_t t = r.begin; t < r.end; t += W)
    Model::template batch<T, Damp>(c, ListedTets<T>(ids, t, int(std::min<std::size_t>(W, r.end - t)), c.listed_corner_forces));
}

// The rayleigh passes live in a translation unit of their own (element_forces_rayleigh.cpp):
// with them instantiated beside the others, GCC 12 left hooke, mul_tn, corner_gradient and
// quat_to_matrix out of line in both units, and every pass, undamped too, ran 13-17 % slower
// (`pliant bench --scenes-only`, 2026-11-28). Models: Linear, Stvk, Corotational.
template <class Model, class T>
void rayleigh_range_pass(const ElementContext<T>& c, Range r);
template <class Model, class T>
void rayleigh_listed_pass(const ElementContext<T>& c, const std::int32_t* ids, Range r);

}  // namespace pliant::detail
