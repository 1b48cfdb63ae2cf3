// Private helpers of the element kernels: a batch of W tets in the lanes of one vector
// register (GCC/Clang vector extensions), so that an element pass runs W tets per instruction.
// Every lane does exactly the IEEE operations, in exactly the order, of the scalar code it
// mirrors (no reassociation, correctly rounded sqrt and division, and fused multiply-adds only
// where both codes ask for one through mul_add below: the build keeps -ffp-contract=off, so the
// compiler never fuses on its own), so a tet's result does not depend on which lane, batch or
// thread computed it.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

// PLIANT_FMA: 1 when the target has a fused multiply-add instruction (x86 FMA3, which every
// AVX2 and AVX-512 CPU has, or an Arm FPU), 0 otherwise (e.g. -march=x86-64, SSE2 only, where
// std::fma is a slow software routine). With 1, mul_add(a, b, c) is a * b + c rounded once
// (std::fma in scalar code, vfmadd in the lanes); with 0, it is a * b rounded, then + c rounded.
// Either way the scalar code and every vector lane give the same bits and results do not depend
// on the thread count, but an FMA build and a non-FMA build of the same source differ at
// round-off. Override with -DPLIANT_FMA=0 (e.g. to compare against a non-FMA build).
#ifndef PLIANT_FMA
#if defined(__FMA__) || defined(__ARM_FEATURE_FMA) || defined(__aarch64__)
#define PLIANT_FMA 1
#else
#define PLIANT_FMA 0
#endif
#endif

namespace pliant::simd {

#if defined(__AVX512F__)
#define PLIANT_SIMD_BYTES 64
#elif defined(__AVX__)
#define PLIANT_SIMD_BYTES 32
#else
#define PLIANT_SIMD_BYTES 16
#endif
// A batch is kUnroll native registers wide: the lanes of different registers are independent
// chains, which keeps the FP pipes busy through the latency of the rotation iteration (one
// register's worth of tets leaves them idle most of the time).
#ifndef PLIANT_SIMD_UNROLL
#define PLIANT_SIMD_UNROLL 1
#endif
inline constexpr int kNativeBytes = PLIANT_SIMD_BYTES;
inline constexpr int kUnroll = PLIANT_SIMD_UNROLL;
inline constexpr int kBytes = kNativeBytes * kUnroll;

template <class T>
struct Pack;
template <>
struct Pack<float> {
  typedef float V __attribute__((vector_size(kBytes)));
  typedef std::int32_t M __attribute__((vector_size(kBytes)));  // lane masks: 0 or -1
  typedef float N __attribute__((vector_size(kNativeBytes)));    // one register
  static constexpr int W = kBytes / 4;
  static constexpr int NW = kNativeBytes / 4;
};
template <>
struct Pack<double> {
  typedef double V __attribute__((vector_size(kBytes)));
  typedef std::int64_t M __attribute__((vector_size(kBytes)));
  typedef double N __attribute__((vector_size(kNativeBytes)));
  static constexpr int W = kBytes / 8;
  static constexpr int NW = kNativeBytes / 8;
};

// Full batch: contiguous load/store at p. Partial batch (count < W): lanes past `count` repeat
// the last valid element on load and are not stored.
template <class T>
inline typename Pack<T>::V load(const T* p, int count) {
  typename Pack<T>::V v = {};
  if (count == Pack<T>::W) {
    std::memcpy(&v, p, sizeof(v));
  } else {
    for (int l = 0; l < Pack<T>::W; ++l) v[l] = p[std::min(l, count - 1)];
  }
  return v;
}

template <class T>
inline void store(T* p, int count, const typename Pack<T>::V& v) {
  if (count == Pack<T>::W) {
    std::memcpy(p, &v, sizeof(v));
  } else {
    for (int l = 0; l < count; ++l) p[l] = v[l];
  }
}

namespace native {

// n[l] = base[idx[l]] for the lanes of one register.
inline Pack<float>::N gather(const float* base, const std::int32_t* idx) {
#if PLIANT_SIMD_BYTES == 64
  return (Pack<float>::N)_mm512_mask_i32gather_ps(_mm512_setzero_ps(), __mmask16(0xFFFF), _mm512_loadu_si512(idx),
                                                  base, 4);
#elif PLIANT_SIMD_BYTES == 32 && defined(__AVX2__)
  const __m256 all = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  return (Pack<float>::N)_mm256_mask_i32gather_ps(_mm256_setzero_ps(), base,
                                                  _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)), all, 4);
#else
  Pack<float>::N n;
  for (int l = 0; l < Pack<float>::NW; ++l) n[l] = base[idx[l]];
  return n;
#endif
}
inline Pack<double>::N gather(const double* base, const std::int32_t* idx) {
#if PLIANT_SIMD_BYTES == 64
  return (Pack<double>::N)_mm512_mask_i32gather_pd(
      _mm512_setzero_pd(), __mmask8(0xFF), _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)), base, 8);
