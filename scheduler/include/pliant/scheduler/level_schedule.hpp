// The level-staggered schedule (thesis ch. 5 §4.3, Fig. 5.6; docs/multiresolution.md): which part
// of each level's work runs on which fine tick. It knows no physics: a job is a level with a period
// (in fine ticks, a power of two) and a cost (its element-pass items, e.g. stepped tets).
//
// A job of period p works in windows of p ticks, aligned on multiples of p (tick 0 starts every
// window): its state is read at the start of a window and it integrates at the end. Staggered:
// its element pass is cut into p slices of nearly equal size, one per tick of the window, so that
// every tick costs about the same (the fine level's pass plus 1/p of each coarser one). Naive: the
// whole pass on the last tick of the window, so every coarse level lands on the same tick and
// those ticks spike. Windows are aligned rather than offset (the ruler sequence) so that a coarser
// level never moves inside a finer level's window: the impulses a level receives are then always
// applied at the positions they were computed at, which keeps linear and angular momentum exact
// (docs/multiresolution.md, "Why aligned windows").
#pragma once
#include <cstddef>
#include <cstdint>
#include <span>

namespace pliant {

enum class ScheduleKind { staggered, naive };

struct LevelJob {
  int period = 1;         // fine ticks per step of the level, a power of two >= 1
  std::size_t items = 0;  // element-pass items (tets) per window
  // Staggered slices begin at multiples of `align` items (the last one ends at `items`): a level
  // stepped from a list takes its tets in batches of vector lanes from the start of its slice, so
  // slices of whole batches leave no lanes empty but the last (an even cut of a 667-tet level over
  // 16 ticks gave slices of 41-42 tets: 3 batches of 16 lanes for 42 tets, 12% of the lanes empty).
  // Slices then differ by up to `align` items instead of one.
  std::size_t align = 1;
};

// What a job does on one tick.
struct LevelDue {
  std::size_t begin = 0, end = 0;  // element items to compute now: [begin, end) of 0 .. items
  bool window_start = false;       // first tick of a window: read the state of other levels now
  bool window_end = false;         // last tick of a window: gather and integrate after the element pass
};

// The plan of tick `tick` (0-based) for each job, into due[j].
void plan_tick(std::span<const LevelJob> jobs, ScheduleKind kind, std::int64_t tick, std::span<LevelDue> due);

// The largest power of two p with p * tick_dt <= stable_dt (at least 1; at most 2^20).
int level_period(double stable_dt, double tick_dt);

}  // namespace pliant
