// Private helpers of the element kernels: gathering one tet's corners into registers, the
// deformation gradient, 3x3 algebra and the corotational rotation extraction.
#pragma once
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "pliant/kernels/element_context.hpp"
#include "simd.hpp"

namespace pliant::detail {

// T is float or double, or a vector of them (simd.hpp: one tet per lane); the helpers below
// are written once for both so that a lane computes exactly what the scalar code computes.
template <class T>
struct Mat3 {
  T m[3][3];
};

template <class T>
struct ScalarOf {
  using type = std::remove_cvref_t<decltype(T{}[0])>;
};
template <>
struct ScalarOf<float> {
  using type = float;
};
template <>
struct ScalarOf<double> {
  using type = double;
};
template <class T>
using scalar_t = typename ScalarOf<T>::type;

// A constant as a T (broadcast to every lane for a vector).
template <class T>
inline T splat(scalar_t<T> s) {
  if constexpr (std::is_floating_point_v<T>) {
    return s;
  } else {
    return T{} + s;
  }
}

// a0 b0 + a1 b1 + a2 b2, summed left to right, each product after the first fused into its sum
// (simd::mul_add: one rounding per term with PLIANT_FMA).
template <class T>
inline T dot3(const T& a0, const T& b0, const T& a1, const T& b1, const T& a2, const T& b2) {
  return simd::mul_add(a2, b2, simd::mul_add(a1, b1, a0 * b0));
}

// One tet's corner data, loaded from the SoA arrays.
template <class T>
struct TetLocal {
  T x[4][3];  // corner positions (m)
  T g[3][3];  // g[c-1][k] = d(phi_c)/dX_k for corners 1..3 (1/m)
  T volume;   // m^3
};

template <class T>
inline void load_tet(const ElementContext<T>& c, std::size_t t, TetLocal<T>& e, std::int32_t n[4]) {
  for (int a = 0; a < 4; ++a) n[a] = c.tet[a][t];
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) e.x[a][k] = c.x[k][n[a]];
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) e.g[a][k] = c.grad[3 * a + k][t];
  e.volume = c.volume[t];
}

// G = sum_{c=1..3} (y_c - y_0) g_c^T for corner values y (positions give F, velocities give F_dot).
template <class T>
inline Mat3<T> corner_gradient(const T y[4][3], const T g[3][3]) {
  Mat3<T> G;
  T d[3][3];
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < 3; ++i) d[a][i] = y[a + 1][i] - y[0][i];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G.m[i][j] = dot3(d[0][i], g[0][j], d[1][i], g[1][j], d[2][i], g[2][j]);
  return G;
}

template <class T>
inline void load_velocities(const ElementContext<T>& c, const std::int32_t n[4], T v[4][3]) {
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) v[a][k] = c.v[k][n[a]];
}

// Writes f_c = -V P g_c for c = 1..3 and f_0 = -(f_1 + f_2 + f_3).
template <class T>
inline void store_corner_forces(const ElementContext<T>& c, std::size_t t, const Mat3<T>& P, const T g[3][3],
                                T volume) {
  T f0[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < 3; ++i) {
      const T fi = -volume * dot3(P.m[i][0], g[a][0], P.m[i][1], g[a][1], P.m[i][2], g[a][2]);
      c.corner_force[3 * (a + 1) + i][t] = fi;
      f0[i] -= fi;
    }
  }
  for (int i = 0; i < 3; ++i) c.corner_force[i][t] = f0[i];
}

template <class T>
inline Mat3<T> mul(const Mat3<T>& A, const Mat3<T>& B) {
  Mat3<T> C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C.m[i][j] = dot3(A.m[i][0], B.m[0][j], A.m[i][1], B.m[1][j], A.m[i][2], B.m[2][j]);
  return C;
}

// A^T B
template <class T>
inline Mat3<T> mul_tn(const Mat3<T>& A, const Mat3<T>& B) {
  Mat3<T> C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C.m[i][j] = dot3(A.m[0][i], B.m[0][j], A.m[1][i], B.m[1][j], A.m[2][i], B.m[2][j]);
  return C;
}

// sym(A) = (A + A^T) / 2
template <class T>
inline Mat3<T> sym(const Mat3<T>& A) {
  Mat3<T> S;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) S.m[i][j] = scalar_t<T>(0.5) * (A.m[i][j] + A.m[j][i]);
  return S;
}

