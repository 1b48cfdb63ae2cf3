// Whether a small parallel region (Executor::run_phases) runs on the calling thread alone or on
// every thread of the executor, chosen by timing both on this machine as the simulation runs.
//
// Why measured and not a constant: what a second thread costs (waking it, the waits at the phase
// boundaries, the cache lines the two halves of a body share) differs by an order of magnitude
// between machines. A 1,152-tet box stepped on 2 threads in 20.6 us against 16.9 on 1 on a 2-vCPU
// Intel Xeon (docs/performance.md, "Small bodies"), but in 13.1-13.5 against 20.9-21.6 on a
// 2-vCPU AMD EPYC (Zen 3, 2026-11-28): no fixed threshold suits both. The choice never changes a
// result: the chunks of a region write disjoint outputs, so which thread runs them does not
// matter (the same state hashes on 1, 2 and 4 threads: the Determinism tests of
// tests/core/test_world.cpp).
//
// How: regions are grouped by size (items in [2^k, 2^(k+1))). Each size class first runs a block
// of regions on the caller and a block on every thread (in blocks: a second thread left asleep by
// serial regions would make every alternate parallel trial pay its wake-up), the first kWarmup of
// each block untimed, the next kTrials timed; it then takes the arm whose median time per item is
// lower (the parallel arm must win by kParallelMargin: a tie leaves the other core free). It
// explores again kFirstRecheck regions later (the first exploration falls in a body's first steps,
// with the second thread just created and its caches cold: a 1,152-tet box measured 17 ns per
// item in parallel there against 11 serial, and 7 against 11 once warm), then every kRecheckEvery
// regions of that class, so that it follows a machine whose load changes. Only exploring regions
// read the clock. From kAlwaysParallelFrom items on, regions always run in parallel, as they did
// before the choice was timed: every machine measured gains there, and an exploration's block of
// serial regions, 10 of every 4,096, would show in the step p99 of bodies whose step is all
// parallel (a 2k-tet box: 38 -> 45 us on 2 threads when 2,048 to 16,383 items were timed too).
// Not thread-safe: one caller at a time, as run_phases. No allocation, no lock.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>

namespace pliant {

class RegionChooser {
 public:
  static constexpr std::size_t kAlwaysParallelFrom = 2048;   // items (Executor::kRegionSerialBelow)
  static constexpr int kWarmup = 2;                           // untimed regions at the start of a block
  static constexpr int kTrials = 8;                           // timed regions per arm and exploration
  static constexpr std::uint32_t kFirstRecheck = 256;         // regions of a class after its first decision
  static constexpr std::uint32_t kRecheckEvery = 4096;        // regions of a class between later explorations
  static constexpr double kParallelMargin = 0.95;             // parallel only if its median is below 0.95 x serial

  // Whether a region of `items` items runs in parallel now (exploring or chosen).
  bool parallel(std::size_t items) const;
  // Whether the region about to run should be timed and passed to record().
  bool exploring(std::size_t items) const;
  // The wall time of a region run as parallel(items) said.
  void record(std::size_t items, bool parallel, double seconds);
  // The choice of the size class of `items` once explored (false before: serial is the default).
  bool chosen_parallel(std::size_t items) const { return classes_[size_class(items)].choice; }

 private:
  struct SizeClass {
    std::array<float, kTrials> serial{}, parallel{};  // s per item
    int serial_runs = 0, parallel_runs = 0;  // regions of this exploration, warm-up included
    bool choice = false;       // the decision of the last exploration
    bool explored = false;     // a decision exists and holds
    std::uint32_t decisions = 0;
    std::uint32_t since = 0;   // regions run since the last decision
  };
  static constexpr int kClasses = 11;  // 2^11 = kAlwaysParallelFrom
  static int size_class(std::size_t items);
  std::array<SizeClass, kClasses> classes_{};
};

}  // namespace pliant
