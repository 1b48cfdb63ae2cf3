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

#if defined(__SANITIZE_THREAD__)
#define PLIANT_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define PLIANT_TSAN 1
#endif
#endif
#ifdef PLIANT_TSAN
#include <sanitizer/tsan_interface.h>
#endif

namespace pliant {
namespace {

// What TBB guarantees, told to ThreadSanitizer (scripts/sanitize.sh tsan). Debian's libtbb is not
// built with -fsanitize=thread: a parallel_for forks and joins inside it, where TSan cannot see,
// so every result a worker wrote and the caller read after the loop (and every input the caller
// wrote before it) was reported as a race. Fork: the caller's writes happen before every chunk;
// join: every chunk happens before the caller goes on. Two addresses, so that one chunk's end is
// not made to happen before another chunk's start (a race between chunks is still reported).
// Compiled to nothing without TSan.
struct LoopSync {
#ifdef PLIANT_TSAN
  char forked = 0, joined = 0;
  void fork() { __tsan_release(&forked); }
  void chunk_begin() { __tsan_acquire(&forked); }
  void chunk_end() { __tsan_release(&joined); }
  void join() { __tsan_acquire(&joined); }
#else
  void fork() {}
  void chunk_begin() {}
  void chunk_end() {}
  void join() {}
#endif
};

}  // namespace

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
  LoopSync sync;
  sync.fork();
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sync.chunk_begin();
                        fn(ctx, Range{r.begin(), r.end()});
                        sync.chunk_end();
                      },
                      tbb::simple_partitioner());
  });
  sync.join();
}

bool Executor::run_all(std::size_t n, std::size_t grain, PredFn fn, const void* ctx) {
  if (n == 0) return true;
  grain = std::max<std::size_t>(grain, 1);
  if (!arena_ || n <= grain) return fn(ctx, Range{0, n});
  std::atomic<bool> all{true};
  LoopSync sync;
  sync.fork();
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sync.chunk_begin();
                        if (!fn(ctx, Range{r.begin(), r.end()})) all.store(false, std::memory_order_relaxed);
                        sync.chunk_end();
                      },
                      tbb::simple_partitioner());
  });
  sync.join();
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
  LoopSync sync;
  sync.fork();
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks_.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sync.chunk_begin();
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          const Chunk& c = chunks_[i];
                          s[c.segment].fn(s[c.segment].ctx, c.range);
                        }
                        sync.chunk_end();
                      },
                      tbb::simple_partitioner());
  });
  sync.join();
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
  LoopSync sync;
  sync.fork();
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks_.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sync.chunk_begin();
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          const Chunk& c = chunks_[i];
                          if (!s[c.segment].fn(s[c.segment].ctx, c.range)) all.store(false, std::memory_order_relaxed);
                        }
                        sync.chunk_end();
                      },
                      tbb::simple_partitioner());
  });
  sync.join();
  return all.load();
}

}  // namespace pliant
