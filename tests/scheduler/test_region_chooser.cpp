// RegionChooser (region_chooser.hpp): a block of serial trials, a block of parallel ones (each
// with its untimed warm-up), then the arm with the lower median time per item (parallel only by a
// margin), explored again after kFirstRecheck and then every kRecheckEvery regions; large regions
// always parallel; size classes apart. Times are given, not
// measured, so the decisions are exact.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>

#include "pliant/scheduler/region_chooser.hpp"

namespace pliant {
namespace {

// Runs one exploration of the class of `items` with the given wall times (s) per region, and
// returns how many of its regions ran in parallel.
int explore(RegionChooser& c, std::size_t items, double serial_s, double parallel_s) {
  int parallel_runs = 0;
  constexpr int kBlock = RegionChooser::kWarmup + RegionChooser::kTrials;
  for (int i = 0; i < 2 * kBlock; ++i) {
    EXPECT_TRUE(c.exploring(items)) << i;
    const bool p = c.parallel(items);
    EXPECT_EQ(p, i >= kBlock) << "a block of serial trials, then a block of parallel ones: " << i;
    parallel_runs += p;
    c.record(items, p, p ? parallel_s : serial_s);
  }
  EXPECT_FALSE(c.exploring(items));
  return parallel_runs;
}

// Runs decided regions of the class of `items` until it explores again; returns how many ran.
std::uint32_t regions_until_exploring(RegionChooser& c, std::size_t items) {
  std::uint32_t n = 0;
  while (!c.exploring(items) && n < 10 * RegionChooser::kRecheckEvery) {
    c.record(items, c.parallel(items), 0);
    ++n;
  }
  return n;
}

TEST(RegionChooser, TriesEachWayInABlockThenKeepsTheFaster) {
  RegionChooser c;
  EXPECT_FALSE(c.parallel(1500));  // the first block is serial
  EXPECT_EQ(explore(c, 1500, 20e-6, 13e-6), RegionChooser::kWarmup + RegionChooser::kTrials);
  EXPECT_TRUE(c.chosen_parallel(1500));
  EXPECT_TRUE(c.parallel(1500));
  // Serial faster: serial.
  RegionChooser d;
  EXPECT_EQ(explore(d, 1500, 17e-6, 20e-6), RegionChooser::kWarmup + RegionChooser::kTrials);
  EXPECT_FALSE(d.parallel(1500));
}

TEST(RegionChooser, ParallelMustWinByTheMargin) {
  RegionChooser c;
  explore(c, 1800, 10e-6, 9.7e-6);  // 3 % faster in parallel: not enough, the other core stays free
  EXPECT_FALSE(c.parallel(1800));
  RegionChooser d;
  explore(d, 1800, 10e-6, 9.0e-6);  // 10 % faster
  EXPECT_TRUE(d.parallel(1800));
}

TEST(RegionChooser, TheWarmUpAndTwoSlowTrialsDoNotDecide) {
  // The first regions of each block (a thread just woken or created, cold caches) are not timed,
  // and two parallel trials that waited on a descheduled thread (1 ms) among fast ones are outvoted
  // (timing the warm-ups instead of the last trials would make four of eight slow: serial).
  RegionChooser c;
  const std::size_t items = 2000;
  constexpr int kBlock = RegionChooser::kWarmup + RegionChooser::kTrials;
  for (int i = 0; i < 2 * kBlock; ++i) {
    const bool p = c.parallel(items);
    const int in_block = i % kBlock;
    double s = p ? 12e-6 : 20e-6;
    if (in_block < RegionChooser::kWarmup) s = p ? 5e-3 : 1e-9;  // warm-ups that would decide it, if timed
    if (p && (in_block == RegionChooser::kWarmup || in_block == RegionChooser::kWarmup + 1)) s = 1e-3;
    c.record(items, p, s);
  }
  EXPECT_FALSE(c.exploring(items));
  EXPECT_TRUE(c.parallel(items));
}

TEST(RegionChooser, ExploresAgainSoonAfterTheFirstDecisionThenRarely) {
  RegionChooser c;
  const std::size_t items = 1200;
  // Decided at the start (a body's first steps): parallel looked slow.
  explore(c, items, 20e-6, 30e-6);
  ASSERT_FALSE(c.parallel(items));
  EXPECT_EQ(regions_until_exploring(c, items), RegionChooser::kFirstRecheck);
  // Warm now: parallel is faster, and the choice follows.
  explore(c, items, 20e-6, 12e-6);
  EXPECT_TRUE(c.parallel(items));
  EXPECT_EQ(regions_until_exploring(c, items), RegionChooser::kRecheckEvery);
  // The other core is now busy elsewhere: parallel has become slower.
  explore(c, items, 20e-6, 35e-6);
  EXPECT_FALSE(c.parallel(items));
}

TEST(RegionChooser, SizeClassesDecideApartAndLargeRegionsAreAlwaysParallel) {
  RegionChooser c;
  explore(c, 1000, 10e-6, 20e-6);  // class [512, 1024): serial
  EXPECT_FALSE(c.parallel(1000));
  EXPECT_TRUE(c.exploring(1024));  // the next class has not been explored
  explore(c, 1500, 30e-6, 20e-6);  // class [1024, 2048): parallel
  EXPECT_TRUE(c.parallel(1500));
  EXPECT_FALSE(c.parallel(600));  // same class as 1000
  EXPECT_TRUE(c.parallel(RegionChooser::kAlwaysParallelFrom));
  EXPECT_FALSE(c.exploring(RegionChooser::kAlwaysParallelFrom));
  EXPECT_TRUE(c.parallel(100 * RegionChooser::kAlwaysParallelFrom));
  // Times are compared per item: a class whose regions vary in size is not misled by the sizes.
  RegionChooser d;
  for (int i = 0; i < 2 * (RegionChooser::kWarmup + RegionChooser::kTrials); ++i) {
    const bool p = d.parallel(1100);
    // serial regions of 1,100 items at 10 ns/item, parallel ones of 2,000 items at 7 ns/item
    d.record(p ? 2000 : 1100, p, p ? 2000 * 7e-9 : 1100 * 10e-9);
  }
  EXPECT_TRUE(d.parallel(1100));
}

}  // namespace
}  // namespace pliant