template <class T>
inline T trace(const Mat3<T>& A) { return A.m[0][0] + A.m[1][1] + A.m[2][2]; }

template <class T>
inline T ddot(const Mat3<T>& A, const Mat3<T>& B) {
  T s{};  // 0 (scalar) or every lane 0
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += A.m[i][j] * B.m[i][j];
  return s;
}

// Isotropic Hooke law on a symmetric strain: a tr(e) I + 2 b e (the diagonal fused).
template <class T>
inline Mat3<T> hooke(const Mat3<T>& e, scalar_t<T> a, scalar_t<T> b) {
  using S = scalar_t<T>;
  Mat3<T> s;
  const T tr = trace(e);
  const T a_tr = a * tr, two_b = splat<T>(S(2) * b);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s.m[i][j] = i == j ? simd::mul_add(two_b, e.m[i][j], a_tr) : two_b * e.m[i][j];
  return s;
}

template <class T>
inline void add_to(Mat3<T>& A, const Mat3<T>& B) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A.m[i][j] += B.m[i][j];
}

template <class T>
inline Mat3<T> quat_to_matrix(const T q[4]) {
  using S = scalar_t<T>;
  using simd::mul_add;
  using simd::mul_sub;
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  const T one = splat<T>(S(1)), two = splat<T>(S(2));
  Mat3<T> R;
  // 1 - 2 (u u + v v) and 2 (u v -+ w t), one rounding per fused term.
  R.m[0][0] = simd::neg_mul_add(two, mul_add(y, y, z * z), one);
  R.m[1][1] = simd::neg_mul_add(two, mul_add(x, x, z * z), one);
  R.m[2][2] = simd::neg_mul_add(two, mul_add(x, x, y * y), one);
  R.m[0][1] = S(2) * mul_sub(x, y, w * z); R.m[0][2] = S(2) * mul_add(x, z, w * y);
  R.m[1][0] = S(2) * mul_add(x, y, w * z); R.m[1][2] = S(2) * mul_sub(y, z, w * x);
  R.m[2][0] = S(2) * mul_sub(x, z, w * y); R.m[2][1] = S(2) * mul_add(y, z, w * x);
  return R;
}

// Tolerance of the rotation iteration: a step below it ends the iteration (rad).
template <class T>
inline scalar_t<T> rotation_tolerance() {
  using S = scalar_t<T>;
  return std::numeric_limits<S>::epsilon() < S(1e-10) ? S(1e-12) : S(4e-6);
}