#elif PLIANT_SIMD_BYTES == 32 && defined(__AVX2__)
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  return (Pack<double>::N)_mm256_mask_i32gather_pd(_mm256_setzero_pd(), base,
                                                   _mm_loadu_si128(reinterpret_cast<const __m128i*>(idx)), all, 8);
#else
  Pack<double>::N n;
  for (int l = 0; l < Pack<double>::NW; ++l) n[l] = base[idx[l]];
  return n;
#endif
}

// base[idx[l]] = n[l] for the first `count` lanes of one register (count <= NW); the others are
// not stored. The indices of the stored lanes must differ (they are distinct tets), so the
// order of the stores does not matter. AVX-512: one masked scatter instead of extracting and
// storing lane by lane.
inline void scatter(float* base, const std::int32_t* idx, int count, const Pack<float>::N& n) {
#if PLIANT_SIMD_BYTES == 64
  const __mmask16 m = count >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << count) - 1);
  _mm512_mask_i32scatter_ps(base, m, _mm512_loadu_si512(idx), __m512(n), 4);
#else
  for (int l = 0; l < count; ++l) base[idx[l]] = n[l];
#endif
}
inline void scatter(double* base, const std::int32_t* idx, int count, const Pack<double>::N& n) {
#if PLIANT_SIMD_BYTES == 64
  const __mmask8 m = count >= 8 ? __mmask8(0xFF) : __mmask8((1u << count) - 1);
  _mm512_mask_i32scatter_pd(base, m, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)), __m512d(n), 8);
#else
  for (int l = 0; l < count; ++l) base[idx[l]] = n[l];
#endif
}

// out[l] = base[idx[l]] for NI int32 lanes (NI: a native register's worth of floats).
inline constexpr int kNativeInts = kNativeBytes / 4;
inline void gather_i32(const std::int32_t* base, const std::int32_t* idx, std::int32_t* out) {
#if PLIANT_SIMD_BYTES == 64
  // The masked form with a zero source: the unmasked one starts from _mm512_undefined_epi32,
  // which GCC 12 warns about (-Wuninitialized), as for the float gather above.
  _mm512_storeu_si512(out, _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), __mmask16(0xFFFF),
                                                       _mm512_loadu_si512(idx), base, 4));
#elif PLIANT_SIMD_BYTES == 32 && defined(__AVX2__)
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out),
                      _mm256_i32gather_epi32(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)), 4));
#else
  for (int l = 0; l < kNativeInts; ++l) out[l] = base[idx[l]];
#endif
}

