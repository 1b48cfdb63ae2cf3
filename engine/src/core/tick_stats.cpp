// TickStats (pliant/tick_stats.hpp).
#include "pliant/tick_stats.hpp"

#include <algorithm>
#include <cmath>

namespace pliant {

void TickStats::add(double seconds, std::size_t tets) {
  ++ticks_;
  tets_ += double(tets);
  tets_max_ = std::max(tets_max_, tets);
  seconds_ += seconds;
  max_s_ = std::max(max_s_, seconds);
  const double b = seconds > kFirst ? std::log(seconds / kFirst) / std::log(kGrowth) : 0.0;
  ++bins_[std::size_t(std::clamp(b, 0.0, double(kBins - 1)))];
}

double TickStats::quantile_s(double q) const {
  if (ticks_ == 0) return 0;
  const double target = std::ceil(std::clamp(q, 0.0, 1.0) * double(ticks_));
  double seen = 0;
  for (int i = 0; i < kBins; ++i) {
    seen += double(bins_[std::size_t(i)]);
    if (seen >= target) return std::min(max_s_, kFirst * std::pow(kGrowth, i + 1));
  }
  return max_s_;
}

}  // namespace pliant
