// A std::vector whose storage starts on a 64-byte (cache line) boundary, for SoA arrays.
//
// Large arrays (kHugeFrom bytes or more: a level of more than about 130k tets in float) are also
// offered to Linux's transparent huge pages, and staggered:
// - Their memory starts on a 2 MiB boundary and is advised MADV_HUGEPAGE before the vector first
//   writes it, so that it is faulted in as 2 MiB pages where the system allows it (THP "always"
//   or "madvise", Debian's default; with "never" the advice does nothing). At 1M tets the element
//   pass's corner loads and the gather's corner-force loads stray over tens of MiB, and with 4 KiB
//   pages many of them also miss the TLB.
// - The array itself starts kStaggerStep x k bytes after that boundary, k = 0..15 taken from the
//   address (bits 21-24), so that arrays read at the same index (a tet's 4 corner, 9 gradient, 4
//   rotation arrays and its volume) do not all fall in the same cache set: with every array on a
//   2 MiB boundary they would, and a 16-way L2 cannot hold 18 streams of one set.
// Cost: each such array takes its size + 65 KiB rounded up to whole 2 MiB pages, all resident under
// THP (at most 2 MiB more each). Measured (peak resident size of `pliant run` of a box, Xeon guest,
// THP madvise): 150k tets 97 -> 147 MB in float, 118 -> 155 MB in double (arrays of 0.6-1.2 MB
// each fill a huge page); 1M tets 327 -> 347 MB and 462 -> 481 MB; without THP, or with
// PLIANT_HUGE_PAGES=0 in the environment, nothing. Speed (perf/layout_ab blocked, whole step):
// docs/performance.md, "Huge pages". Results are the same bits: only addresses change.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace pliant {

// The huge page (x86-64 Linux THP: 2 MiB); the array size (bytes) from which an array gets huge
// pages (the node arrays of a 1M-tet level are 0.8 MiB in float and gain as much as the tet
// arrays); the stagger's step (a 4 KiB page + a cache line: another L2 set and another L1 set)
// and the room kept for it (16 steps).
inline constexpr std::size_t kHugePage = std::size_t(2) << 20;
inline constexpr std::size_t kHugeFrom = kHugePage / 4;
inline constexpr std::size_t kStaggerStep = 4096 + 64;
inline constexpr std::size_t kStaggerRoom = 16 * kStaggerStep;

// The storage of the large arrays.
struct HugeArrays {
  // Bytes allocated for a large array of `bytes`: with the stagger's room, in whole huge pages.
  static constexpr std::size_t footprint(std::size_t bytes) {
    return (bytes + kStaggerRoom + kHugePage - 1) / kHugePage * kHugePage;
  }
  static void* allocate(std::size_t bytes);
  static void deallocate(void* p, std::size_t bytes);
};

inline void* HugeArrays::allocate(std::size_t bytes) {
  const std::size_t size = footprint(bytes);
  void* base = ::operator new(size, std::align_val_t{kHugePage});
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // Advice only: without THP the array keeps small pages. PLIANT_HUGE_PAGES=0 (or off, false, no)
  // in the environment withholds it (read at each large allocation: they are few), for a host that
  // wants the memory more than the speed (the cost, measured, is at the top of this file).
  const char* env = std::getenv("PLIANT_HUGE_PAGES");
  const bool withheld = env && (std::strcmp(env, "0") == 0 || std::strcmp(env, "off") == 0 ||
                                std::strcmp(env, "false") == 0 || std::strcmp(env, "no") == 0);
  if (!withheld) (void)::madvise(base, size, MADV_HUGEPAGE);
#endif
  const std::size_t k = (reinterpret_cast<std::uintptr_t>(base) / kHugePage) & 15u;
  return static_cast<char*>(base) + k * kStaggerStep;
}
inline void HugeArrays::deallocate(void* p, std::size_t bytes) {
  // The stagger is under one huge page: rounding down finds the allocation.
  void* base = reinterpret_cast<void*>(reinterpret_cast<std::uintptr_t>(p) / kHugePage * kHugePage);
  // The unsized form: clang (14, the TSan build's compiler) declares the sized aligned delete only
  // with -fsized-deallocation, and the size is not needed to free.
  (void)bytes;
  ::operator delete(base, std::align_val_t{kHugePage});
}

template <class T>
struct CacheAlignedAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlign{64};
  static_assert(kStaggerStep % 64 == 0, "a staggered array must stay on a cache line");
  CacheAlignedAllocator() = default;
  template <class U>
  CacheAlignedAllocator(const CacheAlignedAllocator<U>&) {}
  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes >= kHugeFrom) return static_cast<T*>(HugeArrays::allocate(bytes));
    return static_cast<T*>(::operator new(bytes, kAlign));
  }
  void deallocate(T* p, std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes >= kHugeFrom)
      HugeArrays::deallocate(p, bytes);
    else
      ::operator delete(p, kAlign);
  }
  template <class U>
  bool operator==(const CacheAlignedAllocator<U>&) const { return true; }
};

template <class T>
using AlignedVector = std::vector<T, CacheAlignedAllocator<T>>;

}  // namespace pliant
