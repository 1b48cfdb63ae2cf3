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

}  // namespace pliant