// Corner positions from an interleaved node array xp (4 values per node: x y z pad): out[k][l]
// = xp[4 * idx[l] + k] for k = 0, 1, 2, the lanes of one register. The same values as three
// gathers from x[3][n]; with AVX-512 and AVX2 one 16 (float) or 32 (double) byte load per node and a
// transpose, instead of 3 gathers of one element per lane.
inline void gather_xyz(const float* xp, const std::int32_t* idx, Pack<float>::N out[3]) {
#if PLIANT_SIMD_BYTES == 64
  // r[j] holds nodes j, j + 4, j + 8, j + 12 in its four 128-bit blocks. (The maskz_ forms with
  // every lane set are the plain instructions; the plain intrinsics warn with GCC 12.)
  __m512 r[4];
  for (int j = 0; j < 4; ++j) {
    __m512 v = _mm512_zextps128_ps512(_mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j])));
    v = _mm512_maskz_insertf32x4(__mmask16(0xFFFF), v, _mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j + 4])), 1);
    v = _mm512_maskz_insertf32x4(__mmask16(0xFFFF), v, _mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j + 8])), 2);
    r[j] = _mm512_maskz_insertf32x4(__mmask16(0xFFFF), v, _mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j + 12])), 3);
  }
  // 4 x 4 transpose within each block: block b of out[k] = component k of nodes 4b .. 4b + 3.
  const __m512d t0 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(__mmask16(0xFFFF), r[0], r[1]));  // x0 x1 y0 y1
  const __m512d t1 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(__mmask16(0xFFFF), r[0], r[1]));  // z0 z1 w0 w1
  const __m512d t2 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(__mmask16(0xFFFF), r[2], r[3]));  // x2 x3 y2 y3
  const __m512d t3 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(__mmask16(0xFFFF), r[2], r[3]));  // z2 z3 w2 w3
  out[0] = (Pack<float>::N)_mm512_castpd_ps(_mm512_maskz_unpacklo_pd(__mmask8(0xFF), t0, t2));
  out[1] = (Pack<float>::N)_mm512_castpd_ps(_mm512_maskz_unpackhi_pd(__mmask8(0xFF), t0, t2));
  out[2] = (Pack<float>::N)_mm512_castpd_ps(_mm512_maskz_unpacklo_pd(__mmask8(0xFF), t1, t3));
#elif PLIANT_SIMD_BYTES == 32
  // AVX2: the same transpose on two 128-bit blocks. r[j] holds nodes j and j + 4.
  __m256 r[4];
  for (int j = 0; j < 4; ++j)
    r[j] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j]))),
                                _mm_loadu_ps(xp + 4 * std::ptrdiff_t(idx[j + 4])), 1);
  const __m256d t0 = _mm256_castps_pd(_mm256_unpacklo_ps(r[0], r[1]));  // x0 x1 y0 y1 | x4 x5 y4 y5
  const __m256d t1 = _mm256_castps_pd(_mm256_unpackhi_ps(r[0], r[1]));  // z0 z1 w0 w1 | z4 z5 w4 w5
  const __m256d t2 = _mm256_castps_pd(_mm256_unpacklo_ps(r[2], r[3]));  // x2 x3 y2 y3 | x6 x7 y6 y7
  const __m256d t3 = _mm256_castps_pd(_mm256_unpackhi_ps(r[2], r[3]));  // z2 z3 w2 w3 | z6 z7 w6 w7
  out[0] = (Pack<float>::N)_mm256_castpd_ps(_mm256_unpacklo_pd(t0, t2));
  out[1] = (Pack<float>::N)_mm256_castpd_ps(_mm256_unpackhi_pd(t0, t2));
  out[2] = (Pack<float>::N)_mm256_castpd_ps(_mm256_unpacklo_pd(t1, t3));
#else
  for (int l = 0; l < Pack<float>::NW; ++l)
    for (int k = 0; k < 3; ++k) out[k][l] = xp[4 * std::ptrdiff_t(idx[l]) + k];
#endif
}
inline void gather_xyz(const double* xp, const std::int32_t* idx, Pack<double>::N out[3]) {
#if PLIANT_SIMD_BYTES == 64
  // r[j] holds nodes j and j + 4 in its two 256-bit halves.
  __m512d r[4];
  for (int j = 0; j < 4; ++j) {
    const __m512d v = _mm512_maskz_broadcast_f64x4(__mmask8(0xFF), _mm256_loadu_pd(xp + 4 * std::ptrdiff_t(idx[j])));
    r[j] = _mm512_mask_broadcast_f64x4(v, __mmask8(0xF0), _mm256_loadu_pd(xp + 4 * std::ptrdiff_t(idx[j + 4])));
  }
  const __m512d t0 = _mm512_maskz_unpacklo_pd(__mmask8(0xFF), r[0], r[1]);  // x0 x1 z0 z1 | x4 x5 z4 z5
  const __m512d t1 = _mm512_maskz_unpackhi_pd(__mmask8(0xFF), r[0], r[1]);  // y0 y1 w0 w1 | y4 y5 w4 w5
  const __m512d t2 = _mm512_maskz_unpacklo_pd(__mmask8(0xFF), r[2], r[3]);  // x2 x3 z2 z3 | x6 x7 z6 z7
  const __m512d t3 = _mm512_maskz_unpackhi_pd(__mmask8(0xFF), r[2], r[3]);  // y2 y3 w2 w3 | y6 y7 w6 w7
  const __m512i lo = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);   // 128-bit blocks 0 of each half
  const __m512i hi = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);  // blocks 1
  out[0] = (Pack<double>::N)_mm512_permutex2var_pd(t0, lo, t2);
  out[1] = (Pack<double>::N)_mm512_permutex2var_pd(t1, lo, t3);
  out[2] = (Pack<double>::N)_mm512_permutex2var_pd(t0, hi, t2);
