// The SoA arrays' allocator (pliant/aligned.hpp): small arrays on a cache line; large ones on a
// cache line too, a whole number of kStaggerStep after a 2 MiB boundary, usable over their whole
// length, and not all at the same offset from it (the point of the stagger).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
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


#if defined(__linux__)
// The VmFlags of the mapping that holds address p (/proc/self/smaps), empty if none.
std::string vm_flags_at(const void* p) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line, flags;
  bool inside = false;
  while (std::getline(smaps, line)) {
    unsigned long lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = address(p) >= lo && address(p) < hi;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line;
  }
  return flags;
}

// A large array is advised MADV_HUGEPAGE (VmFlags "hg"), unless PLIANT_HUGE_PAGES=0 withholds it.
TEST(Aligned, LargeArraysAskForHugePagesUnlessTheEnvironmentSaysNo) {
  if (!std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled")) GTEST_SKIP() << "SKIPPED: this kernel has no transparent huge pages";
  unsetenv("PLIANT_HUGE_PAGES");
  AlignedVector<float> advised(kHugePage, 1.0f);
  const std::string with = vm_flags_at(advised.data() + advised.size() / 2);
  ASSERT_FALSE(with.empty());
  EXPECT_NE(with.find(" hg"), std::string::npos) << with;
  for (const char* no : {"0", "off", "false", "no"}) {
    setenv("PLIANT_HUGE_PAGES", no, 1);
    AlignedVector<float> plain(kHugePage, 1.0f);
    const std::string without = vm_flags_at(plain.data() + plain.size() / 2);
    ASSERT_FALSE(without.empty()) << no;
    EXPECT_EQ(without.find(" hg"), std::string::npos) << no << ": " << without;
  }
  setenv("PLIANT_HUGE_PAGES", "1", 1);  // anything else: the advice is given
  AlignedVector<float> yes(kHugePage, 1.0f);
  EXPECT_NE(vm_flags_at(yes.data() + yes.size() / 2).find(" hg"), std::string::npos);
  unsetenv("PLIANT_HUGE_PAGES");
}
#endif

}  // namespace
}  // namespace pliant
