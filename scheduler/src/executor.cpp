// TBB behind Executor: a task_arena capped at the host's thread count; static partitioning
// (equal chunks, no stealing overhead) since kernel costs per item are uniform.
#include "pliant/scheduler/executor.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

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

// One spin of a waiting loop: tells the core (and its hyper-thread twin) that we are spinning.
inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// Spins of ~40 ns (a pause is ~140 cycles on Skylake-X and later) before a waiting thread yields
// its core: about 40 us, longer than any chunk of a tick (1-10 us) so that a phase boundary is
// crossed without a system call, short enough that a thread waiting on one descheduled by the OS
// (a shared machine) gives its core back.
constexpr int kSpinsBeforeYield = 1024;

}  // namespace

// The barrier of run_phases. Not a sense-reversing barrier over a fixed team: TBB does not
// promise that a parallel_for of `threads` iterations runs them at once (a worker may be asleep,
// or busy in another arena), and a barrier that waits for a thread that never comes deadlocks.
// Instead every chunk has a claim flag, and each thread that enters the region (slot s of T, in
// order of arrival) walks the phases in order: in each it claims first its own block of the
// phase's chunks (the s-th of T equal blocks), then any chunk of the phase still unclaimed, so
// that it leaves a phase only when every chunk of it is claimed. A chunk of phase p waits, once
// claimed, until the count of ended chunks (`done`) reaches the end of phase p-1. Every chunk
// of an earlier phase was then claimed by a thread that runs it without waiting for anything
// later, so the wait always ends; a thread that arrives late finds less to do, and one that
// never arrives leaves all the work to the others. done >= end(p-1) implies that every chunk
// below end(p-1) ended: chunks of later phases wait for that count before they run, so they
// cannot be counted before it is reached. The release increments of `done` and the acquire
// load that sees the end of a phase order every write of that phase before the next one (TSan
// sees these atomics). Each counter on its own cache line: the claims of one thread do not
// disturb the other's wait.
//
// Why own blocks (chunks were claimed from one shared counter, in order, until 2026-11-25): the
// passes of a tick hand data on from phase to phase (positions packed by node, corner forces
// written by tet, gathered by node), and meshes are numbered for locality, so chunk k of one
// phase mostly reads what chunk k of the phase before wrote; with a shared counter, which thread
// got chunk k changed from phase to phase and tick to tick. Measured (docs/performance.md, "Small
// bodies: the deformation monitor and chunk ownership", 2 threads, step p50): the default scene
// 55.0 -> 50.8 us, multires_organ 34.8 -> 32.2, a 2k-tet box 26.9 -> 25.8, but a 4k-tet box
// 36.9 -> 39.7 (not understood). The gather still costs each thread about as long as the whole
// gather on 1 thread. Which thread runs which chunk never changes a result (disjoint outputs).
struct RegionCounters {
  alignas(64) std::atomic<std::uint32_t> slots{0};
  alignas(64) std::atomic<std::uint32_t> done{0};
  alignas(64) std::atomic<bool> all{true};
};

struct Executor::Arena {
  explicit Arena(int n) : arena(n) {}
  tbb::task_arena arena;
  RegionCounters region;
  // One claim flag per chunk of the region (run_phases): grows to the largest tick, then stays.
  std::unique_ptr<std::atomic<std::uint8_t>[]> claimed;
  std::size_t claimed_capacity = 0;
};

namespace {

// Waits until `done` reaches `need` (acquire: the writes of the chunks counted are visible after).
void wait_until(const std::atomic<std::uint32_t>& done, std::uint32_t need) {
  for (int spin = 0; done.load(std::memory_order_acquire) < need; ++spin) {
    if (spin < kSpinsBeforeYield) {
      cpu_relax();
    } else {
      std::this_thread::yield();
    }
  }
}

}  // namespace

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