#elif PLIANT_SIMD_BYTES == 32
  // AVX2: one 32-byte load per node, a 4 x 4 transpose.
  __m256d a[4];
  for (int j = 0; j < 4; ++j) a[j] = _mm256_loadu_pd(xp + 4 * std::ptrdiff_t(idx[j]));
  const __m256d t0 = _mm256_unpacklo_pd(a[0], a[1]);  // x0 x1 | z0 z1
  const __m256d t1 = _mm256_unpackhi_pd(a[0], a[1]);  // y0 y1 | w0 w1
  const __m256d t2 = _mm256_unpacklo_pd(a[2], a[3]);  // x2 x3 | z2 z3
  const __m256d t3 = _mm256_unpackhi_pd(a[2], a[3]);  // y2 y3 | w2 w3
  out[0] = (Pack<double>::N)_mm256_permute2f128_pd(t0, t2, 0x20);
  out[1] = (Pack<double>::N)_mm256_permute2f128_pd(t1, t3, 0x20);
  out[2] = (Pack<double>::N)_mm256_permute2f128_pd(t0, t2, 0x31);
#else
  for (int l = 0; l < Pack<double>::NW; ++l)
    for (int k = 0; k < 3; ++k) out[k][l] = xp[4 * std::ptrdiff_t(idx[l]) + k];
#endif
}

// Correctly rounded square root per lane (the same bits as std::sqrt).
inline Pack<float>::N sqrt(Pack<float>::N x) {
#if PLIANT_SIMD_BYTES == 64
  return (Pack<float>::N)_mm512_maskz_sqrt_ps(__mmask16(0xFFFF), (__m512)x);
#elif PLIANT_SIMD_BYTES == 32
  return (Pack<float>::N)_mm256_sqrt_ps((__m256)x);
#elif defined(__SSE2__)
  return (Pack<float>::N)_mm_sqrt_ps((__m128)x);
#else
  for (int l = 0; l < Pack<float>::NW; ++l) x[l] = __builtin_sqrtf(x[l]);
  return x;
#endif
}
inline Pack<double>::N sqrt(Pack<double>::N x) {
#if PLIANT_SIMD_BYTES == 64
  return (Pack<double>::N)_mm512_maskz_sqrt_pd(__mmask8(0xFF), (__m512d)x);
#elif PLIANT_SIMD_BYTES == 32
  return (Pack<double>::N)_mm256_sqrt_pd((__m256d)x);
#elif defined(__SSE2__)
  return (Pack<double>::N)_mm_sqrt_pd((__m128d)x);
#else
  for (int l = 0; l < Pack<double>::NW; ++l) x[l] = __builtin_sqrt(x[l]);
  return x;
#endif
}

// Fused multiply-adds of one register (PLIANT_FMA only): a * b + c, a * b - c and c - a * b,
// each rounded once. Only the x86 widths have them here; other targets take the lane loop of
// mul_add below.
#if PLIANT_FMA && (defined(__x86_64__) || defined(__i386__)) && defined(__FMA__)
#define PLIANT_SIMD_NATIVE_FMA 1
#if PLIANT_SIMD_BYTES == 64
#define PLIANT_FMA_OPS(NAME, OP)                                                                       \
  inline Pack<float>::N NAME(Pack<float>::N a, Pack<float>::N b, Pack<float>::N c) {                   \
    return (Pack<float>::N)_mm512_##OP##_ps((__m512)a, (__m512)b, (__m512)c);                          \
  }                                                                                                    \
  inline Pack<double>::N NAME(Pack<double>::N a, Pack<double>::N b, Pack<double>::N c) {               \
    return (Pack<double>::N)_mm512_##OP##_pd((__m512d)a, (__m512d)b, (__m512d)c);                      \
  }
