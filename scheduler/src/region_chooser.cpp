// RegionChooser: serial or parallel small regions, by timing both (region_chooser.hpp).
#include "pliant/scheduler/region_chooser.hpp"

#include <algorithm>

namespace pliant {

namespace {

float median(std::array<float, RegionChooser::kTrials> v) {
  std::sort(v.begin(), v.end());
  return 0.5f * (v[RegionChooser::kTrials / 2 - 1] + v[RegionChooser::kTrials / 2]);
}

}  // namespace

int RegionChooser::size_class(std::size_t items) {
  int k = 0;
  while (k + 1 < kClasses && (std::size_t(2) << k) <= items) ++k;
  return k;  // items in [2^k, 2^(k+1)), 0 and 1 in class 0
}

bool RegionChooser::exploring(std::size_t items) const {
  return items < kAlwaysParallelFrom && !classes_[size_class(items)].explored;
}

bool RegionChooser::parallel(std::size_t items) const {
  if (items >= kAlwaysParallelFrom) return true;
  const SizeClass& c = classes_[size_class(items)];
  if (c.explored) return c.choice;
  return c.serial_runs == kWarmup + kTrials;  // a block of serial trials, then a block of parallel ones
}

void RegionChooser::record(std::size_t items, bool parallel, double seconds) {
  if (items >= kAlwaysParallelFrom) return;
  SizeClass& c = classes_[size_class(items)];
  if (c.explored) {
    if (++c.since >= (c.decisions == 1 ? kFirstRecheck : kRecheckEvery)) {  // explore again
      c.explored = false;
      c.serial_runs = c.parallel_runs = 0;
    }
    return;
  }
  const float per_item = float(seconds / double(std::max<std::size_t>(items, 1)));
  int& runs = parallel ? c.parallel_runs : c.serial_runs;
  if (runs >= kWarmup && runs < kWarmup + kTrials) (parallel ? c.parallel : c.serial)[std::size_t(runs - kWarmup)] = per_item;
  ++runs;
  if (c.serial_runs >= kWarmup + kTrials && c.parallel_runs >= kWarmup + kTrials) {
    c.choice = median(c.parallel) < float(kParallelMargin) * median(c.serial);
    c.explored = true;
    ++c.decisions;
    c.since = 0;
  }
}

}  // namespace pliant
