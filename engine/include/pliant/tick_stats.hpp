// Per-tick work and wall time of a World (docs/multiresolution.md, "Flat ticks"): how many tets
// each fine tick computed and how long it took, as a mean, a maximum and percentiles. The times go
// into a histogram of logarithmic bins 2% wide (10 ns .. 100 s), so that recording a tick costs a
// few nanoseconds and no memory however long the run; percentiles are read to within a bin.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>

namespace pliant {

class TickStats {
 public:
  void add(double seconds, std::size_t tets);
  std::int64_t ticks() const { return ticks_; }
  double tet_updates() const { return tets_; }  // tets computed, summed over the ticks
  double tets_mean() const { return ticks_ ? tets_ / double(ticks_) : 0; }
  std::size_t tets_max() const { return tets_max_; }
  double mean_s() const { return ticks_ ? seconds_ / double(ticks_) : 0; }
  double max_s() const { return max_s_; }
  // The q-quantile (0 < q <= 1) of the tick times (s): the upper edge of the bin that holds it,
  // at most max_s().
  double quantile_s(double q) const;

 private:
  static constexpr int kBins = 1200;
  static constexpr double kFirst = 1e-8;   // s, lower edge of bin 0
  static constexpr double kGrowth = 1.02;  // each bin 2% wider than the last
  std::array<std::uint64_t, kBins> bins_{};
  std::int64_t ticks_ = 0;
  double tets_ = 0, seconds_ = 0, max_s_ = 0;
  std::size_t tets_max_ = 0;
};

}  // namespace pliant