// The escape from an iterate where Newton's Hessian is not positive definite (extract_rotation):
// the body-frame rotation p that takes the current rotation R (with M = R^T A) to the *global*
// maximiser of tr(R^T A) over all rotations. tr(R(p)^T M) is the quadratic form p^T N p of Horn's symmetric 4x4 matrix N (1987,
// "Closed-form solution of absolute orientation using unit quaternions"), so the maximiser is the
// eigenvector of N's largest eigenvalue, found here by cyclic Jacobi rotations (deterministic:
// a fixed order, IEEE operations only). Where that eigenvalue is (numerically) repeated, p is the
// projection of the current rotation (1, 0, 0, 0) onto its eigenspace: the nearest maximiser, so a
// degenerate (flat) element keeps its rotation instead of jumping between equivalent ones.
// Returns false, leaving p alone, when the current rotation is already a maximiser (within
// rounding) or p would move it by less than `tol` rad, or on non-finite input: the iteration
// has then converged.
// Scalar only: the batched iteration calls it lane by lane (tet_batch.hpp), so a lane does the
// same arithmetic as the scalar code. It is the rare path: a warm start more than 90 deg away
// from the answer (a body turned over: at 180 deg the gradient of tr(R^T A) vanishes and Newton's
// Hessian is indefinite, a saddle no local method leaves), an inverted tet whose stretches changed
// order since the last step, or a flat or mirrored tet (a degenerate maximum, where it returns
// false). For det A < 0 the global maximiser is the
// rotation of the SVD with the smallest singular value negated (invertible FEM).
template <class S>
inline bool max_trace_escape(const Mat3<S>& M, S tol, S p[4]) {
  static_assert(std::is_floating_point_v<S>);
  S a[4][4];
  a[0][0] = M.m[0][0] + M.m[1][1] + M.m[2][2];
  a[1][1] = M.m[0][0] - M.m[1][1] - M.m[2][2];
  a[2][2] = M.m[1][1] - M.m[0][0] - M.m[2][2];
  a[3][3] = M.m[2][2] - M.m[0][0] - M.m[1][1];
  a[0][1] = a[1][0] = M.m[2][1] - M.m[1][2];
  a[0][2] = a[2][0] = M.m[0][2] - M.m[2][0];
  a[0][3] = a[3][0] = M.m[1][0] - M.m[0][1];
  a[1][2] = a[2][1] = M.m[0][1] + M.m[1][0];
  a[1][3] = a[3][1] = M.m[0][2] + M.m[2][0];
  a[2][3] = a[3][2] = M.m[1][2] + M.m[2][1];
  const S current = a[0][0];  // tr(M): the value at the current rotation
  S v[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  constexpr S eps = std::numeric_limits<S>::epsilon();
  for (int sweep = 0; sweep < 12; ++sweep) {
    S off = 0, diag = 0;
    for (int i = 0; i < 4; ++i) {
      diag += a[i][i] * a[i][i];
      for (int j = i + 1; j < 4; ++j) off += a[i][j] * a[i][j];
    }
    if (!(off > S(1e-4) * eps * eps * diag)) break;  // diagonal to rounding (also stops on NaN)
    for (int r = 0; r < 3; ++r)
      for (int c = r + 1; c < 4; ++c) {
        const S arc = a[r][c];
        if (arc == S(0)) continue;
        const S theta = (a[c][c] - a[r][r]) / (S(2) * arc);
        const S at = std::fabs(theta);
        // t = tan of the rotation angle, the smaller root of t^2 + 2 theta t - 1 = 0.
        S t = at > S(1e15) ? S(0.5) / at : S(1) / (at + std::sqrt(at * at + S(1)));
        if (theta < S(0)) t = -t;
        const S cs = S(1) / std::sqrt(t * t + S(1)), sn = t * cs;
        for (int k = 0; k < 4; ++k) {
          if (k == r || k == c) continue;
          const S akr = a[k][r], akc = a[k][c];
          a[k][r] = a[r][k] = cs * akr - sn * akc;
          a[k][c] = a[c][k] = sn * akr + cs * akc;
        }
        a[r][r] -= t * arc;
        a[c][c] += t * arc;
        a[r][c] = a[c][r] = S(0);
        for (int k = 0; k < 4; ++k) {
          const S vkr = v[k][r], vkc = v[k][c];
          v[k][r] = cs * vkr - sn * vkc;
          v[k][c] = sn * vkr + cs * vkc;
        }
      }
  }
  int top = 0;
  S scale = std::fabs(a[0][0]);
  for (int i = 1; i < 4; ++i) {
    if (a[i][i] > a[top][top]) top = i;
    scale = std::fmax(scale, std::fabs(a[i][i]));
  }
  const S lmax = a[top][top], gap = S(64) * eps * scale;
  if (!(lmax > current + gap)) return false;  // already a maximiser (or NaN)
  S n[4] = {0, 0, 0, 0};
  for (int i = 0; i < 4; ++i)
    if (a[i][i] >= lmax - gap)
      for (int k = 0; k < 4; ++k) n[k] += v[0][i] * v[k][i];
  S norm2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3];
  if (!(norm2 > S(1e-2))) {  // the current rotation is (nearly) orthogonal to the eigenspace
    for (int k = 0; k < 4; ++k) n[k] = v[k][top];
    norm2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3];
  }
  const S inv = (n[0] < S(0) ? S(-1) : S(1)) / std::sqrt(norm2);  // the shorter way round
  for (int k = 0; k < 4; ++k) n[k] *= inv;
  if (!(S(4) * (n[1] * n[1] + n[2] * n[2] + n[3] * n[3]) > tol * tol)) return false;  // angle ~ 2 |n_vec|
  for (int k = 0; k < 4; ++k) p[k] = n[k];
  return true;
}

// q <- q * d (Hamilton product: d is a body-frame increment), not normalised. Each term after
// the first is fused into the running sum (simd::mul_add).
template <class T>
inline void quat_mul(const T q[4], const T d[4], T out[4]) {
  using simd::mul_add;
  using simd::neg_mul_add;
  out[0] = neg_mul_add(q[3], d[3], neg_mul_add(q[2], d[2], neg_mul_add(q[1], d[1], q[0] * d[0])));
  out[1] = neg_mul_add(q[3], d[2], mul_add(q[2], d[3], mul_add(q[1], d[0], q[0] * d[1])));
  out[2] = mul_add(q[3], d[1], mul_add(q[2], d[0], neg_mul_add(q[1], d[3], q[0] * d[2])));
  out[3] = mul_add(q[3], d[0], neg_mul_add(q[2], d[1], mul_add(q[1], d[2], q[0] * d[3])));
}

