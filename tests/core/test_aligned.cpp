// The SoA arrays' allocator (pliant/aligned.hpp): small arrays on a cache line; large ones on a
// cache line too, a whole number of kStaggerStep after a 2 MiB boundary, usable over their whole
// length, and not all at the same offset from it (the point of the stagger).
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <vector>

#include "pliant/aligned.hpp"

namespace pliant {
namespace {

std::uintptr_t address(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }

TEST(Aligned, SmallArraysStartOnACacheLine) {
  for (std::size_t n : {1u, 7u, 1000u, 100000u}) {
    AlignedVector<float> a(n, 1.0f);
    EXPECT_EQ(address(a.data()) % 64, 0u) << n;
  }
}

TEST(Aligned, LargeArraysAreStaggeredAfterAHugePageAndUsableToTheirEnd) {
  // 16 arrays alive at once, of several sizes from kHugeFrom up: each on a cache line, a whole
  // number of stagger steps (under 16) after a 2 MiB boundary; written and read back to the last
  // element (a sanitizer build checks the bounds and the matching delete).
  std::vector<AlignedVector<double>> arrays;
  std::set<std::uintptr_t> offsets;
  for (int i = 0; i < 16; ++i) {
    const std::size_t n = kHugeFrom / sizeof(double) + std::size_t(i) * 100003;
    arrays.emplace_back(n, double(i));
    const AlignedVector<double>& a = arrays.back();
    const std::uintptr_t off = address(a.data()) % kHugePage;
    EXPECT_EQ(address(a.data()) % 64, 0u) << i;
    EXPECT_EQ(off % kStaggerStep, 0u) << i;
    EXPECT_LT(off / kStaggerStep, 16u) << i;
    offsets.insert(off);
  }
  for (int i = 0; i < 16; ++i) {
    AlignedVector<double>& a = arrays[std::size_t(i)];
    a.back() = -1.0;
    EXPECT_EQ(a.front(), double(i));
    EXPECT_EQ(a.back(), -1.0);
  }
  // With every array on the same offset they would share cache sets (aligned.hpp says why).
  EXPECT_GT(offsets.size(), 1u);
  arrays.clear();  // every delete must find its allocation (ASan reports a mismatch)
  AlignedVector<float> grown;
  for (int i = 0; i < 1 << 20; ++i) grown.push_back(float(i));  // reallocations across the threshold
  EXPECT_EQ(grown[123456], 123456.0f);
}

}  // namespace
}  // namespace pliant
