// Runs kernels over index ranges on the number of threads the host chose. The only place that
// touches TBB. Kernels write disjoint outputs, so how TBB splits a range never changes a result.
// No allocation and no virtual call per loop: the body is passed as a function pointer + context.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "pliant/kernels/range.hpp"
#include "pliant/scheduler/region_chooser.hpp"

namespace pliant {

class Executor {
 public:
  // threads <= 0: as many as the process may use (default_threads()). More than that is clamped
  // to it: TBB would not run more at once anyway, and threads() must say what is used.
  explicit Executor(int threads);
  ~Executor();
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  int threads() const { return threads_; }  // the number used (after clamping)

  // Calls body(Range) over [0, n) in chunks of about `grain` items, possibly in parallel.
  template <class Body>
  void parallel_for(std::size_t n, std::size_t grain, const Body& body) {
    run(n, grain, [](const void* ctx, Range r) { (*static_cast<const Body*>(ctx))(r); }, &body);
  }

  // Like parallel_for, but each chunk returns a bool; the result is the AND of all of them.
  template <class Body>
  bool parallel_all(std::size_t n, std::size_t grain, const Body& body) {
    return run_all(n, grain, [](const void* ctx, Range r) { return (*static_cast<const Body*>(ctx))(r); },
                   &body);
  }

  // Several loops in one parallel region: segment i calls fn(ctx, Range) over [0, n) in chunks of
  // about `grain` items. The segments must write disjoint outputs (they may run at once). One
  // fork-join for all of them, instead of one per loop: how the passes due on one tick run.
  struct Segment {
    std::size_t n = 0, grain = 1;
    void (*fn)(const void*, Range) = nullptr;
    const void* ctx = nullptr;
  };
  void run_segments(const Segment* segments, std::size_t count);
  // The same with a bool per chunk; the result is the AND of all of them.
  struct PredicateSegment {
    std::size_t n = 0, grain = 1;
    bool (*fn)(const void*, Range) = nullptr;
    const void* ctx = nullptr;
  };
  bool run_segments_all(const PredicateSegment* segments, std::size_t count);

  // A tick as one parallel region: the phases run in order, the segments of one phase at once
  // (they must write disjoint outputs), and every chunk of phase p has ended, on every thread,
  // before a chunk of phase p+1 begins (its writes are then visible). Between phases the
  // threads stay in the region and wait at a barrier instead of joining and forking again: one
  // fork-join per tick instead of one per pass, which is what makes 2 threads pay on small
  // bodies (1k-4k tets, tens of us per tick). Segment i of a phase is cut into chunks of
  // `grain` items as in run_segments; which thread runs which chunk does not matter (disjoint
  // outputs), so results are the same bits for any thread count; each thread takes its own
  // block of every phase first (the s-th of T), so that chunk k of one phase and chunk k of the
  // next, which mostly share data, run on the same core. Returns the AND of every
  // predicate chunk (true if there is none). No allocation once the scratch has grown to the
  // largest tick, no lock, no throw, no virtual call.
  struct Phase {
    const Segment* segments = nullptr;
    std::size_t segment_count = 0;
    const PredicateSegment* predicates = nullptr;
    std::size_t predicate_count = 0;
  };
  bool run_phases(const Phase* phases, std::size_t count);
  // Sizes run_phases' scratch for regions of up to `chunks` chunks in `phases` phases, so that
  // none of them allocates (the caller knows its largest tick: Simulation sizes it after each
  // prepare, tests/core/test_hot_path_allocations.cpp). Never shrinks.
  void reserve_region(std::size_t chunks, std::size_t phases);
  // Which regions run on the calling thread alone. From kRegionSerialBelow items (tets + nodes +
  // ghosts ... in all the phases) on, a region runs on every thread; below it, by default, each
  // size of region is timed both ways on this machine and runs the faster way (RegionChooser,
  // region_chooser.hpp: a 1,152-tet box stepped 1.6x faster on 2 threads than on 1 on a 2-vCPU AMD
  // EPYC, 1.2x slower on a 2-vCPU Xeon). The choice never changes a result.
  // set_region_serial_below(n) replaces both by a fixed threshold: below n items on the caller,
  // from n on in parallel (0: every region with two chunks or more in parallel; tests use it to
  // run the parallel path on small problems). kRegionSerialBelow was that fixed threshold until
  // 2026-11-28, measured on a quiet 2-vCPU Xeon (docs/performance.md, "Small bodies": with the
  // region parallel from 1,024 items, a 1,152-tet box, about 1,500 items, stepped in 20.6 us on 2
  // threads against 16.9 on 1; a 2,016-tet box in 25.8 against 29.2).
  static constexpr std::size_t kRegionSerialBelow = 2048;
  static_assert(RegionChooser::kAlwaysParallelFrom == kRegionSerialBelow);
  void set_region_serial_below(std::size_t items) {
    region_serial_below_ = items;
    region_threshold_fixed_ = true;
  }
  // Whether a region of `items` items would run in parallel now (for reports and tests).
  bool region_runs_parallel(std::size_t items) const {
    if (!arena_) return false;
    return region_threshold_fixed_ ? items >= region_serial_below_ : region_chooser_.parallel(items);
  }

  // Calls fn(ctx) on this executor's threads, isolated: TBB loops that fn runs (a library using
  // TBB, such as Embree's BVH commit) use at most threads() threads and never pick up other work.
  void run_isolated(void (*fn)(void*), void* ctx);

  // The cores this process may use (TBB's default concurrency: the CPU affinity mask, cgroups).
  static int default_threads();

 private:
  using Fn = void (*)(const void*, Range);
  using PredFn = bool (*)(const void*, Range);
  void run(std::size_t n, std::size_t grain, Fn fn, const void* ctx);
  bool run_all(std::size_t n, std::size_t grain, PredFn fn, const void* ctx);

  struct Chunk {
    std::uint32_t segment;
    Range range;
  };
  std::vector<Chunk> chunks_;  // scratch of run_segments: grows to the largest tick, then stays
  std::size_t total_ = 0;      // items in chunks_
  // Below this many items in all, the segments run on the calling thread: waking the other
  // threads costs more than the work (as kSerialBelow for single loops, pliant/level_passes.hpp).
  static constexpr std::size_t kSerialTotal = 2048;
  void split(std::size_t count, std::size_t (*n)(const void*, std::size_t), std::size_t (*grain)(const void*, std::size_t),
             const void* segments);

  // Scratch of run_phases: every chunk of every phase in order, and where each phase ends.
  struct RegionChunk {
    void (*fn)(const void*, Range);  // a Segment's, or null
    bool (*pred)(const void*, Range);  // a PredicateSegment's, or null
    const void* ctx;
    Range range;
  };
  std::vector<RegionChunk> region_chunks_;
  bool run_region_serial();    // region_chunks_ in order on the caller
  bool run_region_parallel();  // region_chunks_ on every thread, phase by phase
  std::vector<std::uint32_t> phase_end_;  // one past each phase's last chunk in region_chunks_
  std::size_t region_serial_below_ = kRegionSerialBelow;  // with region_threshold_fixed_
  bool region_threshold_fixed_ = false;
  RegionChooser region_chooser_;

  struct Arena;
  int threads_ = 1;
  std::unique_ptr<Arena> arena_;  // null when single-threaded: loops run inline
  std::unique_ptr<Arena> serial_arena_;  // one thread, made by run_isolated when arena_ is null
};

}  // namespace pliant
