// TBB behind Executor: a task_arena capped at the host's thread count; static partitioning
// (equal chunks, no stealing overhead) since kernel costs per item are uniform.
#include "pliant/scheduler/executor.hpp"

#include <algorithm>
#include <atomic>

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

namespace pliant {

struct Executor::Arena {
  explicit Arena(int n) : arena(n) {}
  tbb::task_arena arena;
};

int Executor::default_threads() { return std::max(1, tbb::info::default_concurrency()); }

Executor::Executor(int threads) {
  const int cores = default_threads();
  threads_ = threads <= 0 ? cores : std::min(threads, cores);
  if (threads_ > 1) arena_ = std::make_unique<Arena>(threads_);
}

Executor::~Executor() = default;

void Executor::run_isolated(void (*fn)(void*), void* ctx) {
  // A library that runs its own TBB loops (Embree's BVH commit) runs them here: on this
  // executor's threads, and isolated so that no task of ours is stolen into the middle of it.
  // Single-threaded executors get a one-thread arena on first use (a library's loops would
  // otherwise run on every core of the process).
  if (!arena_) {
    if (!serial_arena_) serial_arena_ = std::make_unique<Arena>(1);
    serial_arena_->arena.execute([&] { tbb::this_task_arena::isolate([&] { fn(ctx); }); });
    return;
  }
  arena_->arena.execute([&] { tbb::this_task_arena::isolate([&] { fn(ctx); }); });
}

void Executor::run(std::size_t n, std::size_t grain, Fn fn, const void* ctx) {
  if (n == 0) return;
  grain = std::max<std::size_t>(grain, 1);
  if (!arena_ || n <= grain) {
    fn(ctx, Range{0, n});
    return;
  }
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { fn(ctx, Range{r.begin(), r.end()}); },
                      tbb::simple_partitioner());
  });
}

bool Executor::run_all(std::size_t n, std::size_t grain, PredFn fn, const void* ctx) {
  if (n == 0) return true;
  grain = std::max<std::size_t>(grain, 1);
  if (!arena_ || n <= grain) return fn(ctx, Range{0, n});
  std::atomic<bool> all{true};
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        if (!fn(ctx, Range{r.begin(), r.end()})) all.store(false, std::memory_order_relaxed);
                      },
                      tbb::simple_partitioner());
  });
  return all.load();
}

void Executor::split(std::size_t count, std::size_t (*n_of)(const void*, std::size_t),
                     std::size_t (*grain_of)(const void*, std::size_t), const void* segments) {
  chunks_.clear();
  total_ = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t n = n_of(segments, i), grain = std::max<std::size_t>(grain_of(segments, i), 1);
    total_ += n;
    for (std::size_t b = 0; b < n; b += grain) chunks_.push_back({std::uint32_t(i), Range{b, std::min(n, b + grain)}});
  }
}

void Executor::run_segments(const Segment* s, std::size_t count) {
  split(count, [](const void* p, std::size_t i) { return static_cast<const Segment*>(p)[i].n; },
        [](const void* p, std::size_t i) { return static_cast<const Segment*>(p)[i].grain; }, s);
  if (chunks_.empty()) return;
  if (!arena_ || chunks_.size() == 1 || total_ < kSerialTotal) {
    for (const Chunk& c : chunks_) s[c.segment].fn(s[c.segment].ctx, c.range);
    return;
  }
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks_.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          const Chunk& c = chunks_[i];
                          s[c.segment].fn(s[c.segment].ctx, c.range);
                        }
                      },
                      tbb::simple_partitioner());
  });
}

bool Executor::run_segments_all(const PredicateSegment* s, std::size_t count) {
  split(count, [](const void* p, std::size_t i) { return static_cast<const PredicateSegment*>(p)[i].n; },
        [](const void* p, std::size_t i) { return static_cast<const PredicateSegment*>(p)[i].grain; }, s);
  if (chunks_.empty()) return true;
  if (!arena_ || chunks_.size() == 1 || total_ < kSerialTotal) {
    bool all = true;
    for (const Chunk& c : chunks_) all &= s[c.segment].fn(s[c.segment].ctx, c.range);
    return all;
  }
  std::atomic<bool> all{true};
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks_.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          const Chunk& c = chunks_[i];
                          if (!s[c.segment].fn(s[c.segment].ctx, c.range)) all.store(false, std::memory_order_relaxed);
                        }
                      },
                      tbb::simple_partitioner());
  });
  return all.load();
}

}  // namespace pliant