#elif PLIANT_SIMD_BYTES == 32
#define PLIANT_FMA_OPS(NAME, OP)                                                                       \
  inline Pack<float>::N NAME(Pack<float>::N a, Pack<float>::N b, Pack<float>::N c) {                   \
    return (Pack<float>::N)_mm256_##OP##_ps((__m256)a, (__m256)b, (__m256)c);                          \
  }                                                                                                    \
  inline Pack<double>::N NAME(Pack<double>::N a, Pack<double>::N b, Pack<double>::N c) {               \
    return (Pack<double>::N)_mm256_##OP##_pd((__m256d)a, (__m256d)b, (__m256d)c);                     \
  }
#else
#define PLIANT_FMA_OPS(NAME, OP)                                                                       \
  inline Pack<float>::N NAME(Pack<float>::N a, Pack<float>::N b, Pack<float>::N c) {                   \
    return (Pack<float>::N)_mm_##OP##_ps((__m128)a, (__m128)b, (__m128)c);                             \
  }                                                                                                    \
  inline Pack<double>::N NAME(Pack<double>::N a, Pack<double>::N b, Pack<double>::N c) {               \
    return (Pack<double>::N)_mm_##OP##_pd((__m128d)a, (__m128d)b, (__m128d)c);                         \
  }
#endif
PLIANT_FMA_OPS(fmadd, fmadd)    // a * b + c
PLIANT_FMA_OPS(fmsub, fmsub)    // a * b - c
PLIANT_FMA_OPS(fnmadd, fnmadd)  // c - a * b
#undef PLIANT_FMA_OPS
#else
#define PLIANT_SIMD_NATIVE_FMA 0
#endif

}  // namespace native

// The three multiply-adds of the kernels, for a scalar (float, double) or a vector of them.
// With PLIANT_FMA each is rounded once (std::fma, exactly what the fused instruction computes,
// since negating an operand is exact); without it each is a product rounded, then a sum
// rounded, the arithmetic the code had before these helpers. Scalar code and lanes call the
// same helper at the same place, so they keep giving the same bits.
namespace fma_impl {
template <class T>
inline constexpr bool kIsScalar = std::is_floating_point_v<T>;

// op: 0 = a * b + c, 1 = a * b - c, 2 = c - a * b.
template <int Op, class T>
inline T fused(const T& a, const T& b, const T& c) {
  if constexpr (!PLIANT_FMA) {
    if constexpr (Op == 0) return a * b + c;
    else if constexpr (Op == 1) return a * b - c;
    else return c - a * b;
  } else if constexpr (kIsScalar<T>) {
    if constexpr (Op == 0) return std::fma(a, b, c);
    else if constexpr (Op == 1) return std::fma(a, b, -c);
    else return std::fma(-a, b, c);
  } else {
    T out;
#if PLIANT_SIMD_NATIVE_FMA
    using S = std::remove_cvref_t<decltype(a[0])>;
    using N = typename Pack<S>::N;
    static_assert(sizeof(T) == sizeof(typename Pack<S>::V));
    for (int u = 0; u < kUnroll; ++u) {
      N na, nb, nc, r;
      std::memcpy(&na, reinterpret_cast<const char*>(&a) + u * kNativeBytes, kNativeBytes);
      std::memcpy(&nb, reinterpret_cast<const char*>(&b) + u * kNativeBytes, kNativeBytes);
      std::memcpy(&nc, reinterpret_cast<const char*>(&c) + u * kNativeBytes, kNativeBytes);
      if constexpr (Op == 0) r = native::fmadd(na, nb, nc);
      else if constexpr (Op == 1) r = native::fmsub(na, nb, nc);
      else r = native::fnmadd(na, nb, nc);
      std::memcpy(reinterpret_cast<char*>(&out) + u * kNativeBytes, &r, kNativeBytes);
    }
#else
    for (int l = 0; l < int(sizeof(T) / sizeof(a[0])); ++l) out[l] = fused<Op>(a[l], b[l], c[l]);
#endif
    return out;
  }
}
}  // namespace fma_impl

