// Private helpers of the element kernels: a batch of W tets in the lanes of one vector
// register (GCC/Clang vector extensions), so that an element pass runs W tets per instruction.
// Every lane does exactly the IEEE operations, in exactly the order, of the scalar code it
// mirrors (no FMA contraction, no reassociation, correctly rounded sqrt and division), so a tet's
// result does not depend on which lane, batch or thread computed it.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
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

}  // namespace native

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
