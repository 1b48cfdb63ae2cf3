// plan_tick and level_period (level_schedule.hpp).
#include "pliant/scheduler/level_schedule.hpp"

namespace pliant {

void plan_tick(std::span<const LevelJob> jobs, ScheduleKind kind, std::int64_t tick, std::span<LevelDue> due) {
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const std::int64_t p = jobs[j].period < 1 ? 1 : jobs[j].period;
    const std::int64_t s = tick % p;  // tick within the window
    const std::size_t n = jobs[j].items;
    LevelDue d;
    d.window_start = s == 0;
    d.window_end = s == p - 1;
    if (kind == ScheduleKind::staggered) {
      // Slice s of p: [s n / p, (s+1) n / p), sizes differing by at most one.
      d.begin = std::size_t((unsigned __int128)n * std::uint64_t(s) / std::uint64_t(p));
      d.end = std::size_t((unsigned __int128)n * std::uint64_t(s + 1) / std::uint64_t(p));
    } else if (d.window_end) {
      d.begin = 0;
      d.end = n;
    }
    due[j] = d;
  }
}

int level_period(double stable_dt, double tick_dt) {
  int p = 1;
  // (1 + 1e-12): a tick chosen as stable_dt / p must give p, whatever the rounding of the product.
  while (p < (1 << 20) && 2.0 * p * tick_dt <= stable_dt * (1 + 1e-12)) p *= 2;
  return p;
}

}  // namespace pliant