template <class T>
inline T mul_add(const T& a, const T& b, const T& c) { return fma_impl::fused<0>(a, b, c); }  // a * b + c
template <class T>
inline T mul_sub(const T& a, const T& b, const T& c) { return fma_impl::fused<1>(a, b, c); }  // a * b - c
template <class T>
inline T neg_mul_add(const T& a, const T& b, const T& c) { return fma_impl::fused<2>(a, b, c); }  // c - a * b

// v[l] = base[idx[l]] for the W lanes.
template <class T>
inline typename Pack<T>::V gather(const T* base, const std::int32_t* idx) {
  typename Pack<T>::V v;
  for (int u = 0; u < kUnroll; ++u) {
    const typename Pack<T>::N n = native::gather(base, idx + u * Pack<T>::NW);
    std::memcpy(reinterpret_cast<char*>(&v) + u * kNativeBytes, &n, kNativeBytes);
  }
  return v;
}

// base[idx[l]] = v[l] for the lanes l < count (native::scatter); the indices must differ.
template <class T>
inline void scatter(T* base, const std::int32_t* idx, int count, const typename Pack<T>::V& v) {
  for (int u = 0; u < kUnroll && count > u * Pack<T>::NW; ++u) {
    typename Pack<T>::N n;
    std::memcpy(&n, reinterpret_cast<const char*>(&v) + u * kNativeBytes, kNativeBytes);
    native::scatter(base, idx + u * Pack<T>::NW, count - u * Pack<T>::NW, n);
  }
}

// out[l] = base[idx[l]] for W int32 lanes (W a multiple of native::kNativeInts).
template <int W>
inline void gather_i32(const std::int32_t* base, const std::int32_t* idx, std::int32_t out[W]) {
  static_assert(W % native::kNativeInts == 0, "whole registers of indices");
  for (int u = 0; u < W; u += native::kNativeInts) native::gather_i32(base, idx + u, out + u);
}

// out[k][l] = xp[4 * idx[l] + k], k = 0, 1, 2, for the W lanes (native::gather_xyz).
template <class T>
inline void gather_xyz(const T* xp, const std::int32_t* idx, typename Pack<T>::V out[3]) {
  if constexpr (std::is_same_v<typename Pack<T>::V, typename Pack<T>::N>) {
    // One register per component: straight into out. (Through a local array and memcpy, GCC 12
    // kept the transposed registers on the stack and copied them over in 16-byte halves, whose
    // loads waited on the 32-byte stores: 7-10 % of the AVX2 element pass in perf samples.)
    native::gather_xyz(xp, idx, out);
    return;
  }
  for (int u = 0; u < kUnroll; ++u) {
    typename Pack<T>::N n[3];
    native::gather_xyz(xp, idx + u * Pack<T>::NW, n);
    for (int k = 0; k < 3; ++k) std::memcpy(reinterpret_cast<char*>(&out[k]) + u * kNativeBytes, &n[k], kNativeBytes);
  }
}

template <class T>
inline typename Pack<T>::V sqrt_lanes(const typename Pack<T>::V& x) {
  typename Pack<T>::V v;
  for (int u = 0; u < kUnroll; ++u) {
    typename Pack<T>::N n;
    std::memcpy(&n, reinterpret_cast<const char*>(&x) + u * kNativeBytes, kNativeBytes);
    n = native::sqrt(n);
    std::memcpy(reinterpret_cast<char*>(&v) + u * kNativeBytes, &n, kNativeBytes);
  }
  return v;
}
inline Pack<float>::V sqrt(const Pack<float>::V& x) { return sqrt_lanes<float>(x); }
inline Pack<double>::V sqrt(const Pack<double>::V& x) { return sqrt_lanes<double>(x); }

// |x| per lane by clearing the sign bit (the same bits as std::fabs).
template <class V>
inline V abs(V x) {
  using M = decltype(x < x);
  using E = std::remove_cvref_t<decltype(M{}[0])>;
  const M sign = M{} + E(E(1) << (sizeof(E) * 8 - 1));
  return (V)((M)x & ~sign);
}

template <class M>
inline bool any(const M& m) {
  constexpr int n = int(sizeof(M) / sizeof(m[0]));
  std::remove_cvref_t<decltype(m[0])> acc = 0;
  for (int l = 0; l < n; ++l) acc |= m[l];
  return acc != 0;
}

}  // namespace pliant::simd
