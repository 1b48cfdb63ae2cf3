// plan_tick (pliant/scheduler/level_schedule.hpp): the staggered slices of each window tile the
// level's items in order, one per tick; with LevelJob::align they begin at multiples of it; naive
// puts the whole pass on the window's last tick.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "pliant/scheduler/level_schedule.hpp"

namespace pliant {
namespace {

TEST(LevelSchedule, StaggeredSlicesTileTheWindowEvenly) {
  const std::vector<LevelJob> jobs{{1, 3863}, {2, 457}, {16, 667}};
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    std::vector<LevelDue> due(jobs.size());
    const std::int64_t p = jobs[j].period;
    std::size_t next = 0, smallest = ~std::size_t(0), largest = 0;
    for (std::int64_t tick = 0; tick < p; ++tick) {
      plan_tick(jobs, ScheduleKind::staggered, tick, due);
      EXPECT_EQ(due[j].begin, next) << "job " << j << " tick " << tick;  // in order, no gap or overlap
      next = due[j].end;
      smallest = std::min(smallest, due[j].end - due[j].begin);
      largest = std::max(largest, due[j].end - due[j].begin);
    }
    EXPECT_EQ(next, jobs[j].items) << "job " << j;
    EXPECT_LE(largest - smallest, 1u) << "job " << j;  // align 1: sizes differ by at most one
  }
}

TEST(LevelSchedule, AlignedSlicesBeginAtMultiplesOfTheAlignment) {
  // A listed level of 667 tets over 16 ticks in batches of 16 lanes: slices of 32 or 48 tets (not
  // 41 or 42), each beginning on a batch, the last ending at 667; a level smaller than one batch
  // per tick leaves ticks empty.
  for (const LevelJob job : {LevelJob{16, 667, 16}, LevelJob{8, 342, 16}, LevelJob{8, 20, 16}, LevelJob{4, 64, 16}}) {
    const std::vector<LevelJob> jobs{{1, 100}, job};
    std::vector<LevelDue> due(jobs.size());
    std::size_t next = 0, largest = 0, partial = 0;
    for (std::int64_t tick = 0; tick < job.period; ++tick) {
      plan_tick(jobs, ScheduleKind::staggered, tick, due);
      const LevelDue& d = due[1];
      EXPECT_EQ(d.begin, next) << job.items << " tick " << tick;
      EXPECT_EQ(d.begin % job.align, 0u) << job.items << " tick " << tick;
      if (d.end < job.items) EXPECT_EQ(d.end % job.align, 0u) << job.items << " tick " << tick;
      partial += (d.end - d.begin) % job.align != 0;
      largest = std::max(largest, d.end - d.begin);
      next = d.end;
      EXPECT_EQ(due[0].end - due[0].begin, 100u);  // the other job as without alignment
    }
    EXPECT_EQ(next, job.items);
    EXPECT_LE(partial, 1u) << job.items;  // only the slice that ends the window may hold a partial batch
    EXPECT_LE(largest, (job.items + std::size_t(job.period) - 1) / std::size_t(job.period) + job.align) << job.items;
  }
  // With align 1 the cut is the even one.
  std::vector<LevelDue> a(1), b(1);
  for (std::int64_t tick = 0; tick < 16; ++tick) {
    plan_tick(std::vector<LevelJob>{{16, 667, 1}}, ScheduleKind::staggered, tick, a);
    plan_tick(std::vector<LevelJob>{{16, 667}}, ScheduleKind::staggered, tick, b);
    EXPECT_EQ(a[0].begin, b[0].begin);
    EXPECT_EQ(a[0].end, b[0].end);
  }
}

TEST(LevelSchedule, NaivePutsTheWholePassOnTheWindowsLastTick) {
  const std::vector<LevelJob> jobs{{8, 342, 16}};
  std::vector<LevelDue> due(1);
  for (std::int64_t tick = 0; tick < 16; ++tick) {
    plan_tick(jobs, ScheduleKind::naive, tick, due);
    const bool last = tick % 8 == 7;
    EXPECT_EQ(due[0].begin, 0u);
    EXPECT_EQ(due[0].end, last ? 342u : 0u) << tick;
  }
}

}  // namespace
}  // namespace pliant
