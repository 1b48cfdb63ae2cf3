// Runs kernels over index ranges on the number of threads the host chose. The only place that
// touches TBB. Kernels write disjoint outputs, so how TBB splits a range never changes a result.
// No allocation and no virtual call per loop: the body is passed as a function pointer + context.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "pliant/kernels/range.hpp"

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

  struct Arena;
  int threads_ = 1;
  std::unique_ptr<Arena> arena_;  // null when single-threaded: loops run inline
  std::unique_ptr<Arena> serial_arena_;  // one thread, made by run_isolated when arena_ is null
};

}  // namespace pliant