bool Executor::run_phases(const Phase* phases, std::size_t count) {
  region_chunks_.clear();
  phase_end_.clear();
  std::size_t items = 0;
  for (std::size_t p = 0; p < count; ++p) {
    const Phase& ph = phases[p];
    for (std::size_t i = 0; i < ph.segment_count; ++i) {
      const Segment& sg = ph.segments[i];
      const std::size_t grain = std::max<std::size_t>(sg.grain, 1);
      items += sg.n;
      for (std::size_t b = 0; b < sg.n; b += grain)
        region_chunks_.push_back({sg.fn, nullptr, sg.ctx, Range{b, std::min(sg.n, b + grain)}});
    }
    for (std::size_t i = 0; i < ph.predicate_count; ++i) {
      const PredicateSegment& sg = ph.predicates[i];
      const std::size_t grain = std::max<std::size_t>(sg.grain, 1);
      items += sg.n;
      for (std::size_t b = 0; b < sg.n; b += grain)
        region_chunks_.push_back({nullptr, sg.fn, sg.ctx, Range{b, std::min(sg.n, b + grain)}});
    }
    // Empty phases are dropped: they would only add a wait.
    if (phase_end_.empty() ? !region_chunks_.empty() : region_chunks_.size() > phase_end_.back())
      phase_end_.push_back(std::uint32_t(region_chunks_.size()));
  }
  if (region_chunks_.empty()) return true;
  if (!arena_ || region_chunks_.size() == 1) return run_region_serial();
  if (region_threshold_fixed_) return items < region_serial_below_ ? run_region_serial() : run_region_parallel();
  // Chosen by timing both ways (RegionChooser); only regions that explore read the clock.
  const bool parallel = region_chooser_.parallel(items);
  if (!region_chooser_.exploring(items)) {
    region_chooser_.record(items, parallel, 0);
    return parallel ? run_region_parallel() : run_region_serial();
  }
  const auto start = std::chrono::steady_clock::now();
  const bool all = parallel ? run_region_parallel() : run_region_serial();
  region_chooser_.record(items, parallel, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return all;
}

void Executor::reserve_region(std::size_t chunks, std::size_t phases) {
  region_chunks_.reserve(chunks);
  phase_end_.reserve(phases);
  if (arena_ && arena_->claimed_capacity < chunks) {
    arena_->claimed = std::make_unique<std::atomic<std::uint8_t>[]>(chunks);
    arena_->claimed_capacity = chunks;
  }
}

bool Executor::run_region_serial() {
  bool all = true;
  for (const RegionChunk& c : region_chunks_) {
    if (c.pred) {
      all &= c.pred(c.ctx, c.range);
    } else {
      c.fn(c.ctx, c.range);
    }
  }
  return all;
}

bool Executor::run_region_parallel() {
  // One TBB fork-join for the whole region: arena.execute + a parallel_for of one iteration per
  // thread, each running work_region until no chunk is left. TBB rather than threads of our own:
  // its workers are already there (parallel_for and Embree's commits use them), a second pool
  // would compete with them for the same 2 cores, and its join tells us when every thread has
  // left the region (after which the counters and the scratch can be reused by the next tick).
  // An iteration that starts after the others took every chunk returns at once.
  RegionCounters& g = arena_->region;
  g.slots.store(0, std::memory_order_relaxed);
  g.done.store(0, std::memory_order_relaxed);
  g.all.store(true, std::memory_order_relaxed);
  const auto total = std::uint32_t(region_chunks_.size());
  if (arena_->claimed_capacity < total) {  // grows to the largest tick, then stays
    arena_->claimed = std::make_unique<std::atomic<std::uint8_t>[]>(total);
    arena_->claimed_capacity = total;
  }
  std::atomic<std::uint8_t>* claimed = arena_->claimed.get();
  for (std::uint32_t i = 0; i < total; ++i) claimed[i].store(0, std::memory_order_relaxed);
  const RegionChunk* chunks = region_chunks_.data();
  const std::uint32_t* ends = phase_end_.data();
  const std::size_t phase_count = phase_end_.size();
  const auto team = std::uint32_t(threads_);
  // What every thread of the region runs (the caller's included): phase by phase, its own block
  // of chunks, then what is left of the phase (see RegionCounters).
  const auto work_region = [&] {
    const std::uint32_t slot = std::min(g.slots.fetch_add(1, std::memory_order_relaxed), team - 1);
    bool all = true;
    for (std::size_t p = 0; p < phase_count; ++p) {
      const std::uint32_t b = p > 0 ? ends[p - 1] : 0, e = ends[p], n = e - b;
      const std::uint32_t own_b = b + std::uint32_t(std::uint64_t(n) * slot / team);
      const std::uint32_t own_e = b + std::uint32_t(std::uint64_t(n) * (slot + 1) / team);
      const auto run = [&](std::uint32_t i) {
        if (claimed[i].load(std::memory_order_relaxed) || claimed[i].exchange(1, std::memory_order_relaxed)) return;
        if (p > 0) wait_until(g.done, b);
        const RegionChunk& c = chunks[i];
        if (c.pred) {
          all &= c.pred(c.ctx, c.range);
        } else {
          c.fn(c.ctx, c.range);
        }
        g.done.fetch_add(1, std::memory_order_release);
      };
      for (std::uint32_t i = own_b; i < own_e; ++i) run(i);
      for (std::uint32_t i = own_e; i < e; ++i) run(i);
      for (std::uint32_t i = b; i < own_b; ++i) run(i);
    }
    if (!all) g.all.store(false, std::memory_order_relaxed);
  };
  LoopSync sync;
  sync.fork();
  // The same blocked_range and partitioner as the other loops here: TBB's own bookkeeping of
  // them is what tests/tsan-suppressions.txt names (libtbb is not built for TSan).
  arena_->arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, std::size_t(threads_), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sync.chunk_begin();
                        for (std::size_t i = r.begin(); i < r.end(); ++i) work_region();
                        sync.chunk_end();
                      },
                      tbb::simple_partitioner());
  });
  sync.join();
  return g.all.load(std::memory_order_relaxed);
}

}  // namespace pliant
