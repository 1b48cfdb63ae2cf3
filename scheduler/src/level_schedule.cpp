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
      // Slice s of p: [c(s), c(s+1)) with c(s) = s n / p rounded down to a multiple of align
      // (c(p) = n): sizes differing by at most align (one, for align 1).
      const std::size_t a = jobs[j].align < 1 ? 1 : jobs[j].align;
      auto cut = [&](std::int64_t k) {
        if (k >= p) return n;
        const auto c = std::size_t((unsigned __int128)n * std::uint64_t(k) / std::uint64_t(p));
        return c / a * a;
      };
      d.begin = cut(s);
      d.end = cut(s + 1);
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