// |q|^2 of a quaternion (fused like dot3).
template <class T>
inline T norm2_4(const T n[4]) {
  return simd::mul_add(n[3], n[3], simd::mul_add(n[2], n[2], simd::mul_add(n[1], n[1], n[0] * n[0])));
}

// One escape on a scalar rotation: q <- q * p normalised (max_trace_escape). Returns false when
// the iteration has converged instead.
template <class S>
inline bool escape_rotation(const Mat3<S>& M, S q[4], S tol) {
  S p[4];
  if (!max_trace_escape(M, tol, p)) return false;
  S n[4];
  quat_mul(q, p, n);
  const S inv = S(1) / std::sqrt(norm2_4(n));
  for (int k = 0; k < 4; ++k) q[k] = n[k] * inv;
  return true;
}

// One Newton step of the rotation iteration (extract_rotation) at M = R^T A, shared by the
// scalar loop and the lanes (tet_batch.hpp) so that both do the same operations.
// H = tr(M) I - sym(M) must be positive definite for the step to be taken (Sylvester): tr > 0,
// h00 > 0, minor = h00 h11 - h01^2 > 0 and det > 1e-6 scale, scale = tr^3. tr > 0 is implied by
// positive definiteness (tr(H) = 2 tr(M)), but with tr < 0 the scale is negative and an
// indefinite H (det < 0) passed, so that a half turn with a small stretch along its axis stopped
// at the saddle (test_rotation_reference.cpp). w = H^-1 g by cofactors, angle2 = |w|^2 (rad^2).
template <class T>
struct RotationStep {
  T tr, h00, minor, det, scale;
  T w[3];
  T angle2;
};

template <class T>
inline RotationStep<T> rotation_step(const Mat3<T>& M) {
  using S = scalar_t<T>;
  using simd::mul_sub;
  RotationStep<T> s;
  const T g[3] = {M.m[2][1] - M.m[1][2], M.m[0][2] - M.m[2][0], M.m[1][0] - M.m[0][1]};
  s.tr = trace(M);
  // H = tr I - sym(M), symmetric.
  const T h00 = s.tr - M.m[0][0], h11 = s.tr - M.m[1][1], h22 = s.tr - M.m[2][2];
  const T h01 = S(-0.5) * (M.m[0][1] + M.m[1][0]);
  const T h02 = S(-0.5) * (M.m[0][2] + M.m[2][0]);
  const T h12 = S(-0.5) * (M.m[1][2] + M.m[2][1]);
  const T c00 = mul_sub(h11, h22, h12 * h12), c01 = mul_sub(h02, h12, h01 * h22), c02 = mul_sub(h01, h12, h02 * h11);
  s.h00 = h00;
  s.det = dot3(h00, c00, h01, c01, h02, c02);
  s.scale = s.tr * s.tr * s.tr;
  const T c11 = mul_sub(h00, h22, h02 * h02), c12 = mul_sub(h01, h02, h00 * h12), c22 = mul_sub(h00, h11, h01 * h01);
  s.minor = c22;
  const T inv = S(1) / s.det;
  s.w[0] = dot3(c00, g[0], c01, g[1], c02, g[2]) * inv;
  s.w[1] = dot3(c01, g[0], c11, g[1], c12, g[2]) * inv;
  s.w[2] = dot3(c02, g[0], c12, g[1], c22, g[2]) * inv;
  s.angle2 = dot3(s.w[0], s.w[0], s.w[1], s.w[1], s.w[2], s.w[2]);
  return s;
}

// Whether the Newton update just taken (step s) is the last one needed, without computing the
// next step to check: from a point where H is positive definite, the step after an update w is
// at most about 0.11 K |w|^3 with K = tr^3 / det (the iteration converges cubically here;
// measured over 4.4 million random stretches from 1e-3 to 1e3, a third of them inverted, and
// warm starts 1e-5 to 0.5 rad away: at most 0.112 K |w|^3 outside the round-off floor). The
// update is final when K |w|^3 < tol, i.e. (9x margin) the check would have found a step below
// tol and stopped: compared squared, scale^2 angle2^3 < tol^2 det^2, without a square root or a
// division (overflow or NaN compare false: the check then runs).
template <class T>
inline auto rotation_step_is_final(const RotationStep<T>& s, scalar_t<T> tol) {
  const T k = s.scale * s.angle2, d = tol * s.det;
  return (k * k) * s.angle2 < d * d;
}

// n = q * (1, w/2), normalised: the body-frame Newton increment w (rad) applied to q.
template <class T>
inline void rotate_by_step(const T q[4], const T w[3], T n[4]) {
  using S = scalar_t<T>;
  const T d[4] = {splat<T>(S(1)), S(0.5) * w[0], S(0.5) * w[1], S(0.5) * w[2]};
  quat_mul(q, d, n);
  const T r2 = norm2_4(n);
  T r;
  if constexpr (std::is_floating_point_v<T>) {
    r = std::sqrt(r2);
  } else {
    r = simd::sqrt(r2);
  }
  const T qinv = S(1) / r;
  for (int k = 0; k < 4; ++k) n[k] *= qinv;
}

// Rotation part of A: the unit quaternion q maximising tr(R^T A), refined in place from the
// given start (the previous step's rotation). With M = R^T A, a body-frame rotation
// R <- R exp([w]x) changes tr(R^T A) by g.w - w^T H w / 2 + O(|w|^3), where
// g = (M32 - M23, M13 - M31, M21 - M12) and H = tr(M) I - sym(M); Newton's step is w = H^-1 g.
// Near the maximiser H is positive definite (its eigenvalues are sums of two signed singular
// values, s1 + s2, s1 + s3, s2 + s3 with s3 negated for det A < 0) and the iteration converges
// fast (cubically, measured: rotation_step_is_final): warm-started, one update, after which the
// step it would take next is bounded from the one just taken, so the loop ends without
// computing it (M, H and the solve again: a third of the iteration's cost) when that bound is
// below the tolerance; otherwise it computes the step and stops when it is below tol. Where H is not positive definite the iterate
// is not near the maximiser: a warm start more than 90 deg away (a body turned over, whose
// start is a saddle or a minimum of tr(R^T A) with g = 0 exactly, where a local method stays
// forever and takes a rigid rotation for a huge strain), an inverted element whose signed
// stretches changed order, or a degenerate (flat, mirrored) element. There the iterate jumps to
// the global maximiser (max_trace_escape: the top eigenvector of Horn's quaternion matrix, the
// nearest one when it is not unique) and Newton goes on from there; at a (degenerate) maximum
// already, it stays. tr(R^T A) has no other local maximum, so this is the rotation Newton would
// reach from a good start; the gradient step of Müller et al. 2016 used here before went round
// in circles for 64 iterations on inverted elements started far from the answer, where |tr M|
// is small and the step w = g / |tr M| huge (tests/kernels/test_rotation_reference.cpp).
// The quaternion update (1, w/2) normalised needs no sin/cos; its angle error only slows
// convergence, it does not move the fixed point.
template <class T>
inline Mat3<T> extract_rotation(const Mat3<T>& A, T q[4]) {
  constexpr int kMaxIterations = 64;
  const T tol = rotation_tolerance<T>();
  Mat3<T> R = quat_to_matrix(q);
  for (int it = 0; it < kMaxIterations; ++it) {
    const Mat3<T> M = mul_tn(R, A);
    const RotationStep<T> s = rotation_step(M);
    const bool newton = s.tr > 0 && s.h00 > 0 && s.minor > 0 && s.det > T(1e-6) * s.scale;
    if (!newton) {  // far from the maximiser or at a degenerate one (also NaN): jump to it
      if (escape_rotation(M, q, tol)) {
        R = quat_to_matrix(q);
        continue;
      }
      break;  // a maximiser already (within rounding)
    }
    if (!(s.angle2 > tol * tol)) break;  // converged (also NaN)
    T n[4];
    rotate_by_step(q, s.w, n);
    for (int k = 0; k < 4; ++k) q[k] = n[k];
    R = quat_to_matrix(q);
    if (rotation_step_is_final(s, tol)) break;  // the next step would be below tol: skip computing it
  }
  return R;
}

}  // namespace pliant::detail
